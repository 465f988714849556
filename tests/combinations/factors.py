"""The factors of the combination matrix, read off the real `franka-sim serve` command.

Every option of `serve` is either a factor of the matrix or named in NOT_FACTORS with the
reason; `test_matrix_factors.py` fails on an option that is neither, so a new flag joins the
matrix or is classified on purpose. An on/off switch or an option with a fixed set of choices
joins by itself: its levels are the CLI's own (off and on, or every choice). Options with
free values are mapped by hand below (WORLD_FLAGS, RECORD, INJECT).
"""

from __future__ import annotations

import enum
import typing
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

# Options that are no factor of the matrix, and why. They configure where and how the server
# is reached or logs, or swap the robot for another one; none of them switches a feature whose
# interplay with the others the matrix is for.
NOT_FACTORS = {
    "host": "where the robot is served: every run puts each robot on a fresh loopback address",
    "urdf": "another hand-less FR3 description is another robot, not a feature "
            "(tests/server/test_cli.py serves one)",
    "joint_discontinuity_scale": "a figure that tunes the IK side of Cartesian commands, not "
                                 "a switch; the matrix's arm motions are joint motions",
    "control_port": "the matrix reaches every robot's control API (/health, /push) on its "
                    "default port; moving it is tests/control's subject",
    "control_token": "guards the control API's HTTP requests only; the cycle never sees it "
                     "(tests/control)",
    "rt_priority": "scheduling of the server process only; it needs CAP_SYS_NICE, and "
                   "SCHED_FIFO servers side by side can starve a machine of two cores",
    "log_level": "what is logged, not what is simulated",
    "physics": "the engine: tests/engines runs the same client programs on each; Genesis "
               "serves one arm with the Hand and refuses the other worlds and flags "
               "(docs/engines.md), and needs its extra",
    "no_gripper": "the same as --tool none, which the tool factor covers",
    "strict_versions": "decides which libfranka versions connect, at Connect only: the "
                       "matrix's clients are pylibfranka 0.21 (v10), which a strict Panda "
                       "refuses by design (tests/clients/test_panda_arm.py)",
    "desk_port": "the Desk's HTTPS port: the cycle never sees the web API, only what its calls "
                 "change (the arm held, the FCI's port), which tests/desk drives",
    "desk_boot": "locked refuses every FCI client until a Desk client brings the robot up, "
                 "which a matrix run does not; tests/desk (and the plugin's marker) cover it",
    "desk_user": "who may call the Desk: its HTTPS layer only (tests/desk)",
    "desk_cert": "the Desk's TLS certificate: its HTTPS layer only (tests/desk)",
    "desk_key": "the Desk's TLS key: its HTTPS layer only (tests/desk)",
    "meshes": "what the arms are drawn with (visual geoms that touch and weigh nothing); "
              "tests/web/test_meshes.py builds a world with them",
    "web": "the web view only reads what the cycle hands off (a copy of what it sent, every "
           "30 ms while someone watches) and changes nothing a client sees; tests/web drives "
           "it in a headless browser during motions, benchmarks/web_watchers.py measures the "
           "cycle with watchers",
}

# The world factor stands for these options together: a packaged scene and the robots it holds.
WORLD_FLAGS = ("scene", "arm", "mobile_base")
RECORD = "record"
INJECT = ("inject", "seed")
INJECT_SPEC = ("--inject", "loss=0.01", "--seed", "1")  # lockstep: the same cycles every run


@dataclass(frozen=True)
class World:
    """A world a run serves: its packaged scene (None: the CLI's default, one arm on --host),
    its arms (name, joint-1 turn in rad, away from any neighbour) and whether a mobile base
    carries them."""

    scene: str | None
    arms: tuple[tuple[str, float], ...]
    base: bool = False

    def args(self, where: Site) -> tuple[str, ...]:
        if self.scene is None:
            return ()  # the one arm `serve` makes on --host
        arms = (("--arm", f"{name}={where.addresses[name]}") for name, _ in self.arms)
        base = ("--mobile-base", where.addresses["base"]) if self.base else ()
        return (*(a for pair in arms for a in pair), "--scene", self.scene, *base)


@dataclass(frozen=True)
class Site:
    """Where a run's server lives: its folder (for files) and each robot's address by name
    (the arms' names, and "base")."""

    folder: Path
    addresses: dict[str, str]


# A level for every packaged scene (test_matrix_factors.py checks that none is missing).
WORLDS = {
    "default": World(None, (("fr3", 0.15),)),
    "dual_arm_table": World("dual_arm_table", (("left", 0.15), ("right", -0.15))),
    "mobile_duo": World("mobile_duo", (("left", 0.15), ("right", -0.15)), base=True),
}


@dataclass(frozen=True)
class Factor:
    """A dimension of the matrix: its levels, the `serve` options it stands for, and the
    arguments a level adds to the command line where the run's server lives."""

    name: str
    levels: tuple
    flags: tuple[str, ...]
    args: Callable[[object, Site], tuple[str, ...]]


def serve_options() -> list:
    """The parameters of `franka-sim serve`, as typer hands them to click (name, opts,
    is_flag, default)."""
    import typer.main

    from franka_sim import cli

    return list(typer.main.get_command(cli.app).commands["serve"].params)


def _annotations() -> dict:
    """The Python types of `serve`'s parameters (an Enum: a fixed set of choices)."""
    from franka_sim import cli

    return typing.get_type_hints(cli.serve)


def _switch(param) -> Factor:
    on = param.opts[0]  # the switch's own name; "--no-…" is its secondary when it has one
    return Factor(param.name, (False, True), (param.name,),
                  lambda level, where: (on,) if level else ())


def _choice(param, choices: type[enum.Enum]) -> Factor:
    option = param.opts[0]
    return Factor(param.name, tuple(choice.value for choice in choices), (param.name,),
                  lambda level, where: (option, level))


# Not a flag: a push through the control API in the middle of the motions.
PUSH = Factor("push", (False, True), (), lambda level, where: ())


def factors() -> list[Factor]:
    """The matrix's factors in the order of `serve`'s options (then the push); raises
    Unclassified naming any option that is neither a factor nor in NOT_FACTORS."""
    out, unclassified, types = [], [], _annotations()
    for param in serve_options():
        name = param.name
        if name in NOT_FACTORS or name in WORLD_FLAGS[1:] or name in INJECT[1:]:
            continue
        if name == WORLD_FLAGS[0]:
            out.append(Factor("world", tuple(WORLDS), WORLD_FLAGS,
                              lambda level, where: WORLDS[level].args(where)))
        elif name == RECORD:
            out.append(Factor(name, (False, True), (name,), lambda level, where:
                              ("--record", str(where.folder / "run.mcap")) if level else ()))
        elif name == INJECT[0]:
            out.append(Factor(name, (False, True), INJECT,
                              lambda level, where: INJECT_SPEC if level else ()))
        elif getattr(param, "is_flag", False) and param.default is False:
            out.append(_switch(param))
        elif isinstance(types.get(name), type) and issubclass(types[name], enum.Enum):
            out.append(_choice(param, types[name]))
        else:
            unclassified.append(name)
    if unclassified:
        raise Unclassified(unclassified)
    return [*out, PUSH]


class Unclassified(Exception):
    """`serve` options that are neither a factor of the matrix nor in NOT_FACTORS."""

    def __init__(self, names: list[str]) -> None:
        super().__init__(f"`serve` options neither a factor of the combination matrix nor in "
                         f"NOT_FACTORS (tests/combinations/factors.py): {', '.join(names)}")
        self.names = names

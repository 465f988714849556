"""`franka-sim`: run a simulated FR3 that libfranka clients connect to as if it were the robot."""

from __future__ import annotations

import inspect
import os
import signal
from pathlib import Path

if os.getpid() == 1:  # a container's init: the kernel drops a SIGTERM that has no handler
    signal.signal(signal.SIGTERM, lambda signum, frame: os._exit(0))

import typer  # noqa: E402 - after the handler: importing it takes the first ~0.4 s

from franka_sim import cli_recordings  # noqa: E402
from franka_sim.cli_help import PlainHelpCommand  # noqa: E402
from franka_sim.config import (ROBOTS, ArmSpec, ClockMode, Config, PhysicsEngine, RobotKind,
                               ToolName)


app = typer.Typer(
    help="A simulated Franka FR3 (with Franka Hand) that speaks libfranka's wire protocol.\n\n"
    "Point unmodified libfranka / pylibfranka code at the address it serves "
    "(127.0.0.1 by default) instead of the robot's.",
    no_args_is_help=True,
    add_completion=False,
    # Help is rich markup, where "[word]" is a style: an extra is written `franka-sim\\[plot]`
    # (tests/server/test_cli.py checks that every help text is shown as written).
    rich_markup_mode="rich",
)


def _show_version(asked: bool) -> None:
    if asked:
        import franka_sim

        typer.echo(f"franka-sim {franka_sim.__version__}")
        raise typer.Exit()


@app.callback()
def _root(
    version: bool = typer.Option(False, "--version", is_eager=True, callback=_show_version,
                                 help="Print franka-sim's version and exit."),
) -> None:
    """The sub-commands stay sub-commands (`franka-sim serve`), however many there are."""


@app.command(cls=PlainHelpCommand)
def serve(
    ctx: typer.Context,
    host: str = typer.Option(
        "127.0.0.1", envvar="FRANKA_SIM_HOST",
        help="Address to serve the robot on (TCP 1337 + UDP). Use one loopback address "
        "per simulated robot, e.g. 127.0.0.2.",
    ),
    urdf: Path | None = typer.Option(
        None, envvar="FRANKA_SIM_URDF", exists=True, dir_okay=False,
        help="Serve (and simulate) this hand-less arm URDF instead of the packaged one.",
    ),
    robot: RobotKind = typer.Option(
        RobotKind.fr3, envvar="FRANKA_SIM_ROBOT",
        help="The arm: fr3 (Franka Research 3) or fer (Franka Emika Panda): its description, "
        "limits and the URDF it serves. An --arm may name its own (NAME:fer=ADDRESS).",
    ),
    strict_versions: bool = typer.Option(
        False, "--strict-versions/--any-versions", envvar="FRANKA_SIM_STRICT_VERSIONS",
        help="Refuse a client whose libfranka does not speak the arm's protocols, as that "
        "robot would (a Panda: robot protocol 5 and below; an FR3: 6 and above). Default: "
        "any supported version on either arm.",
    ),
    clock: ClockMode = typer.Option(
        ClockMode.realtime, envvar="FRANKA_SIM_CLOCK",
        help="realtime: one cycle per wall-clock ms. lockstep: while a motion runs, the next "
        "cycle starts as soon as the client answered the last one (waiting up to 100 ms for it), "
        "so runs are as fast as the client and independent of the host's timing.",
    ),
    physics: PhysicsEngine = typer.Option(
        PhysicsEngine.mujoco, envvar="FRANKA_SIM_PHYSICS",
        help="The physics engine: mujoco (default) or genesis (one arm, the Hand or no tool; "
        "needs franka-sim\\[genesis]; docs/engines.md). Clients see the same robot either way.",
    ),
    enforce_comm_constraints: bool = typer.Option(
        False, "--enforce-comm-constraints/--no-enforce-comm-constraints",
        envvar="FRANKA_SIM_ENFORCE_COMM_CONSTRAINTS",
        help="Abort a motion with communication_constraints_violation after 20 consecutive "
        "lost command cycles, as the robot does. Off: losses are only counted and reported.",
    ),
    enforce_motion_limits: bool = typer.Option(
        False, "--enforce-motion-limits/--no-enforce-motion-limits",
        envvar="FRANKA_SIM_ENFORCE_MOTION_LIMITS",
        help="Abort a motion whose commands break the robot's limits (discontinuities, "
        "velocity/acceleration/jerk, range, torque rate), as the robot does. Off: violations "
        "are checked and logged only.",
    ),
    joint_discontinuity_scale: float = typer.Option(
        1.0, envvar="FRANKA_SIM_JOINT_DISCONTINUITY_SCALE", min=1e-6,
        help="Scale of the joint acceleration/jerk limits the joint side of Cartesian commands "
        "(the IK output) is held to.",
    ),
    scene: str | None = typer.Option(
        None, envvar="FRANKA_SIM_SCENE",
        help="A packaged scene's name (default, dual_arm_table, mobile_duo) or an MJCF file "
        "whose bodies (a table, objects) are placed around the arms, named scene/<name>; its sites "
        "arm/NAME say where arm NAME stands. Default: the packaged table with a 5 cm cube.",
    ),
    arm: list[str] = typer.Option(
        [], "--arm", envvar="FRANKA_SIM_ARMS",
        metavar="NAME[:ROBOT][+TOOL]=ADDRESS[@x,y,z[,yaw_deg]]",
        help="An arm of the world, served on its own ADDRESS (FCI, its tool and control API), "
        "its base at x,y,z (m) turned yaw_deg about the vertical (default: the scene's arm/NAME "
        "site, else the origin), of kind ROBOT (default: --robot's), carrying TOOL (default: "
        "--tool's). Repeat for several arms in one world. Default: one arm named fr3 on --host.",
    ),
    mobile_base: str | None = typer.Option(
        None, "--mobile-base", envvar="FRANKA_SIM_MOBILE_BASE", metavar="ADDRESS",
        help="Stand every arm on a mobile base served as a robot of its own on ADDRESS (FCI "
        "and control API; a 'tmr' URDF, driven by Cartesian-velocity motions: "
        "docs/deviations.md). E.g. --scene mobile_duo --arm left=A --arm right=B.",
    ),
    tool: ToolName = typer.Option(
        ToolName.hand, "--tool", envvar="FRANKA_SIM_TOOL",
        help="The tool on every arm's flange (an --arm may name its own) and the service it "
        "answers beside the FCI: hand (the Franka Hand, gripper protocol on TCP 1338, its "
        "fingers in the world), vacuum (the Cobot Pump, vacuum gripper protocol on TCP "
        "1339, a suction cup in the world) or none "
        "(no tool service: its port refuses connections, and the Hand's body is rigid).",
    ),
    no_gripper: bool = typer.Option(
        False, "--no-gripper", envvar="FRANKA_SIM_NO_GRIPPER",
        help="The same as --tool none.",
    ),
    control_port: int = typer.Option(
        1340, envvar="FRANKA_SIM_CONTROL_PORT", min=0, max=65535,
        help="TCP port of the control API (HTTP + JSON: health, ground truth, reset, bodies, "
        "pushes; docs/control_api.md) on the robot's address. 0: not served.",
    ),
    control_token: str | None = typer.Option(
        None, envvar="FRANKA_SIM_CONTROL_TOKEN",
        help="Require this bearer token on every control API request (Authorization: Bearer "
        "TOKEN), for an address others can reach. Default: none.",
    ),
    desk_port: int = typer.Option(
        0, envvar="FRANKA_SIM_DESK_PORT", min=0, max=65535,
        help="HTTPS port of the Desk, the robot's web API (FR3 system 5+ and the older Desk: "
        "control token, brakes, operating mode, FCI; docs/desk.md), on the robot's address; "
        "the robot's is 443. 0 (default): not served.",
    ),
    desk_boot: str = typer.Option(
        "ready", envvar="FRANKA_SIM_DESK_BOOT", metavar="ready|locked",
        help="ready: FCI active, brakes open, Execution (as without a Desk). locked: as after "
        "power-on (brakes locked, Programming, FCI inactive: port 1337 refuses connections "
        "until a Desk client activates it).",
    ),
    desk_user: list[str] = typer.Option(
        [], "--desk-user", envvar="FRANKA_SIM_DESK_USERS", metavar="NAME:PASSWORD",
        help="A Desk user (repeat for several). Default: franka:franka.",
    ),
    desk_cert: Path | None = typer.Option(
        None, envvar="FRANKA_SIM_DESK_CERT", exists=True, dir_okay=False,
        help="The Desk's TLS certificate (PEM), with --desk-key. Default: a self-signed one "
        "made at the first start and kept per user.",
    ),
    desk_key: Path | None = typer.Option(
        None, envvar="FRANKA_SIM_DESK_KEY", exists=True, dir_okay=False,
        help="The private key (PEM) of --desk-cert.",
    ),
    rt_priority: int = typer.Option(
        0, envvar="FRANKA_SIM_RT_PRIORITY", min=0, max=99,
        help="Run the server under SCHED_FIFO at this priority (1-99), as the robot's own "
        "controller runs in real time: states then leave on time even on a busy machine. "
        "Needs root or CAP_SYS_NICE; without, a warning and normal scheduling. 0: normal.",
    ),
    log_level: str = typer.Option(
        "info", envvar="FRANKA_SIM_LOG_LEVEL", help="debug, info, warning or error."
    ),
    record: Path | None = typer.Option(
        None, dir_okay=False,
        help="Record everything the robot and its clients exchange to this MCAP file "
        "(docs/recording.md): `franka-sim replay`, `plot` and `render` read it.",
    ),
    viewer: bool = typer.Option(
        False, "--viewer", help="Show the arm live in MuJoCo's viewer (needs a display).",
    ),
    meshes: Path | None = typer.Option(
        None, envvar="FRANKA_SIM_MESHES", exists=True, file_okay=False, metavar="DIR",
        help="Draw the arms with the visual meshes of the franka_description installed at DIR "
        "(its meshes/ folder; .dae needs pycollada) instead of our own shapes, in the viewer "
        "and the web view (docs/viewing.md). Only what is drawn changes.",
    ),
    web: int = typer.Option(
        0, "--web", envvar="FRANKA_SIM_WEB_PORT", min=0, max=65535, metavar="PORT",
        help="Serve the web view on this port of the first arm's address: the world in 3D and "
        "each arm's live plots in a browser (docs/viewing.md; needs franka-sim\\[web]). "
        "0 (default): not served.",
    ),
    inject: str | None = typer.Option(
        None, envvar="FRANKA_SIM_INJECT", metavar="SPEC",
        help="Network faults on every robot's UDP path (each arm, the mobile base), both "
        "directions unless dir= says one: loss=P, delay=Dms, jitter=Jms (normal, truncated "
        "at 0), burst=N@Ts (N cycles lost from T s of simulated time; may repeat), "
        "reorder=P, dir=states|commands; e.g. "
        "loss=0.02,reorder=0.01 (docs/robustness.md).",
    ),
    seed: int = typer.Option(
        0, envvar="FRANKA_SIM_SEED", min=0, max=2**64 - 1,
        help="Seed of the injected faults: the same seed hits the same cycles.",
    ),
) -> None:
    """Run the simulated robot until Ctrl-C or SIGTERM."""
    from franka_sim.serving import exec_serving

    if log_level.lower() not in ("debug", "info", "warning", "error"):
        raise typer.BadParameter(f"{log_level!r}: not one of debug, info, warning, error",
                                 param_hint="--log-level")
    try:
        arms = tuple(parse_arm(text) for text in arm)
    except ValueError as exc:
        raise typer.BadParameter(str(exc), param_hint="--arm") from None
    # A --host beside --arm serves nothing: said, rather than a robot silently missing from
    # it. (From FRANKA_SIM_HOST it is the image's or the shell's default: taken silently.)
    if arms and getattr(ctx.get_parameter_source("host"), "name", "") == "COMMANDLINE":
        typer.echo(f"franka-sim serve: --host {host} serves nothing beside --arm (each arm "
                   "names its own address)", err=True)
    # What the engine does not serve is said before what is missing for it (config_rules.py
    # refuses --web with another engine).
    if viewer and physics is not PhysicsEngine.mujoco:
        raise typer.BadParameter("MuJoCo's viewer shows the MuJoCo world only",
                                 param_hint="--viewer")
    if viewer:
        from franka_sim.server.viewer import NoDisplay, check_display

        try:
            check_display()
        except NoDisplay as exc:
            typer.echo(f"franka-sim: {exc}", err=True)
            raise typer.Exit(1) from None
    if web and physics is PhysicsEngine.mujoco:
        from franka_sim.web import web_missing

        if missing := web_missing():
            typer.echo(f"franka-sim: --web: {missing}", err=True)
            raise typer.Exit(1)
    from franka_sim.physics.engine_choice import engine_missing

    if missing := engine_missing(physics.value):
        typer.echo(f"franka-sim: {missing}", err=True)  # one line: what to install
        raise typer.Exit(1)
    from franka_sim.config_rules import ConfigError, checked

    try:
        config = checked(Config(
            host=host, urdf=urdf, robot=robot.value, strict_versions=strict_versions, clock=clock,
            physics=physics.value,
            enforce_comm_constraints=enforce_comm_constraints,
            enforce_motion_limits=enforce_motion_limits,
            joint_discontinuity_scale=joint_discontinuity_scale,
            scene=scene, tool=_tool(tool.value, no_gripper), control_port=control_port,
            control_token=control_token, arms=arms, record=record, mobile_base=mobile_base,
            inject=inject, seed=seed, desk_port=desk_port, desk_boot=desk_boot,
            desk_users=tuple(desk_user), desk_cert=desk_cert, desk_key=desk_key,
            web_port=web, meshes=meshes,
        ))
    except ConfigError as exc:
        raise typer.BadParameter(str(exc), param_hint=exc.flag) from None
    exec_serving(config, rt_priority=rt_priority, log_level=log_level, viewer=viewer)


def _tool(tool: str, no_gripper: bool) -> str:
    """--tool, with --no-gripper as `--tool none` (together only if they agree)."""
    if no_gripper:
        if tool not in ("hand", "none"):
            raise typer.BadParameter(f"--no-gripper is --tool none, not --tool {tool}",
                                     param_hint="--no-gripper")
        return "none"
    return tool


def parse_arm(text: str) -> ArmSpec:
    """NAME[:ROBOT][+TOOL]=ADDRESS[@x,y,z[,yaw_deg]] as an ArmSpec (ValueError saying what is
    wrong)."""
    import ipaddress
    import math

    from franka_sim.tools import tool_names

    name, sep, rest = text.partition("=")
    name, plus, tool = name.strip().partition("+")
    name, colon, robot = name.partition(":")
    if not sep or not name or not rest:
        raise ValueError(f"{text!r}: expected NAME[:ROBOT][+TOOL]=ADDRESS[@x,y,z[,yaw_deg]]")
    if colon and robot not in ROBOTS:
        raise ValueError(f"arm {name}: {robot!r} is not a robot ({', '.join(ROBOTS)})")
    if plus and tool not in tool_names():
        raise ValueError(f"arm {name}: {tool!r} is not a tool ({', '.join(tool_names())})")
    robot, tool = robot or None, tool or None
    if "/" in name or not name.isprintable() or " " in name:
        raise ValueError(f"arm {name!r}: a name has no '/' and no spaces")
    host, at, pose = rest.partition("@")
    try:
        ipaddress.ip_address(host)
    except ValueError:
        raise ValueError(f"arm {name}: {host!r} is not an IP address") from None
    if not at:
        return ArmSpec(name, host, robot=robot, tool=tool)
    try:
        figures = [float(v) for v in pose.split(",")]
    except ValueError:
        raise ValueError(f"arm {name}: {pose!r} is not x,y,z[,yaw_deg] in numbers") from None
    if len(figures) not in (3, 4) or not all(math.isfinite(v) for v in figures):
        raise ValueError(f"arm {name}: {pose!r} is not x,y,z[,yaw_deg] (3 or 4 finite numbers)")
    x, y, z, yaw = (figures + [0.0])[:4]
    return ArmSpec(name, host, (x, y, z, math.radians(yaw)), robot, tool)


@app.command(cls=PlainHelpCommand)
def check(
    ctx: typer.Context,
    host: str = typer.Argument(
        "127.0.0.1", envvar="FRANKA_SIM_HOST", metavar="HOST",
        help="Address of the simulator (or, with --fci, of the robot). Given here, it is "
        "checked even where a serving file is named.",
    ),
    control_port: int = typer.Option(
        1340, envvar="FRANKA_SIM_CONTROL_PORT", min=0, max=65535,
        help="Port of the simulator's control API (0, `serve`'s for none: only --fci or a "
        "serving file can tell).",
    ),
    token: str | None = typer.Option(
        None, envvar="FRANKA_SIM_CONTROL_TOKEN", help="Bearer token of the control API.",
    ),
    serving_file: Path | None = typer.Option(
        None, envvar="FRANKA_SIM_SERVING_FILE", dir_okay=False, metavar="FILE",
        help="Without a HOST argument: check every robot listed in the file a `serve` started "
        "with FRANKA_SIM_SERVING_FILE=FILE writes while it serves (its addresses, control "
        "port and token): ready when all are. The image sets it (docs/deployment.md).",
    ),
    wait: float = typer.Option(
        0.0, min=0.0, help="Try again until ready or this many seconds have passed.",
    ),
    fci: bool = typer.Option(
        False, "--fci", help="Instead of the control API, connect as libfranka does (protocol "
        "v10 on TCP 1337) and wait for one robot state: also works against a robot.",
    ),
    timeout: float = typer.Option(
        2.0, min=0.01, help="Seconds each attempt may take.",
    ),
) -> None:
    """Exit 0 when the simulator at HOST is ready; else 1, with one line on stderr saying why.
    For container health checks and CI scripts."""
    from franka_sim.readiness import check_until

    # A HOST from FRANKA_SIM_HOST is `serve`'s, which --arm and --mobile-base override: the
    # serving file knows better.
    # (click's ParameterSource, by name: typer may bring its own click)
    if getattr(ctx.get_parameter_source("host"), "name", None) == "COMMANDLINE":
        serving_file = None
    if host.count(":") == 1:  # (an IPv6 address has more)
        typer.echo(f"franka-sim check: {host}: HOST is an address alone; the control API's "
                   "port is --control-port", err=True)
        raise typer.Exit(1)
    if serving_file is None and not fci and not control_port:
        typer.echo("franka-sim check: control port 0: no control API to ask (--fci asks the "
                   "robot's FCI)", err=True)
        raise typer.Exit(1)
    reason = check_until(host, wait=wait, timeout=timeout, fci=fci,
                         control_port=control_port, token=token, serving=serving_file)
    if reason is not None:
        typer.echo(f"franka-sim check: {reason}", err=True)
        raise typer.Exit(1)


# The commands that read a recording (replay, plot, render, view) live beside.
for _command in cli_recordings.COMMANDS:
    app.command(cls=PlainHelpCommand)(_command)


def _one_line_summaries() -> None:
    """`franka-sim --help` lists each command by its docstring's first paragraph as one line,
    which the terminal wraps: rich markup would keep the docstring's own line breaks there."""
    for info in app.registered_commands:
        paragraph = inspect.cleandoc(info.callback.__doc__ or "").split("\n\n")[0]
        info.short_help = " ".join(paragraph.split())


_one_line_summaries()


def main() -> None:
    """The CLI; a command line it refuses is one line (cli_errors.py)."""
    from franka_sim.cli_errors import run

    run(app)

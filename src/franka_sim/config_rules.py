"""The rules a Config must follow that span its fields, checked in one place: `franka-sim serve`
says a broken one on its command line, an embedded FrankaSim (and replay) refuse it the same
way, with the flag it concerns.
"""

from __future__ import annotations

import dataclasses
import math
import ipaddress
from pathlib import Path

from franka_sim.config import DESK_BOOTS, ROBOTS, WORLD_REACH, ArmSpec, ClockMode, Config
from franka_sim.control.errors import header_safe

RESERVED_PORTS = range(1337, 1340)  # the FCI, the Franka Hand, the vacuum gripper


class ConfigError(ValueError):
    """A setting cannot be served; `flag` names it as the command line does."""

    def __init__(self, flag: str, message: str) -> None:
        super().__init__(message)
        self.flag = flag


def checked(config: Config) -> Config:
    """`config`, its fault spec normalised and its scene resolved; ConfigError if it breaks a
    rule."""
    if not isinstance(config.clock, ClockMode):  # (an embedder's "lockstep")
        if config.clock not in {mode.value for mode in ClockMode}:
            raise ConfigError("--clock", f"{config.clock!r} is not a clock (one of "
                              f"{', '.join(mode.value for mode in ClockMode)})")
        config = dataclasses.replace(config, clock=ClockMode(config.clock))
    if paths := {name: Path(value) for name in ("urdf", "record", "meshes", "desk_cert",
                                                "desk_key")
                 if isinstance(value := getattr(config, name), str)}:
        config = dataclasses.replace(config, **paths)  # (an embedder's strings)
    if config.control_port in RESERVED_PORTS:
        raise ConfigError("--control-port", (
            f"{config.control_port} is the FCI's, the Hand's or the vacuum gripper's port "
            f"({RESERVED_PORTS.start}-{RESERVED_PORTS.stop - 1}); choose another (default 1340)"))
    _kinds(config)
    scale = config.joint_discontinuity_scale  # (typer's minimum lets a NaN through)
    if not (isinstance(scale, (int, float)) and math.isfinite(scale) and scale >= 1e-6):
        raise ConfigError("--joint-discontinuity-scale", f"{scale!r} is not a finite scale "
                          "of at least 1e-06")
    if config.control_token is not None and not config.control_token.strip():
        raise ConfigError("--control-token", "an empty token protects nothing")
    if config.control_token is not None and not header_safe(config.control_token):
        raise ConfigError("--control-token", "spaces around it or control characters in it "
                          "cannot be sent in an HTTP header")
    if config.mobile_base is not None:
        _address("--mobile-base", config.mobile_base)
        if not config.arms:
            raise ConfigError("--mobile-base", "a mobile base carries the arms named with --arm")
    for arm in config.arms:
        _address("--arm", arm.host, f"arm {arm.name}: ")
    for flag, name, robot in (("--robot", "", config.robot),
                              *(("--arm", f"arm {a.name}: ", a.robot) for a in config.arms)):
        if robot is not None and robot not in ROBOTS:
            raise ConfigError(flag, f"{name}{robot!r} is not a robot (one of "
                              f"{', '.join(ROBOTS)})")
    from franka_sim.tools import tool_names

    for flag, name, tool in (("--tool", "", config.tool),
                             *(("--arm", f"arm {a.name}: ", a.tool) for a in config.arms)):
        if tool is not None and tool not in tool_names():
            raise ConfigError(flag, f"{name}{tool!r} is not a tool (one of "
                              f"{', '.join(tool_names())})")
    if config.tool_port is not None and config.tool_port in (config.robot_port,
                                                             config.control_port):
        raise ConfigError("tool_port", f"{config.tool_port} is the FCI's or the control "
                          "API's port")
    _physics(config)
    _desk(config)
    _web(config)
    _meshes(config)
    changes: dict = {}
    if config.record is not None:
        from franka_sim.recording import mcap_missing

        if missing := mcap_missing():
            raise ConfigError("--record", missing)
    if config.inject is not None:
        changes["inject"] = _fault_spec(config.inject)
    if config.scene is not None:
        from franka_sim.physics.scene import SceneError, resolve_scene

        try:
            changes["scene"] = resolve_scene(config.scene)
        except SceneError as exc:
            raise ConfigError("--scene", str(exc)) from None
    return dataclasses.replace(config, **changes) if changes else config


def _physics(config: Config) -> None:
    """A known engine, installed, and a world it simulates (Genesis: one arm on the world,
    the Hand or no tool; served without the MuJoCo viewers, web view and recordings)."""
    from franka_sim.physics.engine_choice import ENGINES, engine_missing

    engine = getattr(config.physics, "value", config.physics)
    if engine not in ENGINES:
        raise ConfigError("--physics", f"{engine!r} is not an engine (one of "
                          f"{', '.join(ENGINES)})")
    if engine == "mujoco":
        return
    # What the engine cannot simulate is said before what is not installed: a 4 GB extra
    # installed for a world it refuses anyway is the worse news later.
    if len(config.arm_specs()) > 1 or config.mobile_base is not None:
        raise ConfigError("--physics", f"{engine} simulates one arm on the world (one --arm at "
                                       "most, no --mobile-base)")
    if any(config.tool_of(spec) not in ("hand", "none") for spec in config.arm_specs()):
        raise ConfigError("--physics", f"{engine} carries the Franka Hand or no tool")
    for flag, used in (("--web", config.web_port), ("--record", config.record),
                       ("--meshes", config.meshes)):
        if used:
            raise ConfigError("--physics", f"{engine} is served without {flag} "
                              "(they draw and record the MuJoCo world)")
    if missing := engine_missing(engine):
        raise ConfigError("--physics", missing)


def _kinds(config: Config) -> None:
    """What the CLI's parsing guarantees, for an embedder's Config too: a switch is a bool (a
    string "no" is true), a port an int in range, the seed a non-negative int, an arm's base
    three or four numbers."""
    for name in ("enforce_comm_constraints", "enforce_motion_limits", "strict_versions"):
        if not isinstance(getattr(config, name), bool):
            raise ConfigError(f"--{name.replace('_', '-')}",
                              f"{getattr(config, name)!r} is not True or False")
    for name in ("control_port", "desk_port", "web_port"):
        port = getattr(config, name)
        if isinstance(port, bool) or not isinstance(port, int) or not 0 <= port <= 65535:
            raise ConfigError(f"--{name.replace('_', '-')}", f"{port!r} is not a TCP port "
                              "(0-65535)")
    if isinstance(config.seed, bool) or not isinstance(config.seed, int) or config.seed < 0:
        raise ConfigError("--seed", f"{config.seed!r} is not a non-negative integer")
    for name, port in (("robot_port", config.robot_port), ("tool_port", config.tool_port)):
        if port is None and name == "tool_port":
            continue  # (the tool's own)
        if isinstance(port, bool) or not isinstance(port, int) or not 1 <= port <= 65535:
            raise ConfigError(name, f"{port!r} is not a TCP port (1-65535; libfranka connects "
                              "to the FCI's 1337 and the Hand's 1338)")
    if config.robot_port in (config.control_port, config.desk_port, config.web_port):
        raise ConfigError("robot_port", f"{config.robot_port} is another service's port")
    if not isinstance(config.host, str) or not config.host:
        raise ConfigError("--host", f"{config.host!r} is not an address")
    _start_pose(config.q0)
    for spec in config.arms:
        if not isinstance(spec, ArmSpec):
            raise ConfigError("--arm", f"{spec!r} is not an ArmSpec(name, host, base=None, "
                              "robot=None, tool=None)")
        if spec.base is not None and len(spec.base) not in (3, 4):
            raise ConfigError("--arm", f"arm {spec.name}: its base {spec.base!r} is x, y, z "
                              "and an optional yaw in degrees")
        if spec.base is not None and not math.hypot(*spec.base[:3]) <= WORLD_REACH:
            raise ConfigError("--arm", f"arm {spec.name}: its base {tuple(spec.base[:3])} is "
                              f"over {WORLD_REACH:g} m from the world's origin")


def _start_pose(q0) -> None:
    """Seven finite joint angles (each arm's description then holds them to its joint limits:
    assembly.py)."""
    try:
        values = [float(v) for v in q0]
    except (TypeError, ValueError):
        raise ConfigError("q0", f"{q0!r} is not 7 joint angles (rad)") from None
    if len(values) != 7 or not all(map(math.isfinite, values)):
        raise ConfigError("q0", f"{tuple(q0)!r} is not 7 finite joint angles (rad)")


def _desk(config: Config) -> None:
    if config.desk_boot not in DESK_BOOTS:
        raise ConfigError("--desk-boot", f"{config.desk_boot!r}: one of {', '.join(DESK_BOOTS)}")
    if config.desk_boot == "locked" and not config.desk_port:
        # Only the Desk activates the FCI: locked without it, no client could ever connect.
        raise ConfigError("--desk-boot", "a robot booted locked is brought up through its "
                          "Desk: give --desk-port too (the robot's is 443)")
    port = config.desk_port
    if not 0 <= port <= 65535:
        raise ConfigError("--desk-port", f"{port} is not a TCP port (0: no Desk)")
    if port and (port in RESERVED_PORTS or port in (config.control_port, config.tool_port)):
        raise ConfigError("--desk-port", f"{port} is another service's port (the Desk's is 443)")
    if config.desk_users:
        from franka_sim.desk.users import parse_user
    for user in config.desk_users:
        try:
            parse_user(user)
        except ValueError as exc:
            raise ConfigError("--desk-user", str(exc)) from None
    if (config.desk_cert is None) != (config.desk_key is None):
        given, missing = (("--desk-cert", "--desk-key") if config.desk_key is None
                          else ("--desk-key", "--desk-cert"))
        raise ConfigError(given, f"a certificate and its key go together: give {missing} too")
    if config.desk_cert is not None and not config.desk_port:
        raise ConfigError("--desk-cert", "the certificate is the Desk's: give --desk-port too "
                          "(the robot's is 443)")


def _web(config: Config) -> None:
    port = config.web_port
    if not 0 <= port <= 65535:
        raise ConfigError("--web", f"{port} is not a TCP port (0: no web view)")
    if not port:
        return
    if port in RESERVED_PORTS or port in (config.control_port, config.tool_port,
                                          config.desk_port):
        raise ConfigError("--web", f"{port} is another service's port (docs/viewing.md)")
    from franka_sim.web import web_missing

    if missing := web_missing():
        raise ConfigError("--web", missing)


def _meshes(config: Config) -> None:
    """Every arm kind's visual meshes are there (reading them waits for the world's build)."""
    if config.meshes is None:
        return
    from franka_sim.physics.arm_meshes import MeshError, find_meshes

    for robot in sorted({config.robot_of(spec) for spec in config.arm_specs()}):
        try:
            find_meshes(config.meshes, robot)
        except MeshError as exc:
            raise ConfigError("--meshes", str(exc)) from None


def _address(flag: str, text: str, who: str = "") -> None:
    try:
        ipaddress.ip_address(text)
    except ValueError:
        raise ConfigError(flag, f"{who}{text!r} is not an IP address") from None


def _fault_spec(text: str) -> str | None:
    """The spec as its own text (an empty one: no faults)."""
    if not text.strip():
        return None
    from franka_sim.faults import FaultSpecError, parse_spec

    try:
        return parse_spec(text).text()
    except FaultSpecError as exc:
        raise ConfigError("--inject", str(exc)) from None

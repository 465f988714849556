"""What a recording of one of libfranka's C++ examples must show the robot did: the client's
protocol version at Connect, then each example's own motion, read off the states the robot
sent and the commands it took. A run cut short (a committed recording keeps only the start
of a long motion) is checked as far as it went."""

from __future__ import annotations

import numpy as np

from franka_sim.config import READY_POSE
from franka_sim.protocol.codec import GRIPPER_STATE_DTYPE, VACUUM_GRIPPER_STATE_DTYPE
from franka_sim.recording.reader import Recording, command_of

READY = np.array(READY_POSE)
CYCLE = 0.001


def connect_versions(recording: Recording) -> dict[str, int]:
    """The version each service's client asked for in its Connect, by service."""
    versions = {}
    for entry in recording.of("tcp"):
        event = entry.json()
        for request in event["requests"]:
            if request.get("command") == "Connect":
                versions[event["service"]] = request["version"]
    return versions


def requests(recording: Recording) -> list[dict]:
    """Every TCP request the clients sent, decoded (a request the recording could not read
    would show as {"malformed": ...})."""
    return [r for e in recording.of("tcp") for r in e.json()["requests"]]


def replies(recording: Recording, command: str) -> list[str]:
    return [r["status"] for e in recording.of("reply") for r in e.json()["replies"]
            if r.get("command") == command]


def logged(recording: Recording, text: str) -> bool:
    return any(text in e.json()["message"] for e in recording.of("log"))


def commands(recording: Recording) -> np.ndarray:
    return np.array([command_of(e)[3] for e in recording.of("command")])


def motions(recording: Recording) -> list[np.ndarray]:
    """The commands of each motion, in order: those from one Move's kMotionStarted reply to
    the next's."""
    starts = [e.json()["cycle"] for e in recording.of("reply")
              if any(r.get("command") == "Move" and r.get("status") == "kMotionStarted"
                     for r in e.json()["replies"])]
    every = commands(recording)
    ids = every["message_id"].astype(np.int64)
    bounds = [*starts, np.iinfo(np.int64).max]
    return [every[(ids >= a) & (ids < b)] for a, b in zip(bounds, bounds[1:])]


def check_communication_test(recording: Recording, complete: bool) -> None:
    """Zero torques for 10 s: the arm stays where it was, every command arrives on time. Its
    last command finishes the motion: by motion_generation_finished up to robot version 9, by
    torque_command_finished from 10 on (libfranka 0.18 on: torque control runs no generator)."""
    torque = motions(recording)[-1]
    assert not np.any(torque["tau_J_d"]), "the example only sends zero torques"
    assert len(torque) > 10_000 if complete else len(torque) > 100, len(torque)
    if connect_versions(recording)["robot"] >= 10:
        assert torque[-1]["torque_command_finished"] == complete
        assert not np.any(torque["motion_generation_finished"])
    else:
        assert torque[-1]["motion_generation_finished"] == complete
    q = recording.states()["q"]
    assert np.abs(q - READY).max() < 1e-3
    fates = [command_of(e)[2] for e in recording.of("command")]
    assert all(fates), "in lockstep every command is on time"


def check_echo_robot_state(recording: Recording, complete: bool) -> None:
    """Reads 101 states and moves nothing."""
    states = recording.states()
    assert len(states) >= 101 and not recording.of("command")
    assert np.all(states["robot_mode"] == 1)  # kIdle
    assert np.abs(states["q"] - READY).max() < 1e-6


def check_generate_joint_position_motion(recording: Recording, complete: bool) -> None:
    """Joints 4, 5 and 7 go out by pi/8 (1 - cos(pi/2.5 t)) and back in 5 s, the others keep
    still; the arm follows."""
    motion = motions(recording)[-1]
    q_c = motion["q_c"]
    delta = q_c - q_c[0]
    assert np.abs(delta[:, [0, 1, 2, 5]]).max() < 1e-12
    t = np.arange(len(motion)) * CYCLE
    curve = np.pi / 8 * (1 - np.cos(np.pi / 2.5 * t))
    # (libfranka low-pass filters and rate-limits what the callback returns: a cycle behind)
    assert np.abs(delta[:, [3, 4, 6]] - curve[:, None]).max() < 1e-3
    assert len(motion) >= 5001 if complete else delta[:, 3].max() > 0.01
    if complete:
        assert delta[:, 3].max() > np.pi / 4 - 1e-5 and abs(delta[-1, 3]) < 1e-5
    _follows(recording, motion, "q_c", "q", 1e-3)


def check_generate_cartesian_pose_motion(recording: Recording, complete: bool) -> None:
    """The end effector goes along an arc of 0.3 m radius in x-z and back in 10 s."""
    motion = motions(recording)[-1]
    p = motion["O_T_EE_c"][:, 12:15]
    d = p - p[0]
    assert np.abs(d[:, 1]).max() < 1e-9
    assert np.allclose(d[:, 0] ** 2 + (d[:, 2] + 0.3) ** 2, 0.09, atol=1e-6)
    assert len(motion) >= 10_001 if complete else d[:, 0].max() > 0.002
    if complete:
        assert d[:, 0].max() > 0.299 and np.abs(d[-1]).max() < 1e-5  # out to 0.3 m and back
    _follows(recording, motion, "O_T_EE_c", "O_T_EE", 1e-3)


def check_cartesian_impedance_control(recording: Recording, complete: bool) -> None:
    """Torque control computed from the Model the robot gave (coriolis, zero jacobian; from
    0.14 on the dynamics from the URDF it asked for; from 0.18, robot version 10, the whole
    Model from the URDF, the model library gone): the robot runs the client's torques and the
    arm holds its pose."""
    version = connect_versions(recording)["robot"]
    asked = [r.get("command") for r in requests(recording)]
    if version >= 10:  # no model library in the protocol any more
        assert "LoadModelLibrary" not in asked and not logged(recording, "model library sent")
    else:
        assert logged(recording, "model library sent"), "the example loads its Model"
        assert "LoadModelLibrary" in asked
        assert replies(recording, "LoadModelLibrary") == ["kSuccess"]
    if version >= 10:  # the URDF asked for at connecting (joint velocity limits) and for the Model
        assert replies(recording, "GetRobotModel") == ["kSuccess"] * 2
    elif version >= 8:  # libfranka 0.14 on: dynamics from the URDF
        assert replies(recording, "GetRobotModel") == ["kSuccess"]
    else:  # the whole Model from the library
        assert "GetRobotModel" not in asked
    torque = motions(recording)[-1]
    assert len(torque) > 300 and not torque[-1]["motion_generation_finished"]
    states = recording.states()
    during = np.isin(states["message_id"], torque["message_id"])
    assert np.all(states["controller_mode"][during] == 2)  # kExternalController
    moved = np.linalg.norm(states["O_T_EE"][:, 12:15] - READY_EE, axis=1)
    assert moved.max() < 1e-4, f"{moved.max():.2e} m off the equilibrium"


READY_EE = np.array([0.306891, 0.0, 0.486882])  # READY's end effector (flange and Hand)


def check_grasp_object(recording: Recording, complete: bool) -> None:
    """Homing, then a grasp of the 5 cm cube that holds for 3 s."""
    states = np.frombuffer(b"".join(e.data for e in recording.of("gripper_state")),
                           GRIPPER_STATE_DTYPE)
    assert states["width"].max() > 0.075, "homing opened the Hand"
    assert states[-1]["is_grasped"] and abs(states[-1]["width"] - 0.05) < 2e-3
    for command in ("Homing", "Grasp", "Stop"):
        assert replies(recording, command)[-1] == "kSuccess", command


def check_vacuum_object(recording: Recording, complete: bool) -> None:
    """The pump vacuums the cube under the cup (answered once the part is present and the
    vacuum in range), holds it, and drops it off (its last states, 10 a second, show the cup
    venting: the client leaves on the answer); the arm never moves."""
    states = np.frombuffer(b"".join(e.data for e in recording.of("vacuum_gripper_state")),
                           VACUUM_GRIPPER_STATE_DTYPE)
    held = states["part_present"] & states["in_control_range"]
    assert not states[0]["part_present"] and held.sum() >= 30, "held for 3 s"
    assert not states[-1]["part_present"] and states[-1]["vacuum"] < 0.1 * states["vacuum"].max()
    assert replies(recording, "Vacuum") == ["kSuccess"]
    assert replies(recording, "DropOff") == ["kSuccess"]
    assert not recording.of("command"), "the example moves nothing"


def _follows(recording: Recording, motion: np.ndarray, commanded: str, measured: str,
             tolerance: float) -> None:
    """The robot's next state is within `tolerance` of what each command asked for."""
    states = recording.states()
    by_id = {int(i): n for n, i in enumerate(states["message_id"])}
    pairs = [(c[commanded], states[by_id[int(c["message_id"]) + 1]][measured])
             for c in motion if int(c["message_id"]) + 1 in by_id]
    assert len(pairs) > 0.9 * len(motion)
    error = max(np.abs(np.subtract(*pair)).max() for pair in pairs)
    assert error < tolerance, f"{measured} {error:.2e} off {commanded}"


CHECKS = {name[len("check_"):]: f for name, f in globals().items() if name.startswith("check_")}

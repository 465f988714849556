"""franky-control 2.0.0 scenarios, each run in a child Python by tests/clients/test_client_franky.py
(`python franky_scenarios.py SCENARIO HOST`): it drives the robot with franky and prints its
observations as one JSON line after RESULT.

franky and pylibfranka each register pybind11 types of the same name (`Duration`), so the two
cannot be imported into one process, and the test suite imports pylibfranka.
"""

from __future__ import annotations

import json
import math
import re
import sys
import time

import numpy as np

READY = [0.0, -math.pi / 4, 0.0, -3 * math.pi / 4, 0.0, math.pi / 2, math.pi / 4]
SINGULAR_POSE = [0.0, 0.0, 0.0, -0.5, 0.0, 1.0, math.pi / 4]  # wrist centre over joint 1
RESULT = "RESULT "


def _connect(host: str):
    import franky

    robot = franky.Robot(host, realtime_config=franky.RealtimeConfig.Ignore)
    robot.relative_dynamics_factor = 0.2
    return robot


def _fresh(robot):
    """A state published after this call began. Idle, `robot.state` is libfranka's readOnce, which
    keeps the newest *queued* datagram — and a socket nobody read for a while holds old ones (it
    drops the newest when it overflows). The first read drains them; the second is current."""
    robot.state
    return robot.state


def _ms(state) -> int:
    return int(state.time.to_msec())


def _wait_robot_ms(robot, ms: int, sample=None) -> None:
    """Let `ms` of robot time pass while an asynchronous motion runs (polling its state)."""
    t0 = _ms(robot.state)
    deadline = time.monotonic() + 120  # a safety net against a dead server, not a timing bound
    while _ms(robot.state) - t0 < ms:
        if sample is not None:
            sample(robot.state)
        if time.monotonic() > deadline:
            raise TimeoutError(f"robot time did not advance {ms} ms")
        time.sleep(0.002)


def _moving(robot) -> None:
    """Wait for an asynchronous motion's first state. Robot time to its start is not motion
    time: in lockstep a client's idle gap before the Move counts as whole seconds."""
    deadline = time.monotonic() + 120  # a safety net against a dead server, not a timing bound
    while robot.state.robot_mode.name != "Move":
        if time.monotonic() > deadline:
            raise TimeoutError("the motion did not start")
        time.sleep(0.002)


def _settled(robot, ms: int = 300):
    """The state once `ms` of robot time passed idle: the hold has taken out the tracking lag."""
    _wait_robot_ms(robot, ms)
    return _fresh(robot)


def _affine(values) -> list:
    return np.asarray(values.matrix).tolist()


def scenario_state(host: str) -> dict:
    from franky import Frame

    robot = _connect(host)
    s = _fresh(robot)
    later = robot.state
    model = robot.model
    return {
        "q": list(s.q), "q_d": list(s.q_d), "dq": list(s.dq), "robot_mode": s.robot_mode.name,
        "times": [_ms(s), _ms(later)], "O_T_EE": _affine(s.O_T_EE), "F_T_EE": _affine(s.F_T_EE),
        "m_ee": s.m_ee, "has_errors": robot.has_errors, "current_errors": str(s.current_errors),
        "tau_J": list(s.tau_J), "gravity": np.asarray(model.gravity(s)).tolist(),
        "model_pose": _affine(model.pose(Frame.EndEffector, s)),
        "jacobian_shape": list(np.asarray(model.zero_jacobian(Frame.EndEffector, s)).shape),
        "urdf_robot_names": re.findall(r'<robot\s+name="([^"]*)"', robot.model_urdf),
        "urdf_has_link8": 'name="link8"' in robot.model_urdf,
        "joint_position": np.asarray(robot.current_joint_positions).tolist(),
        "ee_translation": np.asarray(robot.current_pose.end_effector_pose.translation).tolist(),
    }


def scenario_joint_motions(host: str) -> dict:
    from franky import JointMotion, JointWaypoint, JointWaypointMotion, ReferenceType

    robot = _connect(host)
    out = {}
    ready = np.array(READY)
    target = ready + np.array([0.1, -0.1, 0.1, 0.1, -0.1, 0.1, 0.2])
    t0 = _ms(robot.state)
    robot.move(JointMotion(target.tolist()))
    s = robot.state
    out["joint_motion"] = {"target": target.tolist(), "q_end": list(s.q), "mode": s.robot_mode.name,
                           "elapsed_ms": _ms(s) - t0, "q": list(_settled(robot).q)}
    robot.move(JointMotion([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, -0.2], ReferenceType.Relative))
    out["relative"] = {"expected": (target + [0, 0, 0, 0, 0, 0, -0.2]).tolist(),
                       "q": list(_settled(robot).q)}
    via = ready + np.array([-0.1, 0.1, 0.0, 0.0, 0.0, 0.0, 0.0])
    robot.move(JointWaypointMotion([JointWaypoint(via.tolist()), JointWaypoint(READY)]))
    s = _settled(robot)
    out["waypoints"] = {"q": list(s.q), "mode": s.robot_mode.name}
    # Two asynchronous motions in a row: franky switches targets inside one running control loop.
    first, second = ready + [0.2, 0, 0, 0, 0, 0, 0], ready + [0, 0, 0, 0, 0, 0, 0.3]
    robot.move(JointMotion(first.tolist()), asynchronous=True)
    _wait_robot_ms(robot, 200)
    robot.move(JointMotion(second.tolist()), asynchronous=True)
    robot.join_motion()
    s = _settled(robot)
    out["blended"] = {"target": second.tolist(), "q": list(s.q), "mode": s.robot_mode.name,
                      "has_errors": robot.has_errors}
    return out


def scenario_cartesian_motions(host: str) -> dict:
    from franky import Affine, CartesianMotion, CartesianWaypoint, CartesianWaypointMotion, ReferenceType

    robot = _connect(host)
    out = {}
    T0 = robot.current_pose.end_effector_pose
    offset = np.array([0.05, 0.02, -0.03])  # in the EE frame: franky composes relative targets on the right
    robot.move(CartesianMotion(Affine(offset.tolist()), ReferenceType.Relative))
    T1 = robot.current_pose.end_effector_pose
    out["relative"] = {"start": _affine(T0), "end": _affine(T1), "offset_ee": offset.tolist(),
                       "mode": robot.state.robot_mode.name}
    goal = Affine((np.asarray(T0.translation) + [0.0, 0.05, 0.0]).tolist(), np.asarray(T0.quaternion).tolist())
    robot.move(CartesianMotion(goal))
    out["absolute"] = {"goal": _affine(goal), "end": _affine(robot.current_pose.end_effector_pose)}
    via = Affine((np.asarray(T0.translation) + [0.0, 0.0, 0.05]).tolist(), np.asarray(T0.quaternion).tolist())
    robot.move(CartesianWaypointMotion([CartesianWaypoint(via), CartesianWaypoint(T0)]))
    out["waypoints"] = {"goal": _affine(T0), "end": _affine(robot.current_pose.end_effector_pose),
                        "mode": robot.state.robot_mode.name}
    return out


def scenario_velocity_motions(host: str) -> dict:
    from franky import CartesianVelocityMotion, Duration, JointVelocityMotion, Twist

    robot = _connect(host)
    out = {}
    s0 = robot.state
    robot.move(JointVelocityMotion([0.1, 0.0, 0.0, 0.0, 0.0, 0.0, -0.1], duration=Duration(500)))
    s1 = robot.state
    out["joint"] = {"dq_total": (np.array(s1.q) - np.array(s0.q)).tolist(), "dq_end": list(s1.dq),
                    "elapsed_ms": _ms(s1) - _ms(s0), "mode": s1.robot_mode.name}
    p0 = np.asarray(robot.current_pose.end_effector_pose.translation)
    t0 = _ms(robot.state)
    robot.move(CartesianVelocityMotion(Twist([0.05, 0.0, 0.0], [0.0, 0.0, 0.0]), duration=Duration(500)))
    s2 = robot.state
    p1 = np.asarray(robot.current_pose.end_effector_pose.translation)
    out["cartesian"] = {"dp": (p1 - p0).tolist(), "elapsed_ms": _ms(s2) - t0,
                        "mode": s2.robot_mode.name, "dq_end": list(s2.dq)}
    return out


def scenario_torque(host: str) -> dict:
    from franky import JointImpedanceMotion, SimpleTorqueMotion, TorqueStopMotion

    robot = _connect(host)
    out = {}
    q0 = np.array(robot.state.q)
    seen = {"dev": 0.0, "modes": set(), "tau_J_d": 0.0}

    def sample(state):
        seen["dev"] = max(seen["dev"], float(np.abs(np.array(state.q) - q0).max()))
        seen["modes"].add(state.robot_mode.name)
        seen["tau_J_d"] = max(seen["tau_J_d"], float(np.abs(state.tau_J_d).max()))

    robot.move(SimpleTorqueMotion(signal_timeout=None), asynchronous=True)  # zero torque
    _moving(robot)
    _wait_robot_ms(robot, 1000, sample)
    robot.move(TorqueStopMotion(), asynchronous=True)
    robot.join_motion()
    s = robot.state
    out["zero_torque"] = {"max_deviation": seen["dev"], "modes": sorted(seen["modes"]),
                          "max_tau_J_d": seen["tau_J_d"], "mode_after": s.robot_mode.name,
                          "deviation_after": float(np.abs(np.array(s.q) - q0).max())}
    target = q0 + np.array([0.1, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    robot.move(JointImpedanceMotion(target.tolist()), asynchronous=True)
    _moving(robot)
    _wait_robot_ms(robot, 2000)
    reached = list(robot.state.q)
    robot.move(TorqueStopMotion(), asynchronous=True)
    robot.join_motion()
    out["joint_impedance"] = {"target": target.tolist(), "q": reached,
                              "mode_after": robot.state.robot_mode.name}
    return out


def scenario_setters(host: str) -> dict:
    import franky

    robot = _connect(host)
    out = {}
    robot.set_collision_behavior([30.0] * 7, [30.0] * 6)
    robot.set_collision_behavior([20.0] * 7, [40.0] * 7, [20.0] * 6, [40.0] * 6)
    robot.set_collision_behavior([20.0] * 7, [40.0] * 7, [10.0] * 7, [30.0] * 7,
                                 [20.0] * 6, [40.0] * 6, [10.0] * 6, [30.0] * 6)
    robot.set_joint_impedance([3000.0, 3000.0, 3000.0, 2500.0, 2500.0, 2000.0, 2000.0])
    robot.set_cartesian_impedance([3000.0, 3000.0, 3000.0, 300.0, 300.0, 300.0])
    robot.set_guiding_mode([True] * 6, False)
    before = _fresh(robot)
    NE_T_EE = np.eye(4)
    NE_T_EE[2, 3] = 0.05
    EE_T_K = np.eye(4)
    EE_T_K[2, 3] = 0.02
    robot.set_ee(NE_T_EE.ravel(order="F").tolist())
    robot.set_k(EE_T_K.ravel(order="F").tolist())
    s = _fresh(robot)
    out["frames"] = {
        "F_T_EE_before": _affine(before.F_T_EE), "F_T_EE": _affine(s.F_T_EE),
        "NE_T_EE": _affine(s.NE_T_EE), "EE_T_K": _affine(s.EE_T_K),
        "O_T_EE_before": _affine(before.O_T_EE), "O_T_EE": _affine(s.O_T_EE),
    }
    # (After the frames: a load declared but not carried lifts the arm a little against the
    # joint impedance, and in lockstep a read after a request finds the arm settled.)
    inertia = [1e-3, 0.0, 0.0, 0.0, 2e-3, 0.0, 0.0, 0.0, 3e-3]
    robot.set_load(0.5, [0.0, 0.0, 0.05], inertia)
    s = _fresh(robot)
    out["load"] = {"m_load": s.m_load, "F_x_Cload": list(s.F_x_Cload),
                   "I_load": np.asarray(s.I_load).ravel(order="F").tolist(),
                   "m_ee": s.m_ee, "m_total": s.m_total}
    # The robot refuses Set* while a motion runs; libfranka turns that into a CommandException.
    # The motion holds its target until the next one takes over (it cannot have ended by the
    # time the setter is sent, however slowly this process runs beside it).
    target = (np.array(READY) + [0.2, 0, 0, 0, 0, 0, 0]).tolist()
    robot.move(franky.JointMotion(target, return_when_finished=False), asynchronous=True)
    _moving(robot)
    _wait_robot_ms(robot, 100)
    try:
        robot.set_joint_impedance([3000.0] * 7)
        out["during_motion"] = None
    except franky.CommandException as exc:
        out["during_motion"] = str(exc)
    robot.move(franky.JointMotion(target))  # takes over, and ends at the target
    robot.join_motion()
    robot.set_ee(np.eye(4).ravel(order="F").tolist())
    robot.set_k(np.eye(4).ravel(order="F").tolist())
    robot.set_load(0.0, [0.0, 0.0, 0.0], [0.0] * 9)
    s = _fresh(robot)
    out["reset"] = {"F_T_EE": _affine(s.F_T_EE), "m_load": s.m_load}
    return out


def scenario_stop(host: str) -> dict:
    import franky

    robot = _connect(host)
    out = {}
    # Long (2 rad at 5 % of the limits: ~15 s of robot time), so the stop 200 ms in meets it
    # running however long a loaded machine keeps this thread from sending it while franky's
    # control thread goes on (in lockstep, several times faster than real time).
    robot.move(franky.JointMotion((np.array(READY) + [2.0, 0, 0, 0, 0, 0, 0]).tolist(),
                                  relative_dynamics_factor=0.05), asynchronous=True)
    _moving(robot)
    _wait_robot_ms(robot, 200)
    robot.stop()
    try:
        robot.join_motion()
        out["preempted"] = None
    except franky.ControlException as exc:
        out["preempted"] = str(exc)
    s = _fresh(robot)
    out["after"] = {"mode": s.robot_mode.name, "has_errors": robot.has_errors,
                    "q0": float(s.q[0]), "dq": list(s.dq)}
    robot.move(franky.JointMotion(READY))
    out["moved_again"] = list(robot.state.q)
    return out


def scenario_singular(host: str) -> dict:
    import franky

    robot = _connect(host)
    out = {}
    robot.move(franky.JointMotion(SINGULAR_POSE))
    before = _fresh(robot)
    out["at"] = list(before.q)
    try:
        robot.move(franky.CartesianMotion(franky.Affine([0.0, 0.0, 0.02]), franky.ReferenceType.Relative))
        out["refused"] = None
    except franky.CommandException as exc:
        out["refused"] = f"{type(exc).__name__}: {exc}"
    s = _fresh(robot)
    out["after"] = {"mode": s.robot_mode.name, "has_errors": robot.has_errors, "q": list(s.q),
                    "last_motion_errors": str(s.last_motion_errors)}
    robot.move(franky.JointMotion(READY))
    out["back"] = list(robot.state.q)
    return out


def scenario_reflex_recovery(host: str) -> dict:
    """Needs a server with --enforce-motion-limits: a 2 Nm torque step in one cycle is 2000 Nm/s."""
    import franky

    robot = _connect(host)
    out = {}
    # franky ramps torques by max_delta_tau per cycle and libfranka low-passes them at 100 Hz by
    # default; both are opened up so that the step reaches the robot as commanded.
    motion = franky.SimpleTorqueMotion(signal_timeout=None, max_delta_tau=10.0)
    robot.move(motion, asynchronous=True, cutoff_frequency=1000.0)
    _moving(robot)
    _wait_robot_ms(robot, 100)
    motion.set_torque([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 2.0])
    try:
        robot.join_motion()
        out["aborted"] = None
    except franky.ControlException as exc:
        out["aborted"] = str(exc)
    s = _fresh(robot)
    out["reflex"] = {"mode": s.robot_mode.name, "has_errors": robot.has_errors,
                     "current_errors": str(s.current_errors),
                     "last_motion_errors": str(s.last_motion_errors)}
    try:
        robot.move(franky.JointMotion(list(s.q)))
        out["move_in_reflex"] = None
    except franky.CommandException as exc:
        out["move_in_reflex"] = str(exc)
    out["recovered"] = robot.recover_from_errors()
    s = _fresh(robot)
    out["after"] = {"mode": s.robot_mode.name, "has_errors": robot.has_errors,
                    "current_errors": str(s.current_errors)}
    # A motion is accepted again. It stays where the arm is: under --enforce-motion-limits a
    # cycle lost to host load while the generator moves would itself be a discontinuity.
    robot.move(franky.JointMotion(list(s.q)))
    out["moved_again"] = robot.state.robot_mode.name
    return out


def scenario_burst_reflex(host: str) -> dict:
    """Joint 1 out and back while a burst of 25 lost cycles (served --inject burst=25@3s)
    trips communication_constraints_violation: libfranka's exception counts the cycles between
    the last two states it read."""
    import franky

    robot = _connect(host)
    out = {"aborted": None}
    try:
        for sign in (1, -1, 1, -1):
            robot.move(franky.JointMotion((np.array(READY) + [0.3 * sign, 0, 0, 0, 0, 0, 0])
                                          .tolist()))
    except franky.ControlException as exc:
        out["aborted"] = str(exc)
    return out


def scenario_elbow_beyond_its_range(host: str) -> dict:
    """A Cartesian motion whose elbow target (joint 3) lies past joint 3's upper end."""
    import franky

    robot = _connect(host)
    pose = franky.Affine([0.4, 0.0, 0.4], [1.0, 0.0, 0.0, 0.0])
    out = {"aborted": None}
    try:
        robot.move(franky.CartesianMotion(franky.RobotPose(pose, franky.ElbowState(3.2))))
    except franky.ControlException as exc:
        out["aborted"] = str(exc)
    out["elbow_c"] = robot.state.elbow_c.joint_3_pos
    return out


def scenario_centred_top_grasp(host: str) -> dict:
    """The open Hand lowered over the default scene's 5 cm cube until the TCP is at its
    centre, then closed on it."""
    import franky

    robot = _connect(host)
    for z in (0.1, 0.025):
        robot.move(franky.CartesianMotion(franky.Affine([0.45, 0.0, z], [1.0, 0.0, 0.0, 0.0])))
    state = _fresh(robot)
    out = {"mode": state.robot_mode.name, "force_z": state.O_F_ext_hat_K[2],
           "tcp_z": state.O_T_EE.translation[2]}
    out["grasped"] = franky.Gripper(host).grasp(0.05, 0.05, 20.0, 0.005, 0.005)
    return out


def scenario_gripper(host: str) -> dict:
    import franky

    gripper = franky.Gripper(host)
    out = {"server_version": gripper.server_version, "initial": [gripper.width, gripper.max_width]}
    out["homing"] = gripper.homing()
    out["max_width"] = gripper.max_width
    out["move"] = gripper.move(0.04, 0.05)
    out["width_after_move"] = gripper.width
    out["grasp_nothing"] = gripper.grasp(0.02, 0.05, 20.0)
    out["after_grasp"] = [gripper.width, gripper.is_grasped]
    out["open"] = gripper.open(0.1)
    out["width_open"] = gripper.width
    try:
        gripper.move(0.5, 0.05)
        out["too_wide"] = None
    except franky.CommandException as exc:
        out["too_wide"] = str(exc)
    # Stop a running move: wait (on the hand's own states) until the fingers are under way.
    start = gripper.width
    future = gripper.move_async(0.01, 0.02)
    deadline = time.monotonic() + 60
    while gripper.width > start - 0.002 and time.monotonic() < deadline:
        pass  # each read blocks for the next 10 Hz GripperState
    out["stop"] = gripper.stop()
    try:
        out["stopped_move"] = future.get()
    except franky.CommandException as exc:
        out["stopped_move"] = str(exc)
    out["width_after_stop"] = gripper.width
    times = [gripper.state.time.to_msec() for _ in range(3)]
    out["state_times"] = times
    return out


SCENARIOS = {name[len("scenario_"):]: fn for name, fn in globals().items() if name.startswith("scenario_")}


if __name__ == "__main__":
    result = SCENARIOS[sys.argv[1]](sys.argv[2])
    print(RESULT + json.dumps(result), flush=True)

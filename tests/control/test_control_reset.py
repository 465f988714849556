"""POST /reset: refused while a client waits on a motion or a gripper action, never half done,
and after it the same program gives the same bits as on a fresh simulator."""

from __future__ import annotations

import math
import subprocess
import sys
import threading
import time

import numpy as np
import pylibfranka
import pytest

from franka_sim.control import Conflict, Control
from franka_sim.testing import running_sim
from support.clients import connect


def wait_for(predicate, timeout: float = 30.0, what: str = "the condition") -> None:
    end = time.monotonic() + timeout
    while not predicate():
        assert time.monotonic() < end, f"timed out waiting for {what}"
        time.sleep(0.01)


def test_reset_while_a_motion_runs_is_refused_and_changes_nothing(control, served):
    robot = connect(served.host)
    finish, failures = threading.Event(), []

    def torque_loop():
        try:
            motion = robot.start_torque_control()
            while True:
                motion.readOnce()
                command = pylibfranka.Torques([0.0] * 7)
                command.motion_finished = finish.is_set()
                motion.writeOnce(command)
                if command.motion_finished:
                    return
        except Exception as exc:  # noqa: BLE001 - reported below
            failures.append(exc)

    loop = threading.Thread(target=torque_loop)
    loop.start()
    try:
        wait_for(lambda: control.health()["robot_mode"] == "Move", what="the motion")
        cycle = control.health()["cycle"]
        with pytest.raises(Conflict, match="in Move: a motion") as refused:
            control.reset(q=[0.1, -0.5, 0.0, -2.0, 0.0, 1.5, 0.5])
        assert refused.value.status == 409
        state = control.state()
        assert state["robot_mode"] == "Move" and state["cycle"] > cycle
        np.testing.assert_allclose(state["q"][0], 0.0, atol=1e-3)  # not moved to 0.1
    finally:
        finish.set()
        loop.join(30)
    assert not failures, failures
    assert control.state()["robot_mode"] == "Idle"
    control.reset()  # once the motion is over
    del robot


GRIPPER_MOVE = """
import sys, pylibfranka
pylibfranka.Gripper(sys.argv[1]).move(0.01, 0.01)  # 7 s at 1 cm/s
"""


def test_reset_while_the_hand_moves_is_refused(control, served):
    client = subprocess.Popen([sys.executable, "-c", GRIPPER_MOVE, served.host])
    try:
        wait_for(lambda: control.state()["gripper_width"] < 0.078, what="the fingers to close")
        with pytest.raises(Conflict, match="gripper action"):
            control.reset()
        assert control.state()["gripper_width"] < 0.078
    finally:
        client.kill()
        client.wait()

    def reset_done() -> bool:
        try:
            control.reset()
        except Conflict:
            return False
        return True

    wait_for(reset_done, what="the action to end with its client")
    assert control.state()["gripper_width"] == pytest.approx(0.08)


INTO_THE_TABLE = [0.0, 1.6, 0.0, -0.3, 0.0, 1.9, 0.78]  # the Hand reaching down through it


def test_a_reset_into_the_table_is_refused_and_the_arm_stays_where_it_was(control, served):
    """A real arm cannot be set down inside the table: 409 naming what would be inside what,
    and a client reading states sees the arm where it was, not pressed against the table."""
    robot = connect(served.host)
    before = robot.read_once()
    with pytest.raises(Conflict, match=r"inside another body: finger\d into scene/table "
                                       r"\(\d+ mm deep\)") as refused:
        control.reset(q=INTO_THE_TABLE)
    assert refused.value.status == 409
    after = robot.read_once()
    assert after.q == before.q and max(map(abs, after.tau_ext_hat_filtered)) < 0.5
    assert control.reset(q=[0.0, 0.9, 0.0, -0.9, 0.0, 1.9, 0.78])["q"][1] == 0.9  # just clear
    # Nor folded into itself, every joint within its range: the hand inside link 2.
    with pytest.raises(Conflict, match=r"inside another body: link2 into hand"):
        control.reset(q=[0.0, -1.7, 0.0, -3.0, 0.0, 0.6, 0.0])
    del robot


def _program(host: str, control: Control) -> np.ndarray:
    """A velocity motion during which the arm is pushed and the cube moved, then a torque
    motion, then settings changed (which a reset must undo). Returns the last state of each
    motion: q, dq, tau_J, external torque."""
    robot = connect(host)
    seen = []
    motion = robot.start_joint_velocity_control(pylibfranka.ControllerMode.JointImpedance)
    motion.readOnce()
    for k in range(1, 400):
        state, _ = motion.readOnce()
        if k == 150:
            control.set_pose("cube", [0.5, 0.2, 0.15])
        if k == 300:  # between two cycles, as every change: the same cycle in every run
            control.push("link7", force=[6.0, 0.0, 0.0], duration=0.05)
        w = 0.3 * math.sin(math.pi * k / 399)
        command = pylibfranka.JointVelocities([w, 0.0, -w, w, 0.0, w, -w])
        command.motion_finished = k == 399
        motion.writeOnce(command)
    seen.append(state)
    del motion
    motion = robot.start_torque_control()
    motion.readOnce()
    for k in range(1, 300):
        state, _ = motion.readOnce()
        tau = 0.8 * math.sin(2 * math.pi * k / 299)
        command = pylibfranka.Torques([0.0, 0.0, 0.0, 0.0, tau, 0.0, tau])
        command.motion_finished = k == 299
        motion.writeOnce(command)
    seen.append(state)
    del motion
    robot.set_joint_impedance([1000.0] * 7)
    robot.set_collision_behavior([50.0] * 7, [60.0] * 7, [50.0] * 6, [60.0] * 6)
    robot.set_load(0.5, [0.0, 0.0, 0.05], [1e-3, 0.0, 0.0, 0.0, 1e-3, 0.0, 0.0, 0.0, 1e-3])
    del robot
    return np.concatenate([np.concatenate([s.q, s.dq, s.tau_J, s.tau_ext_hat_filtered])
                           for s in seen])


def test_after_a_reset_the_same_program_gives_the_same_bits_as_on_a_fresh_simulator():
    with running_sim("--clock", "lockstep") as sim:
        control = Control(sim.host)
        # The control API loads on its first call (~250 ms, more on a busy machine): made
        # mid-motion, in the first run only, it can outlast the cycle's window, and that cycle
        # is extrapolated in one run and not the other. Loaded first, both runs meet it alike.
        control.health()
        fresh = _program(sim.host, control)
        wait_for(lambda: not control.health()["client_connected"], what="the client to leave")
        control.reset()
        again = _program(sim.host, control)
    assert np.abs(fresh[21:28]).max() > 0.0  # the push shows at the first motion's end
    assert np.array_equal(fresh, again)

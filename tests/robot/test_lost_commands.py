"""A lost or late command never turns a smooth stream into a discontinuity (sans-IO).

The client here does each cycle what libfranka's control loop does: it evaluates its generator
at the state's time (message_id, so a skipped state moves it on two cycles) and low-pass
filters the value (100 Hz, libfranka's default) against the commanded signal the state shows,
q_d, O_T_EE_c, elbow_c or tau_J_d; torques then pass its torque-rate limiter, as
joint_impedance_control does. Chosen answers are withheld (lost) or delivered one cycle late,
with both enforcement switches on. A real robot drops a late answer and extrapolates the cycle
it missed, and its state then shows the extrapolated command: the filter anchors on that.
"""

from __future__ import annotations

import math
import random

import numpy as np
import pytest

from franka_sim.protocol.enums import MoveControllerMode as Ctrl
from franka_sim.protocol.enums import MoveMotionGeneratorMode as Gen
from franka_sim.protocol.enums import MoveStatus, RobotMode
from franka_sim.protocol.errors import ERROR_NAMES
from franka_sim.spatial import exp_rotation, rotation_vector
from support.harness import Harness

DT = 1e-3
GAIN = DT / (DT + 1 / (2 * math.pi * 100.0))  # libfranka's first-order filter at 100 Hz
MAX_TORQUE_STEP = (1000.0 - 1e-3) * DT  # its torque-rate limit, per cycle
SECONDS = 3.0
K_GAINS = np.array([600.0, 600.0, 600.0, 600.0, 250.0, 150.0, 50.0])  # joint_impedance_control
D_GAINS = np.array([50.0, 50.0, 50.0, 20.0, 20.0, 20.0, 10.0])


def _bump(t: float) -> float:
    """0 → 1 → 0 over SECONDS, starting and ending at rest."""
    return 0.5 * (1 - math.cos(2 * math.pi * min(t, SECONDS) / SECONDS))


def _revolution(t: float) -> float:
    """0 → 2π over SECONDS, starting and ending at rest."""
    s = min(t, SECONDS) / SECONDS
    return 2 * math.pi * s - math.sin(2 * math.pi * s)


def _pose(state, field="O_T_EE_c") -> np.ndarray:
    return np.reshape(np.array(state[field], dtype=float), (4, 4), order="F")


def _filter_pose(T: np.ndarray, T_last: np.ndarray) -> np.ndarray:
    out = T.copy()
    out[:3, 3] = GAIN * T[:3, 3] + (1 - GAIN) * T_last[:3, 3]
    out[:3, :3] = exp_rotation(GAIN * rotation_vector(T[:3, :3] @ T_last[:3, :3].T)) @ T_last[:3, :3]
    return out


class JointPositionClient:
    """Joints 4, 5 and 7 swing out 0.4 rad and back (peak ≈ 0.42 rad/s)."""

    move = (Ctrl.kJointImpedance, Gen.kJointPosition)

    def command(self, t, state, first, jump):
        if first:
            self.q0 = np.array(state["q_d"], dtype=float)
        q = self.q0.copy()
        q[[3, 4, 6]] += 0.4 * _bump(t)
        if not first:
            q = GAIN * q + (1 - GAIN) * np.array(state["q_d"], dtype=float)
        q[3] += jump * 0.01
        return {"q_c": q}


class CartesianPoseClient:
    """The EE along an arc of 0.3 m radius (libfranka's generate_cartesian_pose_motion, over a
    shorter time; peak ≈ 0.25 m/s)."""

    move = (Ctrl.kJointImpedance, Gen.kCartesianPosition)

    def command(self, t, state, first, jump):
        if first:
            self.T0 = _pose(state)
        angle = math.pi / 4 * _bump(t)
        T = self.T0.copy()
        T[0, 3] += 0.3 * math.sin(angle)
        T[2, 3] += 0.3 * (math.cos(angle) - 1)
        if not first:
            T = _filter_pose(T, _pose(state))
        T[2, 3] += jump * 0.005
        return {"O_T_EE_c": T.ravel(order="F")}


class ElbowClient:
    """The EE holds still while the elbow swings 0.3 rad out and back (libfranka's
    generate_elbow_motion, over a shorter time)."""

    move = (Ctrl.kJointImpedance, Gen.kCartesianPosition)

    def command(self, t, state, first, jump):
        if first:
            self.T0, self.elbow0 = _pose(state), np.array(state["elbow_c"], dtype=float)
        elbow = self.elbow0[0] + 0.3 * _bump(t)
        if not first:
            elbow = GAIN * elbow + (1 - GAIN) * float(state["elbow_c"][0])
        elbow += jump * 0.05
        return {"O_T_EE_c": self.T0.ravel(order="F"), "elbow_c": [elbow, self.elbow0[1]],
                "valid_elbow": True}


class TorqueAndCartesianClient:
    """libfranka's joint_impedance_control: a circle of 5 cm radius in the x-z plane from a
    Cartesian pose generator, tracked by the client's own joint impedance (torques)."""

    move = (Ctrl.kExternalController, Gen.kCartesianPosition)

    def command(self, t, state, first, jump):
        if first:
            self.T0 = _pose(state)
        phi = _revolution(t)
        T = self.T0.copy()
        T[0, 3] += 0.05 * math.sin(phi)
        T[2, 3] += 0.05 * (1 - math.cos(phi))
        if not first:
            T = _filter_pose(T, _pose(state))
        q, dq, q_d = (np.array(state[f], dtype=float) for f in ("q", "dq", "q_d"))
        tau_last = np.array(state["tau_J_d"], dtype=float)
        tau = K_GAINS * (q_d - q) - D_GAINS * dq
        tau = GAIN * tau + (1 - GAIN) * tau_last
        tau = np.clip(tau, tau_last - MAX_TORQUE_STEP, tau_last + MAX_TORQUE_STEP)
        tau[0] += jump * 5.0
        return {"O_T_EE_c": T.ravel(order="F"), "tau_J_d": tau}


CLIENTS = [JointPositionClient, CartesianPoseClient, ElbowClient, TorqueAndCartesianClient]


def run(client, *, lost=(), late=(), jump_at=None):
    """Run one motion with both switches on; returns (errors latched, the Move's status).

    `lost`: cycles whose answer never arrives; `late`: cycles whose answer arrives during the
    next cycle's window (after the robot released that one). Cycle 0 is the first state
    libfranka answers (the one after the state on which the modes flip)."""
    h = Harness(enforce_motion_limits=True, enforce_comm_constraints=True)
    assert h.move(*client.move) == MoveStatus.kMotionStarted
    h.cycle()  # the state on which the modes flip: libfranka reads it, never answers it
    h.cycle()
    id0 = int(h.state["message_id"])
    mailbox: dict[int, list] = {}
    last = round(SECONDS / DT)
    for _ in range(last + 50):
        state = h.state
        if state["robot_mode"] != RobotMode.kMove:
            break
        k = int(state["message_id"]) - id0
        fields = client.command(k * DT, state, k == 0, jump_at is not None and k >= jump_at)
        fields["motion_generation_finished"] = fields["torque_command_finished"] = k >= last
        if k not in lost:
            mailbox.setdefault(k + (k in late), []).append((int(state["message_id"]), fields))
        for message_id, answer in mailbox.pop(k, []):
            h.send(message_id=message_id, **answer)
        h.cycle()
    errors = [name for name, bit in zip(ERROR_NAMES, h.state["errors"]) if bit]
    return errors, [status for _, _, status in h.statuses()]


# Mid-motion, where the streams move fastest; and a few patterns around it.
PATTERNS = {
    "one lost": dict(lost={750}),
    "lost now and then": dict(lost={400, 751, 1100, 1900, 2600}),
    "three lost in a row": dict(lost={750, 751, 752}),
    "one late": dict(late={750}),
    "late twice in a row": dict(late={750, 751}),
    "late then lost": dict(late={750}, lost={751}),
}


@pytest.mark.parametrize("pattern", PATTERNS)
@pytest.mark.parametrize("client", CLIENTS, ids=lambda c: c.__name__)
def test_a_smooth_stream_survives_lost_and_late_answers(client, pattern):
    assert run(client(), **PATTERNS[pattern]) == ([], [MoveStatus.kSuccess])


@pytest.mark.parametrize("client, name", [
    (JointPositionClient, "joint_motion_generator_velocity_discontinuity"),
    (CartesianPoseClient, "cartesian_motion_generator_velocity_discontinuity"),
    (ElbowClient, "cartesian_motion_generator_elbow_limit_violation"),
    (TorqueAndCartesianClient, "controller_torque_discontinuity"),
], ids=lambda x: getattr(x, "__name__", ""))
def test_a_genuine_jump_still_aborts_by_name(client, name):
    errors, statuses = run(client(), lost={700}, jump_at=750)
    assert name in errors and statuses == [MoveStatus.kReflexAborted]


def test_after_a_lost_cycle_the_state_shows_the_extrapolated_command():
    """What libfranka anchors its next command on: where the stream was heading."""
    h = Harness()
    assert h.move(Ctrl.kJointImpedance, Gen.kCartesianPosition) == MoveStatus.kMotionStarted
    h.cycle(2)
    T, (e0, flag) = _pose(h.state), np.array(h.state["elbow_c"], dtype=float)
    for k in range(1, 101):  # 0.1 m/s along x, the elbow at 0.1 rad/s
        T[0, 3] += 1e-4
        h.send(O_T_EE_c=T.ravel(order="F"), elbow_c=[e0 + 1e-4 * k, flag], valid_elbow=True)
        h.cycle()
    h.cycle()  # nothing sent for this one
    assert float(h.state["O_T_EE_c"][12]) == pytest.approx(T[0, 3] + 1e-4, abs=1e-6)
    assert float(h.state["elbow_c"][0]) == pytest.approx(e0 + 1e-4 * 101, abs=1e-6)
    assert float(h.state["delbow_c"][0]) == pytest.approx(0.1, abs=1e-3)


def test_a_gap_carries_the_reference_on_within_the_acceleration_limit():
    """Half the answers late (a jittered link): q_c differenced against an extrapolated q_d can
    exceed the joint acceleration limit for a smooth client; carried on through each gap
    unbounded, it once grew gap after gap. Each extrapolated cycle stays within the limit
    (10 rad/s², the FR3's), enforcement off as by default."""
    h = Harness()
    client = JointPositionClient()
    assert h.move(*client.move) == MoveStatus.kMotionStarted
    h.cycle(2)
    id0 = int(h.state["message_id"])
    draw = random.Random(8)  # (a draw under which the unbounded reference ran away)
    late = {k for k in range(1100) if draw.random() < 0.5}
    mailbox: dict[int, list] = {}
    extrapolated, q_d = [], []
    for _ in range(1000):
        state = h.state
        k = int(state["message_id"]) - id0
        fields = client.command(k * DT, state, k == 0, False)
        mailbox.setdefault(k + (k in late), []).append((int(state["message_id"]), fields))
        for message_id, answer in mailbox.pop(k, []):
            h.send(message_id=message_id, **answer)
        h.cycle()
        if k in late:  # the state now out shows cycle k's command: extrapolated
            extrapolated.append(float(np.max(np.abs(np.array(h.state["ddq_d"])))))
        q_d.append(np.array(h.state["q_d"], dtype=float))
    assert len(extrapolated) > 300 and max(extrapolated) <= 10.0 + 1e-9
    # and the reference stays on the client's way (it swings joints out 0.4 rad at most)
    assert float(np.max(np.abs(np.array(q_d) - client.q0))) < 0.45


@pytest.mark.parametrize("enforce", [False, True])
def test_a_client_heard_only_late_ends_its_motion_by_its_finish(enforce, caplog):
    """Every answer a cycle late: none applies. Enforced, the 20th lost cycle aborts, as on the
    robot. Not enforced, the arm is held (braked to rest) and one line says why; libfranka
    then sends its finish again each cycle until the state shows the motion ended, so a late
    finish ends it (or the client would wait for ever)."""
    h = Harness(enforce_comm_constraints=enforce)
    assert h.move(Ctrl.kJointImpedance, Gen.kJointPosition) == MoveStatus.kMotionStarted
    h.cycle(2)
    q0 = np.array(h.state["q_d"], dtype=float)
    for k in range(40):
        answered = int(h.state["message_id"])
        h.cycle()  # its window closes unanswered
        q_c = q0.copy()
        q_c[6] += 1e-4 * k
        h.send(message_id=answered, q_c=q_c, motion_generation_finished=k >= 30)
        if h.state["robot_mode"] != RobotMode.kMove:
            break
    h.cycle()
    statuses = [status for _, _, status in h.statuses()]
    if enforce:
        assert statuses == [MoveStatus.kReflexAborted]
        assert h.state["errors"][ERROR_NAMES.index("communication_constraints_violation")]
        return
    assert statuses == [MoveStatus.kSuccess] and h.state["robot_mode"] == RobotMode.kIdle
    assert np.allclose(np.array(h.state["q_d"], dtype=float), q0, atol=1e-9)  # never moved
    said = [r.getMessage() for r in caplog.records]
    assert sum("no command on time for 20 cycles" in line for line in said) == 1
    assert sum("motion finished by a late command" in line for line in said) == 1


def test_a_gap_carries_the_cartesian_signals_on_within_their_limits():
    """The Cartesian pose's twist and the elbow continue through a gap at their last rate of
    change, within the robot's envelope (FR3: 9 m/s², 17 rad/s², the elbow's 10 rad/s²)."""
    from franka_sim.robot.cartesian import CartesianTarget
    from franka_sim.robot.checks.figures import FR3
    from franka_sim.robot.motion import ElbowCommand

    limits = np.repeat([FR3.translation.acceleration, FR3.rotation.acceleration], 3)
    target = CartesianTarget(np.eye(4), limits)
    for x in (0.0, 0.0, 0.01):  # a 1 cm jump in one cycle: 10 m/s after 0, 10⁴ m/s²
        pose = np.eye(4)
        pose[0, 3] = x
        target.set_pose(pose)
    before = target.twist.copy()
    target.extrapolate()
    assert (target.twist[0] - before[0]) / DT == pytest.approx(FR3.translation.acceleration)
    elbow = ElbowCommand(0.0, -1.0, max_acceleration=FR3.elbow.acceleration)
    elbow.follow(0.01, -1.0)  # 10 rad/s in one cycle
    elbow.extrapolate()
    assert elbow.position == pytest.approx(0.01 + (10.0 + FR3.elbow.acceleration * DT) * DT)


def test_after_a_gap_the_stream_is_differenced_over_the_cycles_between():
    """The client's next point after a gap is differenced against its last one over the
    cycles between, not against what the gap carried on: a stream at 0.1 rad/s stays at
    0.1 rad/s (differenced against the extrapolation it read 0.07 rad/s and −50 rad/s²)."""
    from franka_sim.robot.motion import JointReference

    reference = JointReference(np.zeros(7), 10.0, 2.62)
    reference.follow_position(np.full(7, 1e-4))  # 0.1 rad/s from rest: 100 rad/s² carried on
    reference.extrapolate()
    reference.extrapolate()
    reference.follow_position(np.full(7, 4e-4))  # three cycles on, still 0.1 rad/s
    np.testing.assert_allclose(reference.dq_d, 0.1)
    np.testing.assert_allclose(reference.ddq_d, 0.0, atol=1e-9)
    reference.follow_position(np.full(7, 5e-4))  # and the next cycle as ever
    np.testing.assert_allclose(reference.dq_d, 0.1)


def test_a_gap_carries_the_reference_on_within_the_velocity_limit():
    """A step the robot let through (5 rad/s in one cycle) is carried on at the joints'
    velocity limit at most."""
    from franka_sim.robot.motion import JointReference

    limits = np.array([2.62, 2.62, 2.62, 2.62, 5.26, 4.18, 5.26])
    reference = JointReference(np.zeros(7), 10.0, limits)
    reference.follow_position(np.full(7, 5e-3))
    reference.extrapolate()
    assert np.all(np.abs(reference.dq_d) <= limits)
    # a joint held at its limit is not pushed on (its feed-forward, its published ddq_d)
    np.testing.assert_array_equal(reference.ddq_d, np.where(limits < 5.0, 0.0, 10.0))


def test_after_a_gap_the_cartesian_stream_is_differenced_over_the_cycles_between():
    """The same for the Cartesian pose and the elbow: a client at 0.1 m/s and 0.1 rad/s is
    read at that speed after two cycles carried on."""
    from franka_sim.robot.cartesian import CartesianTarget
    from franka_sim.robot.checks.figures import FR3
    from franka_sim.robot.motion import ElbowCommand

    target = CartesianTarget(np.eye(4), np.repeat([FR3.translation.acceleration,
                                                   FR3.rotation.acceleration], 3))
    elbow = ElbowCommand(0.0, -1.0, max_acceleration=FR3.elbow.acceleration)
    for k in (1, 2):  # 0.1 m/s from rest, 0.1 rad/s
        pose = np.eye(4)
        pose[0, 3] = k * 1e-4
        target.set_pose(pose)
        elbow.follow(k * 1e-4, -1.0)
    for _ in range(2):
        target.extrapolate()
        elbow.extrapolate()
    pose[0, 3] = 5e-4
    target.set_pose(pose)
    elbow.follow(5e-4, -1.0)
    assert target.twist[0] == pytest.approx(0.1)
    target.extrapolate()  # at 0.1 m/s, not accelerating
    assert target.pose[0, 3] == pytest.approx(6e-4) and target.twist[0] == pytest.approx(0.1)
    elbow.extrapolate()
    assert elbow.position == pytest.approx(6e-4)

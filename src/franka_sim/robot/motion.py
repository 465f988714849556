"""A running Move: its mode pair, and the desired signals its command stream generates.

The robot turns each applied RobotCommand into desired joint signals (q_d, dq_d, ddq_d) or a
desired torque (tau_J_d), differentiating by backward differences at the 1 ms cycle. A cycle
the client missed is filled in as the FCI fills it: motion signals continue at constant
acceleration, torques repeat. After 20 consecutive misses the robot stops extrapolating (that is
where it would abort): it brakes the arm to rest from where it measures it, as its own stop does
(every joint slowing together along its way, none faster than BRAKE_DECELERATION), and holds it
there until the client is heard again.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from franka_sim.kernels import joint_follow
from franka_sim.physics.backend import Measured
from franka_sim.robot.async_target import AsyncTarget
from franka_sim.robot.cartesian import CartesianTarget, dls_step, ee_jacobian
from franka_sim.robot.checks.joint_table import JointLimitTable
from franka_sim.protocol.enums import (
    STATE_CONTROLLER_MODE,
    STATE_MOTION_GENERATOR_MODE,
    ControllerMode,
    MotionGeneratorMode,
    MoveControllerMode,
    MoveMotionGeneratorMode,
    MoveStatus,
)
from franka_sim.protocol.timing import CYCLE_PERIOD as DT
from franka_sim.spatial import pose_error

if TYPE_CHECKING:
    from franka_sim.robot.checks.figures import MotionFigures

MAX_EXTRAPOLATED_CYCLES = 20
# How fast the robot's own stop slows a joint: the FR3's joint acceleration limit (every joint,
# robot/checks/figures.py). From 0.3 rad/s it stops in 30 ms, 4.5 mrad on.
BRAKE_DECELERATION = 10.0  # rad/s²
# A finished motion must end at rest: |dq_d| above this on the finishing cycle is "still moving".
FINISH_VELOCITY_TOLERANCE = 0.05  # rad/s

JOINT_GENERATORS = (MoveMotionGeneratorMode.kJointPosition, MoveMotionGeneratorMode.kJointVelocity)
CARTESIAN_GENERATORS = (
    MoveMotionGeneratorMode.kCartesianPosition, MoveMotionGeneratorMode.kCartesianVelocity,
)


class MoveRejected(Exception):
    """A Move the robot refuses; carries the MoveStatus to answer with."""

    def __init__(self, status: MoveStatus, reason: str) -> None:
        super().__init__(reason)
        self.status = status


@dataclass(frozen=True)
class MoveSpec:
    controller: MoveControllerMode
    generator: MoveMotionGeneratorMode
    use_async: bool
    maximum_velocity: np.ndarray

    @property
    def state_modes(self) -> tuple[MotionGeneratorMode, ControllerMode]:
        return STATE_MOTION_GENERATOR_MODE[self.generator], STATE_CONTROLLER_MODE[self.controller]

    @property
    def torque_controlled(self) -> bool:
        return self.controller is MoveControllerMode.kExternalController


def parse_move(request) -> MoveSpec:
    """Validate a Move request's mode pair and arguments as the robot does."""
    invalid = MoveStatus.kInvalidArgumentRejected
    try:
        controller = MoveControllerMode(int(request.controller_mode))
        generator = MoveMotionGeneratorMode(int(request.motion_generator_mode))
    except ValueError as exc:
        raise MoveRejected(invalid, f"unknown mode: {exc}") from None
    if generator is MoveMotionGeneratorMode.kNone and controller is not MoveControllerMode.kExternalController:
        raise MoveRejected(invalid, "no motion generator requires the external controller")
    deviations = [
        float(v) for d in (request.maximum_path_deviation, request.maximum_goal_pose_deviation)
        for v in (d.translation, d.rotation, d.elbow)
    ]
    if not np.all(np.isfinite(deviations)) or min(deviations) < 0:
        raise MoveRejected(invalid, "path/goal deviations must be finite and non-negative")
    v_max = np.asarray(request.maximum_velocity, dtype=float)
    use_async = bool(request.use_async_motion_generator)
    if use_async:
        if generator is not MoveMotionGeneratorMode.kJointPosition or controller is MoveControllerMode.kExternalController:
            raise MoveRejected(invalid, "the async generator is a joint-position motion under an internal controller")
        if not np.all(np.isfinite(v_max)) or np.any(v_max <= 0):
            raise MoveRejected(invalid, "async motion needs a positive finite maximum_velocity")
    return MoveSpec(controller, generator, use_async, v_max)


class JointReference:
    """Desired joint signals of a joint-space generator, with the FCI's gap filling.

    q_d = q_c, differenced cycle by cycle; after a gap (cycles carried on or braked without a
    command) the next command is differenced against the stream's last, over the cycles
    between: against what the robot carried on, a smooth client's next point read as a step
    of rad/s, which the next gap carried on, gap after gap, under a jittered link (the arm
    thrown about). The real robot aborts on such a step (`--enforce-motion-limits`; the checks
    difference the stream between its commands too); one that lets the motion go on stays on
    the stream. (A Cartesian generator's IK feeds this every cycle, gaps included: there the
    Cartesian target keeps the stream, robot/cartesian.py.)
    """

    def __init__(self, q_start: np.ndarray, max_acceleration: np.ndarray | float = np.inf,
                 max_velocity: np.ndarray | float = np.inf) -> None:
        self.q_d = np.array(q_start, dtype=float)
        self.dq_d = np.zeros(7)
        self.ddq_d = np.zeros(7)
        # rad/s², rad/s per joint: what a gap carries on
        self.max_acceleration, self.max_velocity = max_acceleration, max_velocity
        # The stream's last point and velocity, and the cycles without a command since
        self._q_c, self._dq_c, self._missed = self.q_d, self.dq_d, 0

    def follow_position(self, q_c: np.ndarray) -> None:
        """q_d = q_c, its first two differences (fresh arrays: a drive command keeps them)."""
        signals = np.empty(21)
        if self._missed:
            joint_follow(q_c, self._q_c, self._dq_c, (self._missed + 1) * DT, signals)
        else:
            joint_follow(q_c, self.q_d, self.dq_d, DT, signals)
        self.q_d, self.dq_d, self.ddq_d = signals.reshape(3, 7)
        self._q_c, self._dq_c, self._missed = self.q_d, self.dq_d, 0

    def follow_velocity(self, dq_c: np.ndarray) -> None:
        dq = np.array(dq_c, dtype=float)
        if self._missed:
            self.ddq_d = (dq - self._dq_c) / ((self._missed + 1) * DT)
        else:
            self.ddq_d = (dq - self.dq_d) / DT
        self.dq_d = self._dq_c = dq
        self._missed = 0
        self.q_d = self.q_d + dq * DT

    def restart(self, q: np.ndarray, dq: np.ndarray) -> None:
        """The robot's own stop begins from the arm as measured (the stream's memory kept)."""
        self.q_d, self.dq_d = np.array(q, dtype=float), np.array(dq, dtype=float)
        self.ddq_d = np.zeros(7)

    def extrapolate(self) -> None:
        """A missed cycle: continue at the acceleration frozen when the gap began, within the
        robot's joint acceleration and velocity limits (a client's own stream may exceed
        them: what a gap carries on may not)."""
        limit, fastest = self.max_acceleration, self.max_velocity
        ddq = np.clip(self.ddq_d, -limit, limit)
        dq = self.dq_d + ddq * DT
        self.dq_d = np.clip(dq, -fastest, fastest)
        self.ddq_d = np.where(self.dq_d == dq, ddq, 0.0)  # (held at its limit: no push on)
        self.q_d = self.q_d + self.dq_d * DT
        self._missed += 1

    def brake(self) -> None:
        """One cycle of the robot's stop: every joint slows by the same share, so they reach
        rest together and the arm stays on its way, none slowing faster than
        BRAKE_DECELERATION."""
        self._missed += 1
        dq = self.dq_d
        to_rest = float(np.max(np.abs(dq))) / BRAKE_DECELERATION  # s
        if to_rest == 0.0:
            self.ddq_d = np.zeros(7)
            return
        slower = dq * (1.0 - DT / to_rest) if to_rest > DT else np.zeros(7)
        self.ddq_d = (slower - dq) / DT
        self.dq_d = slower
        self.q_d = self.q_d + slower * DT

    @property
    def at_rest(self) -> bool:
        return not self.dq_d.any()


class ElbowCommand:
    """The commanded elbow (elbow_c) as the robot holds it: the client's, or on a missed cycle
    extrapolated at constant acceleration like every motion signal. Published as elbow_c, it is
    what libfranka's filter and rate limiter anchor the next command on, so a missed cycle must
    leave it where the stream was heading, not where the client last was. After a gap the
    client's next elbow is differenced against its last, over the cycles between (as q_c is:
    JointReference)."""

    __slots__ = ("position", "flag", "_velocity", "_acceleration", "max_acceleration",
                 "max_velocity", "_stream", "_missed")

    def __init__(self, position: float, flag: float, velocity: float = 0.0,
                 max_acceleration: float = math.inf, max_velocity: float = math.inf) -> None:
        self.position, self.flag = position, flag
        self._velocity, self._acceleration = velocity, 0.0
        # rad/s², rad/s: what a gap carries on (as q_d's)
        self.max_acceleration, self.max_velocity = max_acceleration, max_velocity
        self._stream, self._missed = (position, velocity), 0  # the client's last, cycles since

    def follow(self, position: float, flag: float) -> None:
        if self._missed:
            before, velocity_before = self._stream
        else:
            before, velocity_before = self.position, self._velocity
        interval = (self._missed + 1) * DT
        velocity = (position - before) / interval
        self._acceleration = (velocity - velocity_before) / interval
        self._velocity, self.position, self.flag = velocity, position, flag
        self._missed = 0

    def skip(self) -> None:
        """A cycle without a command (the robot carries on, or brakes the joints)."""
        if not self._missed:
            self._stream = (self.position, self._velocity)
        self._missed += 1

    def extrapolate(self) -> None:
        self.skip()
        limit, fastest = self.max_acceleration, self.max_velocity
        acceleration = min(max(self._acceleration, -limit), limit)
        velocity = self._velocity + acceleration * DT
        self._velocity = min(max(velocity, -fastest), fastest)
        self._acceleration = acceleration if self._velocity == velocity else 0.0
        self.position += self._velocity * DT


class Motion:
    """One Move from kMotionStarted to its final status.

    Cartesian generators keep a CartesianTarget and turn it into q_d by one IK step per cycle;
    `kinematics` (the flange pose and Jacobian at the current q_d, computed by the physics with
    each step) and `F_T_EE` (latched at the Move) are what that step needs.
    """

    def __init__(self, command_id: int, spec: MoveSpec, q_start: np.ndarray,
                 O_T_EE_start: np.ndarray | None = None, F_T_EE: np.ndarray | None = None, *,
                 figures: MotionFigures, joint_velocity: np.ndarray | float = np.inf,
                 limits: JointLimitTable | None = None) -> None:
        self.command_id = command_id
        self.spec = spec
        self.running = False  # modes flip on the first published cycle after the Move
        self.first_state: int | None = None  # message_id of that cycle
        # The robot's limits (its kind's figures, its URDF's joint velocities) bound what a
        # gap carries on.
        self._elbow = figures.elbow
        self.reference = JointReference(q_start, figures.joint_acceleration, joint_velocity)
        self.cartesian = (
            CartesianTarget(O_T_EE_start, np.repeat(
                [figures.translation.acceleration, figures.rotation.acceleration], 3),
                np.repeat([figures.translation.velocity, figures.rotation.velocity], 3))
            if spec.generator in CARTESIAN_GENERATORS else None
        )
        self.F_T_EE = np.eye(4) if F_T_EE is None else F_T_EE
        self.kinematics: tuple[np.ndarray, np.ndarray] | None = None
        self.elbow: ElbowCommand | None = None  # while the client commands one
        self.async_target = (
            AsyncTarget(self.reference, spec.maximum_velocity, limits) if spec.use_async
            else None
        )
        self.tau_J_d = np.zeros(7)
        self.last_command = None
        self.finished = False
        # The client's commands stopped coming: past MAX_EXTRAPOLATED_CYCLES the robot brakes
        # the arm (its joint impedance follows `reference` braking to rest) until it hears
        # from the client again; `orphaned`: it never will (the client closed its connection).
        self.braking = False
        self.orphaned = False
        # What a command means for this Move, decided once: the generator's signal to follow
        # (None: torque only), whether it carries tau_J_d, and which flag finishes it.
        generator = spec.generator
        self._follow = (
            self._follow_async if spec.use_async
            else self._follow_position if generator is MoveMotionGeneratorMode.kJointPosition
            else self._follow_velocity if generator is MoveMotionGeneratorMode.kJointVelocity
            else self._follow_cartesian if self.cartesian is not None
            else None
        )
        self._torque_controlled = spec.torque_controlled
        self._finished_flag = ("torque_command_finished"
                               if generator is MoveMotionGeneratorMode.kNone
                               else "motion_generation_finished")

    def apply(self, command) -> None:
        """Take the command the client sent for this cycle."""
        self.last_command = command
        self.braking = False
        if self._follow is not None:
            self._follow(command)
        if self._torque_controlled:
            self.tau_J_d = np.array(command["tau_J_d"], dtype=float)
        self.finished = bool(command[self._finished_flag])

    def asks_to_finish(self, command) -> bool:
        """Whether `command` carries this Move's finish flag (its values aside)."""
        return bool(command[self._finished_flag])

    def _follow_async(self, command) -> None:
        if not command["motion_generation_finished"]:  # (libfranka's stopControl sends zeros)
            self.async_target.target = command["q_c"]
        self.async_target.advance()

    def _follow_position(self, command) -> None:
        self.reference.follow_position(np.asarray(command["q_c"], dtype=float))

    def _follow_velocity(self, command) -> None:
        self.reference.follow_velocity(np.asarray(command["dq_c"], dtype=float))

    def _follow_cartesian(self, command) -> None:
        if self.spec.generator is MoveMotionGeneratorMode.kCartesianPosition:
            self.cartesian.set_pose(np.reshape(command["O_T_EE_c"], (4, 4), order="F"))
        else:
            self.cartesian.set_twist(command["O_dP_EE_c"])
        if not command["valid_elbow"]:
            self.elbow = None
        else:
            position, flag = command["elbow_c"].tolist()
            if self.elbow is None:
                self.elbow = ElbowCommand(position, flag,
                                          max_acceleration=self._elbow.acceleration,
                                          max_velocity=self._elbow.velocity)
            else:
                self.elbow.follow(position, flag)
        self._solve()

    def miss(self, consecutive: int, measured: Measured | None = None) -> None:
        """No command for this cycle, `consecutive` in a row: extrapolate (torques are simply
        held); past MAX_EXTRAPOLATED_CYCLES brake from the arm as measured. An async motion's
        gaps are normal: its generator goes on, unless its client is gone."""
        if self.async_target is not None and not self.orphaned:
            self.async_target.advance()
        elif self.braking or consecutive > MAX_EXTRAPOLATED_CYCLES:
            if not self.braking:
                self.braking = True
                if measured is not None:  # the stop starts from the arm as measured, any mode
                    self.reference.restart(measured.q, measured.dq)
            self.reference.brake()
            if self.cartesian is not None:
                self.cartesian.skip()
                if self.elbow is not None:
                    self.elbow.skip()
        elif self.spec.generator in JOINT_GENERATORS:
            self.reference.extrapolate()
        elif self.cartesian is not None:
            self.cartesian.extrapolate()
            if self.elbow is not None:
                self.elbow.extrapolate()
            self._solve(carried_on=True)

    def _solve(self, carried_on: bool = False) -> None:
        """One IK step from q_d toward the Cartesian target (kinematics evaluated at q_d); a
        step the robot takes on its own (`carried_on`: a gap) within its joint velocities."""
        if self.kinematics is None:
            return
        O_T_F_d, J_F_d = self.kinematics
        O_T_EE_d = O_T_F_d @ self.F_T_EE
        J = ee_jacobian(O_T_F_d, J_F_d, self.F_T_EE)
        q_d = self.reference.q_d
        elbow_error = None if self.elbow is None else self.elbow.position - q_d[2]
        dq = dls_step(J, pose_error(self.cartesian.pose, O_T_EE_d), elbow_error)
        if carried_on:
            fastest = self.reference.max_velocity * DT
            dq = np.clip(dq, -fastest, fastest)
        self.reference.follow_position(q_d + dq)

    def still_moving(self) -> bool:
        """Whether a finishing command leaves the generator moving (the robot refuses that)."""
        if self.spec.generator is MoveMotionGeneratorMode.kNone:
            return False
        return bool(np.max(np.abs(self.reference.dq_d)) > FINISH_VELOCITY_TOLERANCE)

"""The robot-side generator behind `use_async_motion_generator` (libfranka's async position
control): the client sets joint targets, as rarely as it likes, and the robot moves there.

Every joint moves toward its target under the Move's maximum_velocity and a fixed acceleration,
braking so it arrives at rest. It is the robot's own generator, so it keeps the robot's own
limits: no joint runs toward an end faster than the URDF's velocity law allows where it is, and
a target is reached only where that law lets the joint move at all (a target beyond, or at an
end, is approached to there: checks/joint_commands.py judges the target itself). Gaps in the
command stream are normal here: the generator simply keeps going.
"""

from __future__ import annotations

import numpy as np

from franka_sim.protocol.timing import CYCLE_PERIOD as DT
from franka_sim.robot.checks.joint_table import JointLimitTable

# Acceleration of the generator (the FR3's joint acceleration limit is 10 rad/s²; the generator
# keeps well inside it). The robot's own profile is unpublished.
ASYNC_ACCELERATION = 5.0  # rad/s²
# It plans its stops a little gentler than it may accelerate, so that a cycle's step (a
# discrete reference catching up with a curve) never leaves it behind the stop it planned.
PLANNED_DECELERATION = 0.8 * ASYNC_ACCELERATION
# How far inside the stretch where the velocity law allows any speed a target is held.
END_MARGIN = 1e-3  # rad


class AsyncTarget:
    def __init__(self, reference, maximum_velocity, limits: JointLimitTable | None) -> None:
        """`reference`: the motion's JointReference, which this generator moves."""
        self.reference = reference
        self.v_max = np.asarray(maximum_velocity, dtype=float)
        self._limits = limits
        if limits is None:
            self._lowest, self._highest = -np.inf, np.inf
        else:
            # The law allows 0 rad/s within offset²/(2·deceleration) of each end.
            dead = limits.velocity_offset ** 2 / (2.0 * limits.deceleration) + END_MARGIN
            self._lowest, self._highest = limits.lower + dead, limits.upper - dead
            self._braking = _BrakingCurve(limits, PLANNED_DECELERATION)
        self._target = reference.q_d.copy()

    @property
    def target(self) -> np.ndarray:
        return self._target

    @target.setter
    def target(self, q_c) -> None:
        self._target = np.clip(np.asarray(q_c, dtype=float), self._lowest, self._highest)

    def advance(self) -> None:
        ref = self.reference
        error = self._target - ref.q_d
        # Fastest speed from which the joint can still stop at the target.
        v_stop = np.sqrt(2.0 * PLANNED_DECELERATION * np.abs(error))
        speed = np.minimum(self.v_max, v_stop)
        if self._limits is not None:
            room = self._braking.speeds(ref.q_d)
            speed = np.minimum(speed, np.where(error > 0, room[:7], room[7:]))
        v_goal = np.sign(error) * speed
        dv = np.clip(v_goal - ref.dq_d, -ASYNC_ACCELERATION * DT, ASYNC_ACCELERATION * DT)
        dq = ref.dq_d + dv
        arrived = np.abs(error) <= np.abs(dq) * DT
        dq = np.where(arrived, 0.0, dq)
        q = np.where(arrived, self._target, ref.q_d + dq * DT)
        ref.ddq_d = (dq - ref.dq_d) / DT
        ref.dq_d = dq
        ref.q_d = q


class _BrakingCurve:
    """The fastest speed toward each end from which a joint slowing at `acceleration` at most
    stays under the velocity law all the way: where the law falls faster than that (a joint
    whose deceleration limit D exceeds it), the curve leaves the law at the gap g* where the
    law's own slope in time equals the acceleration, and brakes from there on a parabola.

    With the law v(g) = √(2·D·g) − offset, v² + 2·A·(g − p) over the positions p ahead is least
    where √(2·D·p) = offset / (1 − A/D): v(g*) = offset·A / (D − A).
    """

    def __init__(self, limits: JointLimitTable, acceleration: float) -> None:
        self._limits = limits
        D, offset = np.tile(limits.deceleration, 2), np.tile(limits.velocity_offset, 2)
        steeper = D > acceleration
        ratio = np.where(steeper, acceleration / D, 0.0)
        self._g_star = np.where(steeper, (offset / (1.0 - ratio)) ** 2 / (2.0 * D), np.inf)
        self._v_star_squared = np.where(steeper, (offset * ratio / (1.0 - ratio)) ** 2, 0.0)
        self._two_a = 2.0 * acceleration

    def speeds(self, q) -> np.ndarray:
        """(14,) speeds allowed at q toward each end, upper ends first (as speed_limits)."""
        signed = self._limits.signed(q)
        law = self._limits.speed_limits(signed)
        gap = self._limits.ends - signed
        far = gap > self._g_star
        brake = np.sqrt(self._v_star_squared + self._two_a * np.where(far, gap - self._g_star, 0.0))
        return np.where(far, np.minimum(law, brake), law)

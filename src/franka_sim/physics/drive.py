"""The joint drives' law, whatever engine integrates it: the torque a JointCommand asks of the
motors for one step, from the arm's state at the start of the step.

tau = tau_ff + K·(q_d − q) + D·(dq_d − dq) + g(q) [+ M(q)·ddq_d + c(q, dq) + the friction the
robot compensates at dq_d, while a generator runs] [+ the declared load's g(q)], saturated at the
motors' torque limits, minus the joints' residual friction at dq (physics/friction.py); tau_ff
reaches the joint as the motors follow it, at MOTOR_TORQUE_RATE. physics/arm.py (MuJoCo) and
physics/genesis/arm.py apply it the same way; each engine supplies g(q) and the feed-forward
M(q)·ddq_d + c(q, dq) from its own dynamics.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from franka_sim.kernels import drive_follow, drive_impedance, saturate_less
from franka_sim.physics.backend import NO_GAINS, JointCommand
from franka_sim.physics.friction import JointFriction

SETTLE = 1e-6  # rad and rad/s (m and m/s for a finger): the idle hold's standstill band
# (physics/arm.py, "Standstill", says why this size)

# Nm/s: the fastest a motor follows a change of the controller's torque (the FR3's torque-rate
# figure, tests/data/fr3_limits.md); a step in tau_ff reaches the joint as a ramp at this rate.
MOTOR_TORQUE_RATE = 1000.0


class DriveLaw:
    """One arm's drives. `q`, `dq`, `applied` and `gcomp` are the engine's (7,) arrays (views
    the engine keeps current: the state at the start of the step, where the torque goes, g(q));
    `feed_forward(ddq_d)` adds M(q)·ddq_d + c(q, dq) into `applied`."""

    def __init__(self, q: np.ndarray, dq: np.ndarray, applied: np.ndarray, gcomp: np.ndarray,
                 tau_max: np.ndarray, timestep: float, friction: JointFriction,
                 feed_forward: Callable[[np.ndarray], None]) -> None:
        self._q, self._dq, self._applied, self._gcomp = q, dq, applied, gcomp
        self._tau_max, self._tau_min = tau_max, -tau_max
        self.friction = friction
        self._feed_forward = feed_forward
        # The controller's torque as the motors give it: tau_ff followed at MOTOR_TORQUE_RATE.
        self.ff = np.zeros(7)
        self._ff_step = MOTOR_TORQUE_RATE * float(timestep)  # Nm per step
        self._tmp = np.zeros(7)

    def apply(self, cmd: JointCommand, load_gravity: np.ndarray | None = None) -> None:
        """The drive torque for this step into `applied` (g(q) prepared at this q);
        `load_gravity`: the declared load's g(q) when the command declares one (else None)."""
        applied = self._applied
        # tau_ff as the motors give it this step (ff: within a step's rate of the last; tau_ff
        # is finite, the robot drops a non-finite command, robot/fci.py), plus g(q) and, but in
        # torque control, the impedance terms (kernels/: one call each).
        if cmd.K is NO_GAINS:
            drive_follow(applied, self.ff, cmd.tau_ff, self._ff_step, self._gcomp)
        else:
            drive_impedance(applied, self.ff, cmd.tau_ff, self._ff_step, self._gcomp,
                            cmd.q_d, self._q, cmd.K, cmd.dq_d, self._dq, cmd.D)
        if cmd.ddq_d is not None:
            self._feed_forward(cmd.ddq_d)
            applied += self.friction.at(cmd.dq_d, self._tmp)  # the robot's own compensation
        if load_gravity is not None:
            applied += load_gravity
        # The motors saturate at their torque limits, whatever the command asked (an absurd
        # one, applied when limits are only logged, must not blow up the physics; it is finite,
        # robot/fci.py COMMAND_RANGE); the friction acts on the link, past the motor.
        saturate_less(applied, self._tau_max, self._tau_min, self.friction.step(self._dq))

    def same_inputs(self, last: JointCommand | None, cmd: JointCommand, tool_cmd,
                    tool) -> bool:
        """`cmd` (and the tool's command `tool_cmd`, None: kept) asks for what the last step's
        `last` did: the same arrays, compared by identity (the core replaces a command's
        arrays, never mutates them: physics/engine.py), and no torque still being followed."""
        if last is None or not (tool_cmd is None or (
                tool is not None and tool_cmd == tool.command)):
            return False
        return (cmd is last or (
            cmd.tau_ff is last.tau_ff and cmd.q_d is last.q_d and cmd.dq_d is last.dq_d
            and cmd.K is last.K and cmd.D is last.D and cmd.load is last.load
            and cmd.ddq_d is last.ddq_d)) and np.array_equal(self.ff, cmd.tau_ff)

    def settle(self, cmd: JointCommand, tool_cmd, tool, band: float) -> bool:
        """The idle hold's standstill: within `band` of the hold `cmd.q_d` and slower than it,
        the arm is put exactly there, at rest (and its tool likewise, `tool.settle`). True if
        a position changed."""
        tmp, q, dq = self._tmp, self._q, self._dq
        moved = False
        if (np.abs(dq, out=tmp).max() < band
                and np.abs(np.subtract(q, cmd.q_d, out=tmp), out=tmp).max() < band):
            moved = not np.array_equal(q, cmd.q_d)
            q[:] = cmd.q_d
            dq[:] = 0.0
        if tool is None:
            return moved
        return tool.settle(tool_cmd, band) or moved

    def rest(self) -> None:
        """No torque followed any more (a reset, the idle drive at rest)."""
        self.ff.fill(0.0)

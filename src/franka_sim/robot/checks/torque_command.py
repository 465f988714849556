"""tau_J_d under the external controller: its rate, and its range as only recommended.

A torque motion starts from tau_J_d = 0. The FCI lists τ max as only *recommended* under torque
control, so a torque over the URDF effort is reported without aborting (see figures.py).
"""

from __future__ import annotations

import numpy as np

from franka_sim.description.urdf import ArmDescription
from franka_sim.kernels import torque_inside
from franka_sim.protocol.timing import CYCLE_PERIOD
from franka_sim.robot.checks.checker import CommandChecker
from franka_sim.robot.checks.figures import (
    TORQUE_MAGNITUDE, TORQUE_RANGE_ERROR, TORQUE_RATE, TORQUE_RATE_ERROR, echo_slack,
)
from franka_sim.robot.checks.joint_table import joint_limits
from franka_sim.robot.checks.violation import Violation


class TorqueChecker(CommandChecker):
    def __init__(self, desc: ArmDescription) -> None:
        self._table = table = joint_limits(desc)
        self._tau = np.zeros(14)  # signed, as JointLimitTable's vectors
        self._effort = np.tile(table.effort, 2)
        self._rate_thr = TORQUE_RATE + echo_slack(TORQUE_MAGNITUDE, 1)

    def judge(self, command, n: int, out: list) -> None:
        tau, dt = np.empty(14), n * CYCLE_PERIOD
        if not torque_inside(command["tau_J_d"], self._tau, tau, self._effort, self._rate_thr,
                             dt):
            rate = (tau - self._tau) / dt
            for i in range(7):
                if not abs(rate[i]) <= self._rate_thr:
                    out.append(Violation(TORQUE_RATE_ERROR, f"joint {i + 1}", float(abs(rate[i])),
                                         TORQUE_RATE, quantity="torque rate", unit="Nm/s"))
                if not abs(tau[i]) <= self._effort[i]:
                    out.append(Violation(TORQUE_RANGE_ERROR, f"joint {i + 1}", float(abs(tau[i])),
                                         float(self._effort[i]), aborts=False, quantity="torque",
                                         unit="Nm"))
        self._tau = tau

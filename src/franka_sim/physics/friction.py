"""The joint friction an FR3 leaves after its own compensation: what a torque-controlled arm
feels, and why it holds still when nothing drives it.

Model, per joint, in the joint velocity dq (zero at rest, so an arm at rest stays bit-exact):

    tau_f(dq) = phi1 / (1 + exp(-phi2 (dq + phi3))) - phi1 / (1 + exp(-phi2 phi3))

a smooth Coulomb-like term that saturates at about phi1 and, near rest, acts as a viscous
damping of phi1·phi2·s(1 − s) (s the sigmoid at dq = 0: 0.7–1.5 Nm·s/rad here). The values are
the Panda's, identified from its joint torque sensors by Gaz, Cognetti, Oliva, Robuffo Giordano
and De Luca (IEEE RA-L 2019): no identification of the FR3's friction is published, and its
joints are of the same design; docs/deviations.md says what the model leaves out.

The friction acts on the link side of the torque sensor, so the measured tau_J carries it (as
the identification found it) while the motor torque does not: the world applies
motor − tau_f, and the readings add tau_f back into tau_J. The client's Model, like the robot's,
has none.
"""

from __future__ import annotations

import numpy as np

from franka_sim.kernels import friction_argument, friction_torque

PHI1 = np.array([0.54615, 0.87224, 0.64068, 1.2794, 0.83904, 0.30301, 0.56489])  # Nm
PHI2 = np.array([5.1181, 9.0657, 10.136, 5.5903, 8.3469, 17.133, 10.336])  # s/rad
PHI3 = np.array([0.039533, 0.025882, -0.04607, 0.036194, 0.026226, -0.021047,
                 0.0035526])  # rad/s


class JointFriction:
    """tau_f of the seven joints at a velocity, into one array the readings share."""

    def __init__(self) -> None:
        self.torque = np.zeros(7)  # the last step's tau_f (what tau_J carries)
        # The sigmoid as 1/2 + tanh(x/2)/2: tau_f = phi1/2 (tanh(phi2 (dq + phi3)/2) − its
        # value at rest), five ufunc calls a step, exactly zero at rest, and no exp to overflow
        # at an absurd velocity.
        self._half_phi1, self._half_phi2 = PHI1 / 2.0, PHI2 / 2.0
        self._at_rest = np.tanh(PHI2 * PHI3 / 2.0)
        self._tmp = np.zeros(7)

    def at(self, dq: np.ndarray, out: np.ndarray) -> np.ndarray:
        """tau_f(dq) into `out` (numpy's tanh between two fused loops, kernels/)."""
        tmp = self._tmp
        friction_argument(dq, PHI3, self._half_phi2, tmp)
        np.tanh(tmp, out=tmp)
        friction_torque(tmp, self._at_rest, self._half_phi1, out)
        return out

    def step(self, dq: np.ndarray) -> np.ndarray:
        """This step's friction at the joints' velocity (kept in `torque`)."""
        return self.at(dq, self.torque)

    def rest(self) -> None:
        self.torque.fill(0.0)

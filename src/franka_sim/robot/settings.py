"""The robot's settable parameters (the Set* TCP commands) and their validation.

Kept apart from the cycle logic because every Set* command is the same shape: validate the
arguments as the robot would (kInvalidArgumentRejected on anything it would refuse), then store.
Ranges come from the FR3 documentation (see docs/figures.md, "Collision and estimator
settings"); where the robot's own power-up defaults are undocumented we use the values
libfranka's examples set (`setDefaultBehavior`), and docs/deviations.md says so.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from franka_sim.robot.controllers import cartesian_damping, impedance_damping

# K_theta range [0, 14250] Nm/rad; K_x translation [10, 3000] N/m, rotation [1, 300] Nm/rad.
K_THETA_MAX = 14250.0
K_X_TRANSLATION_RANGE = (10.0, 3000.0)
K_X_ROTATION_RANGE = (1.0, 300.0)

DEFAULT_K_THETA = np.array([3000.0, 3000.0, 3000.0, 2500.0, 2500.0, 2000.0, 2000.0])
DEFAULT_K_X = np.array([3000.0, 3000.0, 3000.0, 300.0, 300.0, 300.0])


class InvalidArgument(ValueError):
    """A Set* request the robot answers with kInvalidArgumentRejected."""


def _finite(name: str, values) -> np.ndarray:
    arr = np.asarray(values, dtype=float)
    if not np.all(np.isfinite(arr)):
        raise InvalidArgument(f"{name} contains a non-finite value")
    return arr


def homogeneous_from_column_major(name: str, values) -> np.ndarray:
    """A 4x4 transform from 16 column-major numbers, refused unless it is a rigid transform."""
    m = _finite(name, values).reshape(4, 4, order="F")
    if not np.allclose(m[3], [0.0, 0.0, 0.0, 1.0], atol=1e-9):
        raise InvalidArgument(f"{name} last row is not (0, 0, 0, 1)")
    r = m[:3, :3]
    if not np.allclose(r @ r.T, np.eye(3), atol=1e-5) or np.linalg.det(r) < 0:
        raise InvalidArgument(f"{name} rotation is not orthonormal and right-handed")
    return m


@dataclass
class CollisionThresholds:
    """SetCollisionBehavior's eight arrays: over 'lower' a contact, over 'upper' a collision.

    The acceleration set applies while the motion generator accelerates, the nominal set
    otherwise (robot/external_forces.py). Defaults: libfranka's setDefaultBehavior values.
    """

    lower_torque_acceleration: np.ndarray = field(default_factory=lambda: np.full(7, 20.0))
    upper_torque_acceleration: np.ndarray = field(default_factory=lambda: np.full(7, 20.0))
    lower_torque_nominal: np.ndarray = field(default_factory=lambda: np.full(7, 10.0))
    upper_torque_nominal: np.ndarray = field(default_factory=lambda: np.full(7, 10.0))
    lower_force_acceleration: np.ndarray = field(default_factory=lambda: np.full(6, 20.0))
    upper_force_acceleration: np.ndarray = field(default_factory=lambda: np.full(6, 20.0))
    lower_force_nominal: np.ndarray = field(default_factory=lambda: np.full(6, 10.0))
    upper_force_nominal: np.ndarray = field(default_factory=lambda: np.full(6, 10.0))

    @classmethod
    def from_request(cls, req) -> "CollisionThresholds":
        names = [f.name for f in cls.__dataclass_fields__.values()]  # type: ignore[attr-defined]
        wire = [
            "lower_torque_thresholds_acceleration", "upper_torque_thresholds_acceleration",
            "lower_torque_thresholds_nominal", "upper_torque_thresholds_nominal",
            "lower_force_thresholds_acceleration", "upper_force_thresholds_acceleration",
            "lower_force_thresholds_nominal", "upper_force_thresholds_nominal",
        ]
        values = {n: _finite(w, req[w]) for n, w in zip(names, wire)}
        for n, v in values.items():
            if np.any(v < 0):
                raise InvalidArgument(f"{n} has a negative threshold")
        for kind in ("torque_acceleration", "torque_nominal", "force_acceleration", "force_nominal"):
            if np.any(values[f"lower_{kind}"] > values[f"upper_{kind}"]):
                raise InvalidArgument(f"lower {kind} threshold above the upper one")
        return cls(**values)


MAX_LOAD_MASS = 20.0  # kg
MAX_LOAD_COM = 1.0  # m from the flange
MAX_LOAD_INERTIA = 10.0  # kg m^2, a principal moment about the CoM


@dataclass
class Load:
    """A payload declared with SetLoad: mass, CoM in the flange frame, inertia about the CoM.

    It joins the robot's model (gravity compensation, the external-force estimate), not the
    world: what the arm really carries is whatever the scene puts in the Hand.
    """

    mass: float = 0.0
    F_x_C: np.ndarray = field(default_factory=lambda: np.zeros(3))
    inertia: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))

    @classmethod
    def from_request(cls, req) -> "Load":
        mass = float(_finite("m_load", [req["m_load"]])[0])
        com = _finite("F_x_Cload", req["F_x_Cload"])
        inertia = _finite("I_load", req["I_load"]).reshape(3, 3, order="F")
        if mass < 0:
            raise InvalidArgument("m_load is negative")
        # Beyond what any FR3 could carry or hold (its payload is 3 kg): refused rather than
        # simulated (docs/deviations.md; the robot's own bounds are not published).
        if mass > MAX_LOAD_MASS:
            raise InvalidArgument(f"m_load {mass} kg is beyond {MAX_LOAD_MASS} kg")
        if np.abs(com).max() > MAX_LOAD_COM:
            raise InvalidArgument(f"F_x_Cload {com.tolist()} is beyond {MAX_LOAD_COM} m of the "
                                  "flange")
        if not np.allclose(inertia, inertia.T, atol=1e-9):
            raise InvalidArgument("I_load is not symmetric")
        eigenvalues = np.linalg.eigvalsh(inertia)
        if np.min(eigenvalues) < -1e-9:
            raise InvalidArgument("I_load is not positive semi-definite")
        if np.max(eigenvalues) > MAX_LOAD_INERTIA:
            raise InvalidArgument(f"I_load has a principal moment beyond {MAX_LOAD_INERTIA} kg m^2")
        return cls(mass, com, inertia)


@dataclass
class RobotSettings:
    """Everything a client can configure over TCP, with the robot's defaults."""

    K_theta: np.ndarray = field(default_factory=lambda: DEFAULT_K_THETA.copy())
    K_x: np.ndarray = field(default_factory=lambda: DEFAULT_K_X.copy())
    collision: CollisionThresholds = field(default_factory=CollisionThresholds)
    NE_T_EE: np.ndarray = field(default_factory=lambda: np.eye(4))
    EE_T_K: np.ndarray = field(default_factory=lambda: np.eye(4))
    load: Load = field(default_factory=Load)
    guiding_mode: tuple[bool, ...] = (True, True, True, True, True, True)
    guiding_nullspace: bool = True
    _derived: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    @property
    def D_theta(self) -> np.ndarray:
        """The joint impedance's damping, derived from K_theta."""
        return self._derive(self.K_theta, impedance_damping)

    @property
    def D_x(self) -> np.ndarray:
        """The Cartesian impedance's damping, derived from K_x."""
        return self._derive(self.K_x, cartesian_damping)

    def _derive(self, K: np.ndarray, law) -> np.ndarray:
        """law(K), computed anew only when K is replaced (a Set* command), not every cycle."""
        cached = self._derived.get(law)
        if cached is None or cached[0] is not K:
            cached = self._derived[law] = (K, law(K))
        return cached[1]

    def set_joint_impedance(self, K_theta) -> None:
        k = _finite("K_theta", K_theta)
        if np.any(k < 0) or np.any(k > K_THETA_MAX):
            raise InvalidArgument(f"K_theta outside [0, {K_THETA_MAX}] Nm/rad")
        self.K_theta = k

    def set_cartesian_impedance(self, K_x) -> None:
        k = _finite("K_x", K_x)
        lo, hi = K_X_TRANSLATION_RANGE
        if np.any(k[:3] < lo) or np.any(k[:3] > hi):
            raise InvalidArgument(f"K_x translation outside [{lo}, {hi}] N/m")
        lo, hi = K_X_ROTATION_RANGE
        if np.any(k[3:] < lo) or np.any(k[3:] > hi):
            raise InvalidArgument(f"K_x rotation outside [{lo}, {hi}] Nm/rad")
        self.K_x = k

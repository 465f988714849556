"""The cycle's fused vector loops: compiled where the package was built with a C compiler,
else their numpy reference (kernels/reference.py), which gives the same bits.

`FRANKA_SIM_KERNELS=numpy` in the environment makes a process use the reference even where the
compiled module is there (to compare the two, or to rule the compiled module out); `COMPILED`
says which one this process runs. docs/benchmarks.md gives what the compiled module saves.
"""

from __future__ import annotations

import os

from franka_sim.kernels import reference

KERNELS = ("drive_follow", "drive_impedance", "saturate_less", "torque_inside", "measured_inside",
           "joint_position_step", "friction_argument", "friction_torque", "add_feed_forward",
           "impedance_torque", "joint_follow", "doubles_within", "narrow_into", "bind_readings")


def _load_compiled():
    """(the compiled module or None, why not)."""
    if os.environ.get("FRANKA_SIM_KERNELS", "").lower() == "numpy":
        return None, "FRANKA_SIM_KERNELS=numpy"
    try:
        from franka_sim.kernels import _compiled
    except ImportError:  # built without a compiler: the reference runs
        return None, "franka-sim was installed without a C compiler or Python's headers"
    if missing := [name for name in KERNELS if not hasattr(_compiled, name)]:
        return None, f"the compiled module predates {', '.join(missing)}: install again"
    return _compiled, ""


_compiled_module, WHY_NUMPY = _load_compiled()
_source = _compiled_module or reference
COMPILED = _source is not reference

drive_follow = _source.drive_follow
drive_impedance = _source.drive_impedance
saturate_less = _source.saturate_less
torque_inside = _source.torque_inside
measured_inside = _source.measured_inside
joint_position_step = _source.joint_position_step
friction_argument = _source.friction_argument
friction_torque = _source.friction_torque
add_feed_forward = _source.add_feed_forward
impedance_torque = _source.impedance_torque
joint_follow = _source.joint_follow
doubles_within = _source.doubles_within
narrow_into = _source.narrow_into
bind_readings = _source.bind_readings
signed = reference.signed

__all__ = ["COMPILED", "KERNELS", "WHY_NUMPY", "signed", *KERNELS]

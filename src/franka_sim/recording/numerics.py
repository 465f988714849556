"""Which numerical kernels this process runs, as a recording keeps them.

A replay is bit for bit when the same MuJoCo and NumPy builds run the same kernels. NumPy
picks its SIMD routines by the CPU at run time, and OpenBLAS its core (overridden by
OPENBLAS_CORETYPE); two machines, or one with and without that variable, may differ in the
last bit of a product, and a replay then diverges within a few cycles. A recording keeps these
figures so that `replay` can say, when it diverges, that the kernels differed."""

from __future__ import annotations

import ctypes
import platform
import re

_CORENAME = ("scipy_openblas_get_corename64_", "scipy_openblas_get_corename",
             "openblas_get_corename64_", "openblas_get_corename")


def numerics() -> dict[str, str]:
    """The machine, the builds and the kernels they picked here."""
    import mujoco
    import numpy as np

    return {"machine": platform.machine(), "numpy": np.__version__,
            "mujoco": mujoco.__version__, "openblas_core": _openblas_core(),
            "numpy_simd": _numpy_simd()}


def differences(recorded: dict, here: dict | None = None) -> list[str]:
    """"name recorded → here" for each figure that differs (none for an older recording)."""
    here = numerics() if here is None else here
    return [f"{name} {recorded[name] or '?'} → {here.get(name) or '?'}"
            for name in sorted(recorded) if recorded[name] != here.get(name)]


def _openblas_core() -> str:
    """The core OpenBLAS picked (Haswell, SkylakeX, Zen…), from the library NumPy loaded."""
    try:
        with open("/proc/self/maps") as maps:
            paths = set(re.findall(r"\S*openblas\S*\.so\S*", maps.read()))
    except OSError:  # not Linux
        return ""
    for path in sorted(paths):
        try:
            library = ctypes.CDLL(path)
        except OSError:
            continue
        for name in _CORENAME:
            function = getattr(library, name, None)
            if function is not None:
                function.restype = ctypes.c_char_p
                return (function() or b"").decode(errors="replace")
    return ""


def _numpy_simd() -> str:
    """The SIMD targets NumPy dispatches to on this CPU (e.g. X86_V3 X86_V4 AVX512_ICL)."""
    try:
        from numpy._core._multiarray_umath import __cpu_dispatch__, __cpu_features__
    except ImportError:  # another NumPy's layout
        return ""
    enabled = [target for target in __cpu_dispatch__ if __cpu_features__.get(target)]
    return " ".join(enabled)

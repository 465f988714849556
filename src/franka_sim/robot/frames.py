"""The FCI's matrix convention: 4x4 transforms travel column-major (16 numbers)."""

from __future__ import annotations

import numpy as np


def column_major(T: np.ndarray) -> np.ndarray:
    """16 numbers in the order the FCI puts a 4x4 matrix on the wire."""
    return np.asarray(T).ravel(order="F")

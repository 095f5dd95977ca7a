"""Model matrices as the shaders' mat4 push constants."""

from __future__ import annotations

import numpy as np


def column_major(matrix) -> list[float]:
    """A 4 × 4 matrix as the 16 floats of a GLSL mat4 (column-major)."""
    return [float(v) for v in np.asarray(matrix, dtype=np.float64).T.ravel()]


def set_matrix(shader, name: str, matrix) -> None:
    """Set a mat4 push constant; variants that do not read it have optimised it away."""
    try:
        shader.uniform_float(name, column_major(matrix))
    except ValueError as exc:
        if "not found" not in str(exc):
            raise


def normal_matrix(model_matrix: np.ndarray) -> np.ndarray:
    """The inverse transpose of a model matrix (the identity for a singular one)."""
    if abs(np.linalg.det(model_matrix)) > 1e-30:
        return np.linalg.inv(model_matrix).T
    return np.eye(4)

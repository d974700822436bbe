"""Mitsuba-convention 4x4 transforms without Mitsuba (``mi.ScalarTransform4f`` look-alike).

``Transform4f().translate(v).rotate(axis, angle)`` composes as Mitsuba does: each call returns
``self @ op``. The maths is in the Rust core (the same code the XML loader uses).
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from . import _core

Vec3 = Sequence[float]


class Transform4f:
    """An affine 4x4 transform; ``.matrix`` is a row-major ``numpy`` array."""

    def __init__(self, matrix: "np.ndarray | Sequence[Sequence[float]] | None" = None) -> None:
        self.matrix = np.eye(4) if matrix is None else np.asarray(matrix, dtype=float).reshape(4, 4)

    def _then(self, m: list) -> "Transform4f":
        return Transform4f(self.matrix @ np.asarray(m))

    def translate(self, v: Vec3) -> "Transform4f":
        return self._then(_core.transform_translate(_vec3(v)))

    def scale(self, v: "Vec3 | float") -> "Transform4f":
        s = [float(v)] * 3 if np.isscalar(v) else _vec3(v)  # type: ignore[arg-type]
        return self._then(_core.transform_scale(s))

    def rotate(self, axis: Vec3, angle: float) -> "Transform4f":
        """Rotate by ``angle`` degrees about ``axis`` (right-handed)."""
        return self._then(_core.transform_rotate(_vec3(axis), float(angle)))

    def look_at(self, origin: Vec3, target: Vec3, up: Vec3 = (0.0, 1.0, 0.0)) -> "Transform4f":
        """Local +z towards ``target``, local +x = up x dir (Mitsuba's convention)."""
        return self._then(_core.transform_look_at(_vec3(origin), _vec3(target), _vec3(up)))

    def __matmul__(self, other: "Transform4f") -> "Transform4f":
        return Transform4f(self.matrix @ other.matrix)

    def apply(self, p: Vec3) -> np.ndarray:
        """Transform a point."""
        return (self.matrix @ np.append(np.asarray(p, dtype=float), 1.0))[:3]

    def __repr__(self) -> str:
        return f"Transform4f({self.matrix.tolist()})"


def _vec3(v: Vec3) -> list:
    a = np.asarray(v, dtype=float).reshape(-1)
    if a.shape != (3,):
        raise ValueError(f"expected three numbers, got {v!r}")
    return a.tolist()

"""Scene-dict values as plain Python: what a mitransient user puts in a dict (Mitsuba/drjit points,
colours and transform chains, NumPy arrays, nlos_rs transforms, IntEnums) becomes bools, numbers,
strings and nested lists that the core reads. Nothing here imports Mitsuba."""

from __future__ import annotations

from enum import Enum
from typing import Any, Mapping, Sequence

import numpy as np

from .transform import Transform4f


def _is_drjit(v: Any) -> bool:
    return type(v).__module__.split(".")[0] in ("mitsuba", "drjit")


def _array(v: Any) -> Any:
    """A Mitsuba/drjit value as a NumPy array by value. A transform's matrix is its `.matrix`;
    on any other drjit array `.matrix` is a swizzle (`ScalarPoint3f(1, 2, 3).matrix` is six 1s),
    so only transforms are read through it. Dynamic arrays of width one ((n, 1), e.g. `mi.Point2f`)
    become (n,), and a single number (`mi.Float(0.5)`) a scalar."""
    if "Transform" in type(v).__name__:
        return np.asarray(v.matrix, dtype=float)
    a = np.asarray(v, dtype=float)
    if a.ndim == 2 and a.shape[1] == 1:
        a = a[:, 0]
    return a.reshape(()) if a.size == 1 else a


#: Deepest nesting of dicts accepted (a scene needs a handful; the core has the same limit).
MAX_DEPTH = 64


def normalize(v: Any, depth: int = 0) -> Any:
    """Turn transforms, points, colours and arrays into plain nested lists, recursively."""
    if isinstance(v, Mapping):
        if depth > MAX_DEPTH:
            from ._core import SceneError

            raise SceneError(f"scene dict: objects nested more than {MAX_DEPTH} deep")
        return {k: normalize(x, depth + 1) for k, x in v.items()}
    if isinstance(v, Enum) and isinstance(v, int):  # e.g. mitransient's CaptureType
        return int(v)
    if v is None or isinstance(v, (bool, int, float, str)):
        return v
    if isinstance(v, np.generic):
        return v.item()
    if isinstance(v, Transform4f):
        return v.matrix.tolist()
    try:
        a = _array(v) if _is_drjit(v) else np.asarray(v, dtype=float)
    except (TypeError, ValueError):
        return v  # the core names the plugin and key in its error
    if a.ndim == 0:
        return float(a)
    if a.shape == (3, 4):  # affine 3x4
        a = np.vstack([a, [0.0, 0.0, 0.0, 1.0]])
    return a.tolist() if a.ndim in (1, 2) else v


def numbers(v: Any, n: int, what: str) -> Sequence[float]:
    """`n` floats from a tuple, list, NumPy array or Mitsuba/drjit point (e.g. `mi.Point2f(x, y)`)."""
    try:
        a = _array(v) if _is_drjit(v) else np.asarray(v, dtype=float)
    except (TypeError, ValueError):
        a = None
    if a is None or a.shape != (n,) or not np.all(np.isfinite(a)):
        raise TypeError(f"{what} must be {n} finite numbers, got {v!r}")
    return [float(x) for x in a]

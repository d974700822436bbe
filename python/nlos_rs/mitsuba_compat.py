"""Running the same scene dicts through Mitsuba 3 + mitransient (the peer), for comparisons.

Mitsuba is imported only when these functions are called. Its LLVM backend needs libLLVM >= 16:
:func:`setup_llvm` points ``DRJIT_LIBLLVM_PATH`` at Debian's ``libLLVM-19.so`` when it is present.
"""

from __future__ import annotations

import glob
import os
import time
from typing import Any, Mapping, Tuple

import numpy as np

from .transform import Transform4f

_POINT_KEYS = {"sensor_origin", "center"}


def setup_llvm() -> None:
    """Point drjit at a libLLVM >= 16 if none is configured (Debian's default LLVM 15 aborts)."""
    if os.environ.get("DRJIT_LIBLLVM_PATH"):
        return
    for pattern in ("/usr/lib/x86_64-linux-gnu/libLLVM-19.so*", "/usr/lib/llvm-19/lib/libLLVM*.so*",
                    "/usr/lib/*/libLLVM-1[6-9].so*", "/usr/lib/*/libLLVM-2[0-9].so*"):
        found = sorted(glob.glob(pattern))
        if found:
            os.environ["DRJIT_LIBLLVM_PATH"] = found[0]
            return


def import_mitransient(variant: str = "llvm_ad_mono"):
    """Import mitsuba (variant set first, as mitransient requires) and mitransient."""
    setup_llvm()
    import mitsuba as mi

    mi.set_variant(variant)
    import mitransient as mitr  # noqa: F401  (registers the plugins)

    return mi, mitr


def to_mitsuba(d: Any, key: str = "") -> Any:
    """Convert an nlos_rs scene dict to the form ``mi.load_dict`` takes (transforms and points)."""
    import mitsuba as mi

    if isinstance(d, Mapping):
        return {k: to_mitsuba(v, k) for k, v in d.items()}
    if isinstance(d, Transform4f):
        return mi.ScalarTransform4f(d.matrix)
    if key == "to_world" and np.shape(d) == (4, 4):
        return mi.ScalarTransform4f(np.asarray(d, dtype=float))
    if key in _POINT_KEYS and np.shape(d) == (3,):
        return mi.ScalarPoint3f(*map(float, d))
    return d


def render_mitransient(d: Mapping[str, Any], spp: int, seed: int = 0, variant: str = "llvm_ad_mono") -> Tuple[np.ndarray, np.ndarray, float]:
    """Render with mitransient; returns ``(steady, transient, seconds)`` (render only, synced)."""
    mi, _ = import_mitransient(variant)
    import drjit as dr

    scene = mi.load_dict(to_mitsuba(d))
    t0 = time.perf_counter()
    steady, transient = mi.render(scene, spp=spp, seed=seed)
    dr.eval(steady, transient)
    dr.sync_thread()
    seconds = time.perf_counter() - t0
    return np.array(steady), np.array(transient), seconds

"""nlos_rs: fast, correct transient light transport for non-line-of-sight imaging.

Takes the scene dicts and XML files that mitransient 1.3.1 takes (``transient_nlos_path``,
``nlos_capture_meter``, ``transient_hdr_film``, ``projector``) and returns NumPy arrays in
mitransient's layout. Importing nlos_rs never imports Mitsuba.

>>> import nlos_rs
>>> steady, transient = nlos_rs.render(nlos_rs.scenes.z_nlos_1corner(), spp=64)
"""

from __future__ import annotations

import os
import time
import warnings
from typing import Any, Mapping, Optional, Tuple, Union

import numpy as np

from . import _core
from ._core import Scene, SceneError, __version__
from . import io, metrics, nlos, scenes, sensor, transform
from .transform import Transform4f
from .values import normalize
from .xml import save_xml
from .out_of_core import render_to_file

__all__ = [
    "Scene",
    "SceneError",
    "Transform4f",
    "io",
    "to_tal",
    "load_dict",
    "load_file",
    "metrics",
    "nlos",
    "render",
    "render_to_file",
    "save_xml",
    "scenes",
    "speed_of_light",
    "transform",
    "__version__",
]

#: Speed of light in m/s (``mitransient.utils.speed_of_light``); time = OPL / c.
speed_of_light = 299792458.0


def load_dict(d: Mapping[str, Any]) -> Scene:
    """Load a mitransient-style scene dict (``{'type': 'scene', ...}``).

    Relative mesh paths resolve against the current directory. Unknown keys raise
    :class:`SceneError` naming the plugin and key.
    """
    if not isinstance(d, Mapping):
        raise TypeError(f"load_dict expects a dict, got {type(d).__name__}")
    scene = _warn(_core.load_dict(normalize(d), os.getcwd()))
    scene._nlos_source = ("dict", dict(d))  # what nlos_rs.distributed workers load again
    return scene


def load_file(path: Union[str, os.PathLike], **params: Any) -> Scene:
    """Load a Mitsuba XML scene; keyword arguments substitute ``$name`` parameters."""

    def text(v: Any) -> str:
        return ("true" if v else "false") if isinstance(v, bool) else str(v)

    scene = _warn(_core.load_file(os.fspath(path), {k: text(v) for k, v in params.items()}))
    scene._nlos_source = ("file", os.path.abspath(os.fspath(path)), dict(params))
    return scene


def _warn(scene: Scene) -> Scene:
    for w in scene.warnings:
        warnings.warn(w, stacklevel=3)
    return scene


def to_tal(scene, transient, zero_t_start: bool = False):
    """A ``tal.io.NLOSCaptureData`` of a render (see :mod:`nlos_rs.io`)."""
    return io.to_tal(_as_scene(scene), transient, zero_t_start)


_VARIANTS = {"mono": True, "rgb": False}


_UNITS = {"": 1, "B": 1, "KB": 10**3, "MB": 10**6, "GB": 10**9, "KIB": 2**10, "MIB": 2**20, "GIB": 2**30, "TIB": 2**40}


def _bytes(v: Union[int, str]) -> int:
    """Bytes from an integer or a string like "512MiB" or "2 GB"."""
    if isinstance(v, (int, np.integer)) and not isinstance(v, bool) and 0 < v < 2**64:
        return int(v)
    if isinstance(v, str):
        import re

        m = re.fullmatch(r"\s*([0-9.]+)\s*([A-Za-z]*)\s*", v)
        if m and m.group(2).upper() in _UNITS:
            n = float(m.group(1)) * _UNITS[m.group(2).upper()]
            if 0 < n < 2**64:
                return int(n)
    raise SceneError(f"plugin 'render': key 'max_memory': bytes as a positive integer or a string like '512MiB', got {v!r}")


def _as_scene(scene: Union[Scene, Mapping[str, Any], str, os.PathLike]) -> Scene:
    if isinstance(scene, Scene):
        return scene
    if isinstance(scene, Mapping):
        return load_dict(scene)
    if isinstance(scene, (str, os.PathLike)):
        return load_file(scene)
    raise TypeError(f"render expects a Scene, a scene dict or an XML path, got {type(scene).__name__}")


class _Progress:
    """A tqdm bar (terminal or Jupyter) that appears only once a render has run for a second."""

    def __init__(self, enabled: bool) -> None:
        self.enabled, self.bar, self.start = enabled, None, time.monotonic()

    def __call__(self, done: int, total: int) -> None:
        if not self.enabled:
            return
        if self.bar is None:
            if time.monotonic() - self.start < 1.0 or done >= total:
                return
            from tqdm.auto import tqdm

            self.bar = tqdm(total=total, unit="path", unit_scale=True, desc="nlos_rs", leave=False)
        self.bar.update(done - self.bar.n)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


_SAMPLERS = ("independent", "stratified", "multijitter", "orthogonal", "ldsampler")


def _kernel_options(kernel: Optional[str], sigma: Union[float, str, None], bandwidth: Union[float, str, None]) -> dict:
    """The core's kernel options; a width of "auto" picks the shape's width per scan point."""
    auto = [name for name, v in (("kernel_sigma", sigma), ("kernel_bandwidth", bandwidth)) if isinstance(v, str)]
    for name in auto:
        if (sigma if name == "kernel_sigma" else bandwidth) != "auto":
            raise SceneError(f"plugin 'render': key '{name}': must be a number of bins or 'auto'")
    if not auto:
        return {"kernel": kernel, "kernel_sigma": sigma, "kernel_bandwidth": bandwidth}
    placeholder = 1.0  # the shape's width, replaced per scan point
    if auto == ["kernel_sigma"] and bandwidth is None:
        return {"kernel": kernel or "gaussian", "kernel_sigma": placeholder, "auto_width": True}
    if auto == ["kernel_bandwidth"] and sigma is None:
        return {"kernel": kernel or "epanechnikov", "kernel_bandwidth": placeholder, "auto_width": True}
    raise SceneError("plugin 'render': key 'kernel_bandwidth': set kernel_sigma or kernel_bandwidth, not both")


def render(
    scene: Union[Scene, Mapping[str, Any], str, os.PathLike],
    spp: Optional[int] = None,
    seed: int = 0,
    threads: Optional[int] = None,
    progress: bool = True,
    variant: str = "mono",
    integrator: Optional[str] = None,
    kernel: Optional[str] = None,
    kernel_sigma: Union[float, str, None] = None,
    kernel_bandwidth: Union[float, str, None] = None,
    hgrs_max_iterations: Optional[int] = None,
    hgrs_estimator: Optional[str] = None,
    max_memory: Union[int, str, None] = None,
    return_variance: bool = False,
    target_rel_error: Optional[float] = None,
    max_spp: Optional[int] = None,
    sampler: Optional[str] = None,
) -> Tuple[np.ndarray, ...]:
    """Render an NLOS capture; returns ``(steady, transient)`` as float32 arrays.

    Shapes follow mitransient: steady ``(H, W, C)``; transient ``(H, W, T, C)``, or for an
    exhaustive capture ``(H, W, LH, LW, T, C)``; ``C`` is 1 for ``variant="mono"`` and 3 for
    ``"rgb"``. ``spp`` defaults to the scene sampler's ``sample_count``; ``seed`` is added to its
    ``seed``. Results are bit-identical for a seed whatever ``threads`` is. The GIL is released;
    Ctrl-C stops the render (``KeyboardInterrupt``).

    ``integrator`` switches the scene's integrator by name (``"transient_nlos_path"`` or
    ``"transient_nlos_path_rs"``, Hidden Geometry Rejection Sampling, with ``hgrs_max_iterations``
    and ``hgrs_estimator`` = ``"resampled"`` (unbiased, default) or ``"rejection"`` (as the thesis
    publishes it, biased)) keeping its other parameters.

    Temporal kernel (overrides the film's): ``kernel`` = ``"box"``, ``"gaussian"`` (width
    ``kernel_sigma``) or ``"epanechnikov"``, ``"triangular"``, ``"biweight"``, ``"triweight"``,
    ``"cosine"`` (half-width ``kernel_bandwidth``), widths in time bins. Without ``kernel``,
    ``kernel_sigma`` alone means Gaussian and ``kernel_bandwidth`` alone Epanechnikov. A width of
    ``"auto"`` is chosen per scan point from its samples: the box render is smoothed at the width of
    least estimated squared error (Stein's unbiased risk estimate; docs/techniques.md).

    ``return_variance=True`` returns ``(steady, transient, variance)``: each transient value's
    variance of the mean, estimated from the per-sample values. ``target_rel_error=e`` samples each
    scan point in blocks of 256 until its total's relative error is within ``e`` at 90 % confidence
    (1.645 standard errors of the mean at most ``e`` times the total, after at least 1024 samples),
    or ``max_spp`` samples (default: ``spp``, or the scene's ``sample_count``); deterministic for a seed. Both render each scan point in one task.

    ``sampler`` overrides the scene's: ``"independent"``, or ``"stratified"``, ``"multijitter"``,
    ``"orthogonal"``, ``"ldsampler"`` — all four draw from one Owen-scrambled Sobol' sequence.

    The output's size is checked before it is allocated: beyond ``max_memory`` (bytes, or a string
    such as ``"512MiB"``; default 80 % of the memory available) the render raises ``SceneError``.
    """
    key = variant.split("_")[-1] if variant.startswith(("llvm_", "cuda_", "scalar_")) else variant
    if key not in _VARIANTS:
        raise ValueError(f"variant must be 'mono' or 'rgb', got {variant!r}")
    def integer(name: str, v: Any, lo: int) -> None:
        if not isinstance(v, (int, np.integer)) or isinstance(v, bool) or not lo <= v < 2**64:
            raise SceneError(f"plugin 'render': key '{name}': must be an integer in [{lo}, 2^64), got {v!r}")

    if sampler is not None and sampler not in _SAMPLERS:
        raise SceneError(f"plugin 'render': key 'sampler': must be one of {_SAMPLERS}, got {sampler!r}")
    if max_spp is not None:
        if target_rel_error is None:
            raise SceneError("plugin 'render': key 'max_spp': is the budget of target_rel_error; set that too (or use spp)")
        spp = max_spp
    for name, v, lo in (("spp", spp, 1), ("threads", threads, 1), ("seed", seed, 0)):
        if v is not None:
            integer(name, v, lo)
    limit = None if max_memory is None else _bytes(max_memory)
    scene = _as_scene(scene)
    if integrator is not None or hgrs_max_iterations is not None or hgrs_estimator is not None:
        name = scene.integrator if integrator is None else integrator
        scene = scene.with_integrator(name, hgrs_max_iterations, hgrs_estimator)
    bar = _Progress(progress)
    try:
        options = {"spp": spp, "seed": int(seed), "threads": threads, "mono": _VARIANTS[key], "max_memory": limit,
                   "return_variance": bool(return_variance), "target_rel_error": target_rel_error,
                   "low_discrepancy": None if sampler is None else sampler != "independent",
                   **_kernel_options(kernel, kernel_sigma, kernel_bandwidth)}
        steady, transient, variance = _core.render(scene, options, bar)
        return (steady, transient, variance) if return_variance else (steady, transient)
    finally:
        bar.close()

"""Renders split into parts that run anywhere: on the cores of this machine, on the processes of a
Dask ``LocalCluster``, or on a Dask cluster (docs/distributed.md). Needs ``pip install .[distributed]``
for Dask; ``nlos_rs.render_to_file`` (out of core) works without it.

    import nlos_rs.distributed as nd
    steady, transient = nd.render(scene, spp=None, seed=0, client=None)
    nd.batch(["z_nlos_1corner", "scene.xml"], "out/")

A part is a run of pixels and a run of each pixel's sample chunks (``nlos_rs._core.render_plan``);
workers return raw sums and ``_core.assemble`` adds them in the local render's order, so the result
equals ``nlos_rs.render(scene, spp=spp, seed=seed)`` bit for bit whatever the workers and however
the tasks are scheduled. A worker that dies costs only its tasks: Dask runs them again elsewhere,
with the same result.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import pickle
from pathlib import Path
from typing import Any, Dict, Iterator, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from . import _core
from ._core import Scene, SceneError

Source = Tuple[Any, ...]
Range = Tuple[int, int]


def source(scene: Union[Scene, Mapping[str, Any], str, os.PathLike, Source]) -> Source:
    """What a worker needs to load the scene again: ``("dict", d)`` (also for a built-in scene
    name) or ``("file", path, params)``; a ``Scene`` carries the source it was loaded from."""
    from .scenes import BUILTIN

    if isinstance(scene, tuple):
        return scene
    if isinstance(scene, Mapping):
        return ("dict", dict(scene))
    if isinstance(scene, (str, os.PathLike)):
        if str(scene) in BUILTIN:
            return ("dict", BUILTIN[str(scene)]())
        return ("file", os.path.abspath(os.fspath(scene)), {})
    if isinstance(scene, Scene):
        src = getattr(scene, "_nlos_source", None)
        if src is None:
            raise TypeError("this Scene was changed after loading (focus_laser_at) or not made by nlos_rs.load_dict/"
                            "load_file: pass the scene dict or XML path, which workers load again")
        return src
    raise TypeError(f"expected a Scene, a scene dict, an XML path or a built-in scene name, got {type(scene).__name__}")


def load(src: Source) -> Scene:
    """The scene of a source (on a worker: loaded once per process and kept)."""
    key = hashlib.sha256(pickle.dumps(src)).hexdigest()
    if _LOADED.get("key") != key:
        _LOADED.clear()
        _LOADED.update(key=key, scene=_load(src))
    return _LOADED["scene"]


_LOADED: Dict[str, Any] = {}


def _load(src: Source) -> Scene:
    from . import load_dict, load_file

    kind = src[0]
    if kind == "dict":
        return load_dict(src[1])
    if kind == "file":
        return load_file(src[1], **src[2])
    raise ValueError(f"unknown scene source {kind!r}")


def _options(spp, seed, variant, kernel, kernel_sigma, kernel_bandwidth) -> Dict[str, Any]:
    if variant not in ("mono", "rgb"):
        raise ValueError(f"variant must be 'mono' or 'rgb', got {variant!r}")
    return {"spp": spp, "seed": int(seed), "mono": variant == "mono", "kernel": kernel, "kernel_sigma": kernel_sigma,
            "kernel_bandwidth": kernel_bandwidth}


def tasks_of(plan: Mapping[str, Any], pixels: Range, count: int) -> List[Tuple[Range, Range]]:
    """About ``count`` parts covering every chunk of ``pixels``, in pixel then chunk order."""
    p0, p1 = pixels
    chunks = plan["chunks"]
    if chunks == 1:
        n = max(1, min(count, p1 - p0))
        cuts = np.linspace(p0, p1, n + 1).round().astype(int)
        return [((int(a), int(b)), (0, 1)) for a, b in zip(cuts[:-1], cuts[1:]) if b > a]
    per_pixel = max(1, min(chunks, -(-count // (p1 - p0))))
    cuts = np.linspace(0, chunks, per_pixel + 1).round().astype(int)
    return [((p, p + 1), (int(a), int(b))) for p in range(p0, p1) for a, b in zip(cuts[:-1], cuts[1:]) if b > a]


def _part(src: Source, pixels: Range, chunks: Range, opts: Mapping[str, Any], threads: Optional[int] = None):
    """One task: the raw sums of a part (runs on a worker)."""
    if threads is None:
        with contextlib.suppress(ImportError, ValueError):
            from distributed import get_worker

            threads = get_worker().state.nthreads
    t, s = _core.render_part(load(src), pixels, chunks, {**opts, "threads": threads})
    return pixels, chunks, t, s


def _aligned(part):
    """A part as the core reads it (arrays that crossed the network may arrive unaligned)."""
    p, c, t, s = part
    return tuple(p), tuple(c), np.require(t, np.float32, ["C", "A"]), np.require(s, np.float64, ["C", "A"])


@contextlib.contextmanager
def _client(client) -> Iterator[Any]:
    """A Dask client: the one given, one connected to a scheduler address, or an embedded
    LocalCluster of one single-threaded worker process per core on 127.0.0.1, closed after."""
    try:
        from distributed import Client, LocalCluster
    except ImportError as e:
        raise ImportError("rendering on Dask needs dask.distributed: pip install 'dask[distributed]' "
                          "(or nlos_rs's extra: pip install '.[distributed]')") from e

    if client is not None and not isinstance(client, str):
        yield client
        return
    if isinstance(client, str):
        with Client(client) as c:
            yield c
        return
    with LocalCluster(n_workers=os.cpu_count() or 1, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address="127.0.0.1:0") as cluster, Client(cluster) as c:
        yield c


def compute_parts(src: Source, plan: Mapping[str, Any], opts: Mapping[str, Any], pixels: Range, client=None,
                  progress=None, tasks: Optional[int] = None) -> list:
    """The parts of a run of pixels, sorted: on ``client`` (a Dask client) or, if None, here."""
    if client is None:
        return [_part(src, p, c, opts) for p, c in tasks_of(plan, pixels, 1)]
    from distributed import as_completed

    n = tasks or 4 * max(1, sum(client.nthreads().values()))
    work = tasks_of(plan, pixels, n)
    futures = [client.submit(_part, src, p, c, opts, key=f"nlos_rs-part-{hashlib.sha1(pickle.dumps((src, p, c, opts))).hexdigest()}")
               for p, c in work]
    parts = []
    for future in as_completed(futures):
        parts.append(_aligned(future.result()))
        if progress is not None:
            progress(len(parts), len(work))
    del futures
    return sorted(parts, key=lambda p: (p[0][0], p[1][0]))


def render(scene, spp: Optional[int] = None, seed: int = 0, client=None, variant: str = "mono",
           kernel: Optional[str] = None, kernel_sigma: Optional[float] = None,
           kernel_bandwidth: Optional[float] = None, progress: bool = True, tasks: Optional[int] = None) -> Tuple[np.ndarray, np.ndarray]:
    """Render on a Dask cluster: ``(steady, transient)``, equal bit for bit to
    ``nlos_rs.render(scene, spp=spp, seed=seed, variant=variant, ...)``.

    ``client``: a ``dask.distributed.Client``, a scheduler address (``"tcp://host:8786"``), or None
    for a LocalCluster started for the call (one worker process per core, on 127.0.0.1) and closed
    after. ``tasks``: how many parts (default 4 per worker thread). Progress shows as a tqdm bar and
    in Dask's dashboard.
    """
    src = source(scene)
    local = scene if isinstance(scene, Scene) else load(src)
    opts = _options(spp, seed, variant, kernel, kernel_sigma, kernel_bandwidth)
    plan = _core.render_plan(local, opts)
    _core.render_check_memory(local, plan["pixels"], opts)
    bar = _bar(progress, "nlos_rs (dask)")
    try:
        with _client(client) as c:
            parts = compute_parts(src, plan, opts, (0, plan["pixels"]), client=c, progress=bar, tasks=tasks)
    finally:
        if bar is not None:
            bar.close()
    t, s = _core.assemble(local, parts, opts)
    return s.reshape(plan["steady_shape"]), t.reshape(plan["transient_shape"])


class _bar:
    """A tqdm bar over parts."""

    def __new__(cls, enabled: bool, desc: str):
        if not enabled:
            return None
        return super().__new__(cls)

    def __init__(self, enabled: bool, desc: str) -> None:
        self.desc, self.tqdm = desc, None

    def __call__(self, done: int, total: int) -> None:
        if self.tqdm is None:
            from tqdm.auto import tqdm

            self.tqdm = tqdm(total=total, unit="part", desc=self.desc, leave=False)
        self.tqdm.update(done - self.tqdm.n)

    def close(self) -> None:
        if self.tqdm is not None:
            self.tqdm.close()


def batch(scenes: Sequence[Union[str, os.PathLike, Mapping[str, Any]]], out_dir: Union[str, os.PathLike],
          spp: Optional[int] = None, seed: int = 0, client=None, progress: bool = True,
          max_memory: Union[int, str, None] = None) -> List[Path]:
    """Render one tal capture per scene into ``out_dir/<name>.hdf5`` (built-in name, XML path, or a
    ``(name, dict)`` pair). Resumable: an existing output is complete (outputs are written to a
    temporary name and renamed when done) and is skipped; an interrupted one is rendered again.
    ``client`` as in :func:`render` (None renders here)."""
    from . import render_to_file

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for item in scenes:
        name, scene = (item if isinstance(item, tuple) else (Path(os.fspath(item)).stem, item))
        path = out / f"{name}.hdf5"
        paths.append(path)
        if path.exists():
            continue
        tmp = out / f".{name}.hdf5.partial"
        render_to_file(scene, tmp, spp=spp, seed=seed, client=client, progress=progress, max_memory=max_memory)
        os.replace(tmp, path)
    return paths

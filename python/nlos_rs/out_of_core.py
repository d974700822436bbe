"""``nlos_rs.render_to_file``: a capture rendered and written tile by tile (runs of sensor rows)
into tal's HDF5 layout, so that a capture several times larger than memory renders on one machine;
distributable through a Dask client as well (docs/distributed.md)."""

from __future__ import annotations

import os
from typing import Any, Dict, Optional, Union

import numpy as np

from . import _core, distributed, io
from ._core import Scene, SceneError

#: Bytes held per byte of a tile's transient: the workers' raw sums (one copy per chunk), the
#: assembled values, the float64 channel sum, its float32 cast and the transposed copy.
_COPIES = 5


def render_to_file(scene, path: Union[str, os.PathLike], spp: Optional[int] = None, seed: int = 0,
                   max_memory: Union[int, str, None] = None, client=None, variant: str = "mono",
                   kernel: Optional[str] = None, kernel_sigma: Optional[float] = None,
                   kernel_bandwidth: Optional[float] = None, progress: bool = True, zero_t_start: bool = False, compression_level: int = 0,
                   scene_info: Optional[Dict[str, Any]] = None) -> None:
    """Render ``scene`` and write it as a tal HDF5 capture at ``path``, a run of sensor rows at a time,
    keeping memory below ``max_memory`` (bytes or a string like ``"512MiB"``; default 80 % of the
    memory available). The file's H equals what ``render()`` + ``io.write_capture()`` write, bit for
    bit. ``client``: as in ``nlos_rs.distributed.render`` (None renders here, on every core)."""
    from . import _bytes

    src = distributed.source(scene)
    local = scene if isinstance(scene, Scene) else distributed.load(src)
    opts = distributed._options(spp, seed, variant, kernel, kernel_sigma, kernel_bandwidth)
    plan = _core.render_plan(local, opts)
    limit = _core.memory_limit(None if max_memory is None else _bytes(max_memory))
    w, h = local.film_size
    row = plan["pixel_len"] * 4 * w
    rows = min(h, int(limit // (row * (_COPIES + plan["chunks"]))))
    if rows < 1:
        raise SceneError(f"plugin 'render_to_file': key 'max_memory': one sensor row of the transient needs "
                         f"{row * (_COPIES + plan['chunks'])} bytes while rendered and written, more than the {limit} allowed")
    fields = io.capture_fields(local, None, zero_t_start, scene_info)
    pad = io.leading_bins(local, zero_t_start)
    exhaustive = local.capture_type == "exhaustive"
    bins = local.temporal[0]
    lasers = (local.laser_scan[0], local.laser_scan[1]) if exhaustive else ()
    # H is contiguous, as write_capture makes it, so that reading it whole (as tal does) is fast; a
    # compressed H is stored in chunks of whole tiles (below HDF5's 4 GiB chunk limit).
    shape = (pad + bins,) + lasers + (w, h)
    chunks = shape[:-1] + (max(1, min(rows, (2 << 30) // row)),) if compression_level else None
    f = io.write_fields(path, fields, compression_level, H_shape=shape, H_chunks=chunks)
    bar = distributed._bar(progress, "nlos_rs (to file)")
    try:
        with (distributed._client(client) if client is not None else _here()) as c:
            for y0 in range(0, h, rows):
                y1 = min(h, y0 + rows)
                parts = distributed.compute_parts(src, plan, opts, (y0 * w, y1 * w), client=c)
                t, _ = _core.assemble(local, parts, opts)
                del parts
                tile = io.tal_H(np.asarray(t).reshape((y1 - y0,) + tuple(plan["transient_shape"][1:])), exhaustive)
                del t
                f["H"][pad:, ..., y0:y1] = tile
                del tile
                if bar is not None:
                    bar(y1, h)
    finally:
        f.close()
        if bar is not None:
            bar.close()


class _here:
    """No client: parts render in this process."""

    def __enter__(self):
        return None

    def __exit__(self, *exc) -> None:
        return None

"""Hand-off to tal (y-tal 0.20): the ``NLOSCaptureData`` fields and tal's HDF5 layout.

``write_capture`` writes tal's file format directly with h5py (no tal import): one top-level dataset
per field, enums as HDF5 enum datasets, ``scene_info`` as YAML text (JSON, which YAML reads).
``to_tal`` builds a ``tal.io.NLOSCaptureData`` when tal is installed. Axis conventions
(tal's ``tal/io/capture_data.py``): H is ``(T, Sx, Sy)`` — time, then the wall's x index, then
y — or ``(T, Lx, Ly, Sx, Sy)`` for exhaustive captures; grids are ``(X, Y, 3)``; times are metres of
optical path.

tal 0.20 quirks: ``pf_dev`` needs ``t_start = 0`` and ``fk`` ignores ``t_start``; pass
``zero_t_start=True`` to pad H with empty leading bins (``t_start`` must be a whole number of bins).
"""

from __future__ import annotations

import json
import os
from typing import Any, Dict, Optional, Union

import numpy as np

from ._core import Scene

#: tal.enums values.
H_FORMAT = {"T_Sx_Sy": 1, "T_Lx_Ly_Sx_Sy": 2}
GRID_X_Y_3 = 2


def tal_H(transient: np.ndarray, exhaustive: bool) -> np.ndarray:
    """mitransient's order (y, x, [ly, lx,] t, c) to tal's H (t, [lx, ly,] x, y), channels summed.
    Photon counts (nlos_rs.sensor.simulate) stay integers; radiometric values are float32."""
    t = np.asarray(transient)
    if t.dtype.kind in "iu":
        t = t.sum(-1, dtype=np.int64)
    elif t.shape[-1] == 1 and t.dtype == np.float32:
        t = t[..., 0]  # one channel: its float64 sum cast back to float32 is itself
    else:
        t = t.sum(-1, dtype=np.float64).astype(np.float32)
    return np.ascontiguousarray(np.transpose(t, (4, 3, 2, 1, 0) if exhaustive else (2, 1, 0)))


def leading_bins(scene: Scene, zero_t_start: bool) -> int:
    """Empty bins padded before H so that ``t_start = 0`` (tal 0.20's ``pf_dev``), or 0."""
    _, delta_t, t_start = scene.temporal
    if not zero_t_start or t_start == 0:
        return 0
    pad = t_start / delta_t
    if abs(pad - round(pad)) > 1e-6 or pad < 0:
        raise ValueError(f"zero_t_start needs start_opl ({t_start}) to be a whole number of bins ({delta_t})")
    return int(round(pad))


def capture_fields(scene: Scene, transient: Optional[np.ndarray], zero_t_start: bool = False,
                   scene_info: Optional[Dict[str, Any]] = None) -> Dict[str, Any]:
    """The ``NLOSCaptureData`` fields of a render (channels summed, as ``tal render`` does); with
    ``transient=None`` every field but ``H`` (``nlos_rs.render_to_file`` writes H tile by tile)."""
    from . import __version__

    if scene.phasor_frequencies is not None:
        raise ValueError("a phasor_hdr_film capture has no time bins: write_capture/to_tal take "
                         "transient_hdr_film captures (save the phasors with numpy)")

    w, h = scene.film_size
    bins, delta_t, t_start = scene.temporal
    exhaustive = scene.capture_type == "exhaustive"
    pad = leading_bins(scene, zero_t_start)
    H = None
    if transient is not None:
        expect = (h, w) + ((scene.laser_scan[1], scene.laser_scan[0]) if exhaustive else ()) + (bins,)
        t = np.asarray(transient)
        if t.shape[:-1] != expect:
            raise ValueError(f"transient shape {t.shape} does not match the scene (expected {expect + ('C',)})")
        H = tal_H(t, exhaustive)
        if pad:
            H = np.concatenate([np.zeros((pad,) + H.shape[1:], H.dtype), H], axis=0)
    if pad:
        t_start = 0.0
    # Wall points at the scan-pixel centres, [x, y] order.
    grid = np.array([[scene.relay_wall_point((ix + 0.5) / w, (iy + 0.5) / h)[0] for iy in range(h)] for ix in range(w)], np.float32)
    normals = np.array([[scene.relay_wall_point((ix + 0.5) / w, (iy + 0.5) / h)[1] for iy in range(h)] for ix in range(w)], np.float32)
    if scene.capture_type == "confocal":
        laser_grid, laser_normals = grid, normals
    else:
        pts, nrm = scene.laser_points()  # (rows = y, cols = x, 3)
        laser_grid = np.transpose(np.array(pts, np.float32), (1, 0, 2))
        laser_normals = np.transpose(np.array(nrm, np.float32), (1, 0, 2))
    info = {"renderer": "nlos_rs", "nlos_rs_version": __version__, "capture_type": scene.capture_type,
            "integrator": scene.integrator, "spp": scene.spp, "temporal_kernel": list(scene.temporal_kernel)}
    info.update(scene_info or {})
    return {
        "H": H,
        "H_format": H_FORMAT["T_Lx_Ly_Sx_Sy" if exhaustive else "T_Sx_Sy"],
        "sensor_xyz": np.array(scene.sensor_origin, np.float32),
        "sensor_grid_xyz": grid,
        "sensor_grid_normals": normals,
        "sensor_grid_format": GRID_X_Y_3,
        "laser_xyz": np.array(scene.laser_origin, np.float32),
        "laser_grid_xyz": laser_grid,
        "laser_grid_normals": laser_normals,
        "laser_grid_format": GRID_X_Y_3,
        "volume_format": None,
        "delta_t": float(delta_t),
        "t_start": float(t_start),
        "t_accounts_first_and_last_bounces": bool(scene.account_first_and_last_bounces),
        "scene_info": info,
    }


def write_capture(path: Union[str, os.PathLike], scene: Scene, transient: np.ndarray, zero_t_start: bool = False,
                  compression_level: int = 0, scene_info: Optional[Dict[str, Any]] = None) -> None:
    """Write a render as a tal HDF5 capture (readable by ``tal.io.read_capture``)."""
    write_fields(path, capture_fields(scene, transient, zero_t_start, scene_info), compression_level)


def write_fields(path: Union[str, os.PathLike], fields: Dict[str, Any], compression_level: int = 0,
                 H_shape: Optional[tuple] = None, H_chunks: Optional[tuple] = None):
    """Write capture fields in tal's layout; with ``H_shape`` (and ``fields["H"]`` None) create an
    empty float32 H of that shape, stored in ``H_chunks``, and return the open file for the caller
    to fill and close."""
    import h5py

    enums = {
        "H_format": h5py.enum_dtype({"UNKNOWN": 0, "T_Sx_Sy": 1, "T_Lx_Ly_Sx_Sy": 2, "T_Si": 3, "T_Li_Si": 4}, basetype="i4"),
        "sensor_grid_format": h5py.enum_dtype({"UNKNOWN": 0, "N_3": 1, "X_Y_3": 2}, basetype="i4"),
        "laser_grid_format": h5py.enum_dtype({"UNKNOWN": 0, "N_3": 1, "X_Y_3": 2}, basetype="i4"),
    }
    f = h5py.File(path, "w")
    try:
        for key, value in fields.items():
            if key == "H":
                kw = {"compression": "gzip", "compression_opts": compression_level} if compression_level else {}
                if value is None:
                    f.create_dataset(key, shape=H_shape, dtype=np.float32, fillvalue=0.0, chunks=H_chunks, **kw)
                else:
                    f.create_dataset(key, data=value, **kw)
            elif key in enums:
                f.create_dataset(key, data=np.array([value], np.int32), dtype=enums[key])
            elif key == "scene_info":
                f.create_dataset(key, data=json.dumps(value))
            elif value is None:
                f.create_dataset(key, data=h5py.Empty("f"))
            else:
                f.create_dataset(key, data=value)
    except BaseException:
        f.close()
        raise
    if H_shape is not None:
        return f
    f.close()
    return None


def to_tal(scene: Scene, transient: np.ndarray, zero_t_start: bool = False, scene_info: Optional[Dict[str, Any]] = None):
    """A ``tal.io.NLOSCaptureData`` of a render (needs y-tal)."""
    import tal
    from tal.enums import GridFormat, HFormat

    fields = capture_fields(scene, transient, zero_t_start, scene_info)
    data = tal.io.NLOSCaptureData()
    for key, value in fields.items():
        setattr(data, key, value)
    data.H_format = HFormat(fields["H_format"])
    data.sensor_grid_format = GridFormat(fields["sensor_grid_format"])
    data.laser_grid_format = GridFormat(fields["laser_grid_format"])
    return data

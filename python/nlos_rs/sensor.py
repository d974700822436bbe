"""What a SPAD records of a rendered transient: absolute photon counts, the instrument response,
Poisson noise, dark and ambient counts, afterpulsing, crosstalk and pile-up (docs/sensor.md).

    from nlos_rs import sensor
    spad = sensor.Spad(exposure_s=8e-3, pile_up=True)
    lam = sensor.expected_counts(scene, transient, spad)     # mean detections per bin (float64)
    counts = sensor.simulate(scene, transient, spad, seed=0) # one noisy capture (int64)
    est = sensor.coates(counts, scene, spad)                 # pile-up-corrected estimate of lam

``transient`` is a mono render of ``scene`` (``nlos_rs.render(scene)[1]``), with laser sampling.
The work is done in Rust (``nlos_rs._core``), in parallel, and is deterministic for a seed.
"""

from __future__ import annotations

import dataclasses
import os
from typing import Any, Dict, Mapping, Optional, Sequence, Union

import numpy as np

from . import _core
from ._core import Scene


@dataclasses.dataclass(frozen=True)
class Spad:
    """A SPAD with time-correlated single-photon counting, and the pulsed laser it is paired with.

    Defaults are a typical NLOS system: 30 ps pulse, 20 ps jitter (FWHM), 250 mW at 11 MHz and
    532 nm, 8 ms per scan point, 40 % detection efficiency, 1 kHz dark counts. ``irf`` (a 1-D array at
    the capture's bin width, zero delay at its peak) replaces pulse and jitter. ``footprint_m2`` is
    the wall area the SPAD sees at a scan point (its active area imaged on the wall; 2e-5 m² is a
    5 mm spot); ``aperture_diameter_mm`` the collecting lens.
    """

    pulse_fwhm_ps: float = 30.0
    jitter_fwhm_ps: float = 20.0
    jitter_tail_ps: float = 0.0
    irf: Optional[Sequence[float]] = None
    laser_power_w: float = 0.25
    rep_rate_hz: float = 11e6
    wavelength_nm: float = 532.0
    exposure_s: float = 8e-3
    efficiency: float = 0.4
    dark_count_rate_hz: float = 1e3
    ambient_rate_hz: float = 0.0
    pile_up: bool = False
    dead_time_ns: float = 0.0
    afterpulse_prob: float = 0.0
    crosstalk_prob: float = 0.0
    aperture_diameter_mm: float = 25.4
    footprint_m2: float = 2e-5

    def __post_init__(self) -> None:
        _core.spad_check(self.params())  # a bad parameter fails here, before any render

    def params(self) -> Dict[str, Any]:
        """The parameters as a dict (an IRF array as a list), as ``scene_info`` stores them."""
        d = dataclasses.asdict(self)
        if d["irf"] is not None:
            d["irf"] = np.asarray(d["irf"], dtype=np.float64).tolist()
        if isinstance(d["pile_up"], np.bool_):
            d["pile_up"] = bool(d["pile_up"])
        return d

    @classmethod
    def from_string(cls, text: str) -> "Spad":
        """From ``key=value,key=value`` (the CLI's ``--spad``), e.g. ``exposure_s=8e-3,pile_up=true``."""
        fields = {f.name: f for f in dataclasses.fields(cls)}
        kw: Dict[str, Any] = {}
        for item in filter(None, (s.strip() for s in text.split(","))):
            key, sep, value = item.partition("=")
            key = key.strip()
            if not sep or key not in fields:
                raise _core.SceneError(f"plugin 'spad': key '{key}': expected key=value with a key of {sorted(fields)}")
            v = value.strip()
            if key == "pile_up":
                if v.lower() not in ("true", "false", "1", "0"):
                    raise _core.SceneError(f"plugin 'spad': key 'pile_up': expected true or false, got {v!r}")
                kw[key] = v.lower() in ("true", "1")
            elif key == "irf":
                kw[key] = np.loadtxt(v, dtype=np.float64).ravel().tolist()
            else:
                try:
                    kw[key] = float(v)
                except ValueError:
                    raise _core.SceneError(f"plugin 'spad': key '{key}': expected a number, got {v!r}") from None
        return cls(**kw)


def _scene(scene: Union[Scene, Mapping[str, Any], str, os.PathLike]) -> Scene:
    from . import _as_scene

    return _as_scene(scene)


def _spad(spad: Optional[Spad]) -> Dict[str, Any]:
    if spad is None:
        return Spad().params()
    if not isinstance(spad, Spad):
        raise TypeError(f"expected a nlos_rs.sensor.Spad, got {type(spad).__name__}")
    return spad.params()


def _transient(transient) -> np.ndarray:
    return np.ascontiguousarray(np.asarray(transient), dtype=np.float32)


def expected_counts(scene, transient, spad: Optional[Spad] = None) -> np.ndarray:
    """Mean detections per bin over the exposure (float64, the transient's shape): the transient in
    absolute photon counts, through the instrument response, plus dark and ambient counts."""
    return _core.spad_expected_counts(_scene(scene), _transient(transient), _spad(spad))


def simulate(scene, transient, spad: Optional[Spad] = None, seed: int = 0) -> np.ndarray:
    """One noisy capture (int64 counts, the transient's shape); deterministic for a seed."""
    return _core.spad_simulate(_scene(scene), _transient(transient), _spad(spad), int(seed))


def coates(counts, scene, spad: Optional[Spad] = None) -> np.ndarray:
    """Coates' pile-up-corrected estimate of the mean detections per bin (float64). Without
    ``pile_up`` the counts are returned as floats."""
    c = np.asarray(counts)
    if c.dtype.kind not in "iu":
        raise _core.SceneError(f"plugin 'spad': key 'counts': expected integer counts, got {c.dtype}")
    return _core.spad_coates(_scene(scene), np.ascontiguousarray(c, dtype=np.int64), _spad(spad))

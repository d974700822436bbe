"""Error metrics of the thesis' evaluation (§5.2) — the thesis being
I. Tienda Hernando, *Técnicas de muestreo para simulación de transporte de luz sin línea de
visión* (Sampling techniques for non-line-of-sight light transport simulation), bachelor's thesis
(Trabajo Fin de Grado), Universidad de Zaragoza, 2023.

``mse`` is eq. 5.1, the mean of squared differences over the compared values; ``psnr`` is eq. 5.2,
20·log10 MAX(I) − 10·log10 MSE, with MAX the maximum of the reference. Both take optional masks:
``time_window=(first_bin, last_bin_exclusive)`` on the time axis (axis 2 of (H, W, T, C) arrays)
and ``pixels``, a boolean (H, W) mask.
"""

from __future__ import annotations

from typing import Optional, Tuple

import numpy as np


def _select(a: np.ndarray, time_window: Optional[Tuple[int, int]], pixels: Optional[np.ndarray]) -> np.ndarray:
    a = np.asarray(a, dtype=np.float64)
    if time_window is not None:
        if a.ndim < 3:
            raise ValueError("time_window needs arrays with a time axis (H, W, T[, C])")
        a = a[:, :, time_window[0]:time_window[1]]
    if pixels is not None:
        pixels = np.asarray(pixels, dtype=bool)
        if pixels.shape != a.shape[:2]:
            raise ValueError(f"pixel mask {pixels.shape} does not match the image {a.shape[:2]}")
        a = a[pixels]
    return a


def mse(ref: np.ndarray, est: np.ndarray, time_window: Optional[Tuple[int, int]] = None,
        pixels: Optional[np.ndarray] = None) -> float:
    """Mean squared error (thesis eq. 5.1)."""
    if np.shape(ref) != np.shape(est):
        raise ValueError(f"shapes differ: {np.shape(ref)} vs {np.shape(est)}")
    r, e = _select(ref, time_window, pixels), _select(est, time_window, pixels)
    return float(np.mean((r - e) ** 2))


def psnr(ref: np.ndarray, est: np.ndarray, time_window: Optional[Tuple[int, int]] = None,
         pixels: Optional[np.ndarray] = None) -> float:
    """Peak signal-to-noise ratio in dB (thesis eq. 5.2), MAX taken over the (masked) reference."""
    peak = float(np.max(_select(ref, time_window, pixels)))
    err = mse(ref, est, time_window, pixels)
    return float("inf") if err == 0 else 20 * np.log10(peak) - 10 * np.log10(err)

"""Statistical comparison of Monte Carlo estimates from independent replicates.

Two estimators agree when, for every compared quantity, Welch's t statistic of their replicate
means is consistent with zero. The tolerance is the measured replicate variance; the test level is
alpha = 1e-3 Šidák-corrected over all quantities, so a correct renderer fails about once in a
thousand runs, and never for fixed seeds once it has passed.
"""

from __future__ import annotations

import numpy as np
from scipy import stats


def welch(a: np.ndarray, b: np.ndarray):
    """Per-quantity Welch t and degrees of freedom of replicate arrays (n, ...)."""
    na, nb = len(a), len(b)
    ma, mb = a.mean(0), b.mean(0)
    va, vb = a.var(0, ddof=1) / na, b.var(0, ddof=1) / nb
    se2 = va + vb
    ok = se2 > 0
    t = np.where(ok, (ma - mb) / np.sqrt(np.where(ok, se2, 1.0)), 0.0)
    dof = np.where(ok, se2**2 / (va**2 / (na - 1) + vb**2 / (nb - 1) + 1e-300), 1.0)
    return t, dof, ok


def agreement(a: np.ndarray, b: np.ndarray, alpha: float = 1e-3) -> dict:
    """Compare replicate arrays; returns statistics and whether the two agree."""
    t, dof, ok = welch(np.asarray(a, float), np.asarray(b, float))
    m = int(ok.sum())
    p = 2 * stats.t.sf(np.abs(t[ok]), dof[ok])
    sidak = 1 - (1 - alpha) ** (1 / max(m, 1))
    return {
        "n": m,
        "max_abs_t": float(np.abs(t[ok]).max()) if m else 0.0,
        "min_p": float(p.min()) if m else 1.0,
        "sidak_level": sidak,
        "mean_t2": float(np.mean(t[ok] ** 2)) if m else 0.0,
        "agree": bool(m == 0 or p.min() > sidak),
    }


def rebin(x: np.ndarray, factor: int, axis: int) -> np.ndarray:
    """Sum groups of ``factor`` consecutive entries along ``axis`` (drops a remainder)."""
    x = np.moveaxis(x, axis, -1)
    n = x.shape[-1] // factor * factor
    x = x[..., :n].reshape(*x.shape[:-1], n // factor, factor).sum(-1)
    return np.moveaxis(x, -1, axis)


def ratio_with_error(a: np.ndarray, b: np.ndarray):
    """Ratio of replicate means of two scalars and its standard error (delta method)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    ma, mb = a.mean(), b.mean()
    r = ma / mb
    se = r * np.sqrt(a.var(ddof=1) / len(a) / ma**2 + b.var(ddof=1) / len(b) / mb**2)
    return r, se


def capture_features(t: np.ndarray) -> np.ndarray:
    """Replicates of a scan's transient (n, H, W, T) → each scan point's total and the capture's
    time profile in groups of 20 bins."""
    return np.concatenate([t.sum(-1).reshape(len(t), -1), rebin(t.sum((1, 2)), 20, -1)], axis=1)


def assert_same_capture(a: np.ndarray, b: np.ndarray, label: str):
    """Assert that two estimators' replicates (n, H, W, T) agree on every capture feature and on
    the total (ratio within 4 standard errors); print and return the ratio and its error."""
    res = agreement(capture_features(a), capture_features(b))
    r, se = ratio_with_error(a.sum((1, 2, 3)), b.sum((1, 2, 3)))
    print(f"\n{label} = {r:.4f} ± {se:.4f}; {res}")
    assert res["agree"], res
    assert abs(r - 1) < 4 * se + 1e-9, (r, se)
    return r, se

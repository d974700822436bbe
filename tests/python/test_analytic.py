"""The estimator against an analytic scene: one small diffuse patch facing the relay wall.

The three-bounce transient (wall x1 → patch y → laser spot p_L) is
  ∫_patch f1 · cos_y / r1² · f_y · cos_L / r2² · L_spot dA_y,  L_spot = E · π/|p_L − o_L|² · ρ_w/π · cos(p_L → o_L)
with Lambertian f = ρ/π · cos_out (docs/mitransient-model.md §3.6), binned by its optical path
length r1 + r2 (+ |s − x1| + |p_L − o_L| when account_first_and_last_bounces). Evaluated here with
an independent NumPy midpoint quadrature.
"""

import numpy as np
import pytest

import nlos_rs

S = np.array([-0.5, 0.0, 0.25])  # sensor and laser origin
P_L = np.zeros(3)  # laser spot: the wall centre
C, HALF = np.array([0.15, 0.1, 0.6]), 0.05  # patch centre and half side (10 x 10 cm)
W = H = 2
BINS, DT, T0 = 1400, 0.002, 0.9


def scene(afl: bool, spp: int) -> dict:
    patch = {"type": "rectangle", "bsdf": {"type": "diffuse", "reflectance": 0.7},
             "to_world": nlos_rs.Transform4f().translate(C.tolist()).rotate([1, 0, 0], 180).scale(HALF)}
    return nlos_rs.scenes.nlos_scene({"patch": patch}, width=W, height=H, spp=spp, temporal_bins=BINS,
                                     bin_width_opl=DT, start_opl=T0, capture_type="single",
                                     account_first_and_last_bounces=afl)


def quadrature(afl: bool, n: int = 700) -> np.ndarray:
    rho_w, rho_h = 1.0, 0.7
    u = (np.arange(n) + 0.5) / n * 2 - 1
    uu, vv = np.meshgrid(u, u)
    y = np.stack([C[0] + HALF * uu, C[1] - HALF * vv, np.full_like(uu, C[2])], -1).reshape(-1, 3)
    dA = (2 * HALF / n) ** 2
    n_y, n_w = np.array([0.0, 0.0, -1.0]), np.array([0.0, 0.0, 1.0])
    d_lo = np.linalg.norm(P_L - S)
    l_spot = np.pi / d_lo**2 * rho_w / np.pi * np.dot(n_w, (S - P_L) / d_lo)
    out = np.zeros((H, W, BINS))
    for iy in range(H):
        for ix in range(W):
            x1 = np.array([2 * (ix + 0.5) / W - 1, 2 * (iy + 0.5) / H - 1, 0.0])
            v1 = y - x1
            r1 = np.linalg.norm(v1, axis=1)
            w1 = v1 / r1[:, None]
            v2 = P_L - y
            r2 = np.linalg.norm(v2, axis=1)
            w2 = v2 / r2[:, None]
            f1 = rho_w / np.pi * (w1 @ n_w)
            g1 = (-w1 @ n_y) / r1**2
            f2 = rho_h / np.pi * (w2 @ n_y)
            g2 = (-w2 @ n_w) / r2**2
            val = f1 * g1 * f2 * g2 * l_spot * dA
            opl = r1 + r2 + ((np.linalg.norm(x1 - S) + d_lo) if afl else 0.0)
            b = np.floor((opl - T0) / DT).astype(int)
            assert b.min() >= 0 and b.max() < BINS
            out[iy, ix] = np.bincount(b, weights=val, minlength=BINS)
    return out


@pytest.mark.parametrize("afl", [False, True])
def test_patch_matches_quadrature(afl):
    spp = 1 << 23  # per-bin Monte Carlo noise ~0.2 % of the peak
    _, t = nlos_rs.render(scene(afl, spp), progress=False)
    mc = t[..., 0].astype(float)
    ref = quadrature(afl)
    tot_err = np.abs(mc.sum(-1) / ref.sum(-1) - 1)
    peak_err = np.abs(mc - ref).max(-1) / ref.max(-1)
    print(f"\nafl={afl}: total rel. error per pixel {tot_err.ravel()}, max bin error / peak {peak_err.ravel()}")
    assert tot_err.max() < 0.01
    assert peak_err.max() < 0.01
    # The peak sits at the same optical path length.
    assert np.all(np.abs(mc.argmax(-1) - ref.argmax(-1)) <= 1)


def test_first_and_last_bounces_shift_by_the_two_legs():
    """Same seed, same paths: the flag only adds |s - x1| + |p_L - o_L| to every optical path."""
    _, a = nlos_rs.render(scene(False, 1 << 14), progress=False)
    _, b = nlos_rs.render(scene(True, 1 << 14), progress=False)
    bins = np.arange(BINS)
    for iy in range(H):
        for ix in range(W):
            x1 = np.array([2 * (ix + 0.5) / W - 1, 2 * (iy + 0.5) / H - 1, 0.0])
            legs = np.linalg.norm(x1 - S) + np.linalg.norm(P_L - S)
            pa, pb = a[iy, ix, :, 0], b[iy, ix, :, 0]
            np.testing.assert_allclose(pa.sum(), pb.sum(), rtol=1e-5)
            shift = (pb @ bins) / pb.sum() - (pa @ bins) / pa.sum()
            assert abs(shift - legs / DT) < 0.5, (shift, legs / DT)

"""Error you can see and control: ``render(..., return_variance=True)`` (each transient value's
variance of the mean) and ``render(..., target_rel_error=e, max_spp=n)`` (adaptive sampling per scan
point). Checked against the spread of independent seeds, on the built-in Z and on a file from
mitransient's repository."""

import os

import numpy as np
import pytest

import nlos_rs
from nlos_rs import scenes

SEEDS = 16
SIMPLE = os.path.join(os.path.dirname(__file__), "..", "data", "mitransient", "transient-nlos", "nlos-z-simple.xml")


def z(**kw):
    kw.setdefault("width", 8)
    kw.setdefault("height", 8)
    return scenes.z_nlos_1corner(**kw)


CASES = {
    "z single": lambda: (z(), {"spp": 1024}),
    "z confocal, triweight kernel": lambda: (z(capture_type="confocal"), {"spp": 512, "kernel": "triweight",
                                                                          "kernel_bandwidth": 2.0}),
    "z rgb": lambda: (z(), {"spp": 256, "variant": "rgb"}),
    "mitransient nlos-z-simple.xml": lambda: (nlos_rs.load_file(SIMPLE), {"spp": 256}),
}


@pytest.mark.parametrize("case", list(CASES))
def test_predicted_variance_matches_the_spread_across_seeds(case):
    scene, kw = CASES[case]()
    runs = [nlos_rs.render(scene, seed=s, progress=False, return_variance=True, **kw) for s in range(SEEDS)]
    transients = np.stack([r[1] for r in runs])
    predicted = np.stack([r[2] for r in runs]).mean(0)
    spread = transients.var(0, ddof=1)
    lit = spread > 0
    # Summed over bins (the variance of a bin's sum over the capture), and bin by bin (median).
    total = predicted[lit].sum() / spread[lit].sum()
    median = np.median(predicted[lit] / spread[lit])
    print(f"\n{case}: predicted/spread = {total:.3f} (sum), {median:.3f} (median over {lit.sum()} bins)")
    assert 0.8 <= total <= 1.25 and 0.8 <= median <= 1.25
    assert (predicted[~lit] == 0).all() and (predicted >= 0).all()


def test_variance_changes_nothing_else():
    d = z(spp=300)
    steady, transient = nlos_rs.render(d, seed=4, progress=False)
    s2, t2, var = nlos_rs.render(d, seed=4, progress=False, return_variance=True)
    assert np.array_equal(steady, s2) and np.array_equal(transient, t2) and var.shape == transient.shape
    # Exhaustive captures and phasor films carry a variance per value too.
    ex = z(width=2, height=2, capture_type="exhaustive", spp=64)
    t, v = nlos_rs.render(ex, progress=False, return_variance=True)[1:]
    assert v.shape == t.shape and v.sum() > 0
    ph = z(width=2, height=2, spp=64)
    ph["relay_wall"]["nlos_sensor"]["film"].update(type="phasor_hdr_film", wl_mean=0.06, wl_sigma=0.06)
    t, v = nlos_rs.render(ph, progress=False, return_variance=True)[1:]
    assert v.shape == t.shape and v.sum() > 0


def test_target_rel_error_holds_at_90_percent_confidence():
    """Each scan point's total, sampled until its relative error is within e at 90 % confidence,
    deviates from a high-spp reference by about e / 1.645 (RMS over points and seeds), and by at most
    1.3 e on at least 90 % of the points (the issue's "2.6 % on 90 % of points at e = 0.02"), on two
    scenes."""
    for scene, e, ref_spp, max_spp in ((z(), 0.02, 1 << 21, 1 << 20),
                                       (nlos_rs.load_file(SIMPLE), 0.1, 1 << 17, 1 << 16)):
        ref = nlos_rs.render(scene, spp=ref_spp, progress=False)[0][..., 0]
        lit = ref > 0
        rel = np.array([nlos_rs.render(scene, seed=100 + s, target_rel_error=e, max_spp=max_spp,
                                       progress=False)[0][..., 0][lit] / ref[lit] - 1 for s in range(4)])
        rms = np.sqrt(np.mean(rel**2)) / e
        within = np.mean(np.abs(rel) <= 1.3 * e)
        print(f"\ne={e}: RMS error {rms:.3f} e; {within:.1%} of points within 1.3 e; "
              f"{np.mean(np.abs(rel) <= e):.1%} within e")
        assert 0.45 <= rms <= 0.75
        assert within >= 0.9


def test_target_rel_error_is_deterministic_and_adapts():
    d = z(width=4, height=4)
    a = nlos_rs.render(d, target_rel_error=0.03, max_spp=20000, seed=2, threads=1, progress=False)
    b = nlos_rs.render(d, target_rel_error=0.03, max_spp=20000, seed=2, threads=2, progress=False)
    assert all(np.array_equal(x, y) for x, y in zip(a, b))
    # A looser target stops earlier: a different (noisier) estimate; the budget caps it.
    loose = nlos_rs.render(d, target_rel_error=0.2, max_spp=20000, seed=2, progress=False)
    assert not np.array_equal(loose[1], a[1])
    capped = nlos_rs.render(d, target_rel_error=1e-6, max_spp=1024, seed=2, progress=False)
    # Adaptive sampling traces one path per scan point: the same samples as a render without sample
    # reuse (which adds a 16-pixel film's samples in chunks: float rounding).
    per_point = z(width=4, height=4, nlos_sample_reuse=False)
    np.testing.assert_allclose(capped[1], nlos_rs.render(per_point, spp=1024, seed=2, progress=False)[1], rtol=1e-5, atol=0)


@pytest.mark.parametrize("kw, key", [
    ({"return_variance": True, "spp": 1}, "return_variance"),
    ({"target_rel_error": 0.0}, "target_rel_error"),
    ({"target_rel_error": float("nan")}, "target_rel_error"),
    ({"max_spp": 100}, "max_spp"),
    ({"kernel": "parabolic", "kernel_bandwidth": 1.0}, "kernel"),
    ({"kernel": "cosine", "kernel_sigma": 1.0}, "kernel_bandwidth"),
])
def test_bad_options_name_their_key(kw, key):
    with pytest.raises(nlos_rs.SceneError, match=key):
        nlos_rs.render(z(width=2, height=2, spp=4), progress=False, **kw)


def test_renders_in_parts_refuse_per_sample_options():
    from nlos_rs import _core

    scene = nlos_rs.load_dict(z(width=2, height=2, spp=4))
    for key, value in (("return_variance", True), ("target_rel_error", 0.1)):
        with pytest.raises(nlos_rs.SceneError, match=key):
            _core.render_part(scene, (0, 1), (0, 1), {"mono": True, key: value})

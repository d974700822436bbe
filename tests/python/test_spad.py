"""nlos_rs.sensor on real renders: absolute calibration checked against an independent computation,
linearity, the background formula, Poisson statistics over seeds, Coates at high flux, every
capture type, tal reading the counts back, and bad input. The maths without a scene (instrument
response, pile-up law, afterpulses, crosstalk) is tested in tests/spad.rs."""

import numpy as np
import pytest

import nlos_rs
from nlos_rs import SceneError, scenes, sensor

C = 299_792_458.0
PLANCK = 6.626_070_15e-34


@pytest.fixture(scope="module")
def z():
    scene = nlos_rs.load_dict(scenes.z_nlos_1corner(width=8, height=8, spp=256, temporal_bins=300, bin_width_opl=0.006))
    return scene, nlos_rs.render(scene, progress=False, seed=1)[1]


def test_calibration_matches_the_formula_computed_here(z):
    # No instrument response and no background: λ = k · H per pixel, with k from docs/sensor.md
    # computed here from the scene's geometry. The Z's laser sits at (-0.5, 0, 0.25) aimed at the
    # wall's centre (0, 0, 0) on its axis: W = π / z_l², E_spot = E · W · cos θ_L with E = 1.
    scene, h = z
    spad = sensor.Spad(pulse_fwhm_ps=0.0, jitter_fwhm_ps=0.0, dark_count_rate_hz=0.0)
    lam = sensor.expected_counts(scene, h, spad)
    laser = np.array([-0.5, 0.0, 0.25])
    z_l = np.linalg.norm(laser)
    e_spot = np.pi / z_l**2 * (0.25 / z_l)
    q = spad.laser_power_w / spad.rep_rate_hz
    photon = PLANCK * C / (spad.wavelength_nm * 1e-9)
    aperture = np.pi * (spad.aperture_diameter_mm * 0.5e-3) ** 2
    s = np.array(scene.sensor_origin)
    for (row, col) in [(0, 0), (3, 5), (7, 7)]:
        x = np.array(scene.scan_points()[row][col])
        d2 = np.sum((s - x) ** 2)
        cos = (s - x)[2] / np.sqrt(d2)
        k = q / e_spot * spad.footprint_m2 * cos * aperture / d2 * spad.efficiency * spad.exposure_s * spad.rep_rate_hz / photon
        np.testing.assert_allclose(lam[row, col], k * h[row, col].astype(np.float64), rtol=2e-5, atol=0)
    assert lam.sum() > 0


def test_linear_in_power_exposure_and_efficiency(z):
    scene, h = z
    base = sensor.Spad(dark_count_rate_hz=0.0)
    lam = sensor.expected_counts(scene, h, base)
    for key, f in [("laser_power_w", 3.0), ("exposure_s", 0.5), ("efficiency", 2.0)]:
        other = sensor.Spad(**{**base.params(), key: getattr(base, key) * f})
        np.testing.assert_allclose(sensor.expected_counts(scene, h, other), f * lam, rtol=1e-12, atol=1e-300)


def test_background_is_rate_times_exposure_times_rep_rate_times_bin(z):
    scene, h = z
    spad = sensor.Spad(dark_count_rate_hz=1234.0, ambient_rate_hz=5e5, exposure_s=2e-3)
    lam = sensor.expected_counts(scene, np.zeros_like(h), spad)
    bins, dt, t0 = scene.temporal
    want = (1234.0 + 5e5) * 2e-3 * spad.rep_rate_hz * (dt / C)
    np.testing.assert_allclose(lam, want, rtol=1e-12)


def test_poisson_over_seeds_and_determinism(z):
    # 64 seeds: per bin the mean count's standard error is sqrt(λ / 64); the z-scores of all bins
    # with λ > 1 must look standard normal (mean within 5/sqrt(n), variance within 10 %).
    scene, h = z
    spad = sensor.Spad(exposure_s=1e-4)
    lam = sensor.expected_counts(scene, h, spad)
    draws = np.stack([sensor.simulate(scene, h, spad, seed=s) for s in range(64)]).astype(np.float64)
    m = lam > 1.0
    zs = (draws.mean(0)[m] - lam[m]) / np.sqrt(lam[m] / 64)
    assert abs(zs.mean()) < 5 / np.sqrt(m.sum()) and abs(zs.var() - 1) < 0.1, (zs.mean(), zs.var())
    ratio = draws.var(0, ddof=1)[m].mean() / lam[m].mean()
    assert abs(ratio - 1) < 0.05, ratio
    assert np.array_equal(draws[3], sensor.simulate(scene, h, spad, seed=3))
    assert draws.dtype == np.float64 and sensor.simulate(scene, h, spad).dtype == np.int64


def test_pile_up_at_high_flux_and_coates_recovers_lambda(z):
    # 50 mW for 2 ms on the Z: up to 3 photons per laser period per scan point, so raw counts are
    # skewed early (late bins keep as little as 14 % of λ). Coates' estimate, averaged over 16 seeds,
    # is within 5 % of λ wherever a bin holds over 200 counts, and within 5 standard errors wherever
    # it holds over 10: per seed Var(λ̂_i) ≈ N² q / (M (1 − q)), q = 1 − e^{−λ_i/N}, M the periods
    # still without a detection.
    scene, h = z
    spad = sensor.Spad(laser_power_w=0.05, exposure_s=2e-3, pile_up=True, ambient_rate_hz=1e6)
    lam = sensor.expected_counts(scene, h, spad)
    n = spad.exposure_s * spad.rep_rate_hz
    assert (lam.sum(axis=2) / n).max() > 2.0, "not a high-flux test"
    counts = [sensor.simulate(scene, h, spad, seed=s) for s in range(16)]
    assert all(c.sum(axis=2).max() <= n for c in counts)
    est = np.mean([sensor.coates(c, scene, spad) for c in counts], axis=0)
    raw = np.mean(counts, axis=0)
    m = raw > 200
    assert m.sum() > 100
    assert np.abs(est[m] / lam[m] - 1).max() < 0.05
    q = 1 - np.exp(-lam / n)
    alive = n * np.exp(-(np.cumsum(lam, axis=2) - lam) / n)
    se = n * np.sqrt(q / (alive * (1 - q))) / 4
    ok = raw > 10  # the normal approximation of the binomial holds
    assert (np.abs(est - lam)[ok] < 5 * se[ok] + 1e-9).all()
    # Without Coates the late part of a bright histogram is under-counted.
    assert (raw[m] / lam[m]).min() < 0.5


@pytest.mark.parametrize("capture", ["confocal", "exhaustive"])
def test_confocal_and_exhaustive(capture):
    d = scenes.z_nlos_1corner(width=4, height=4, spp=64, capture_type=capture)
    scene = nlos_rs.load_dict(d)
    h = nlos_rs.render(scene, progress=False)[1]
    lam = sensor.expected_counts(scene, h, sensor.Spad())
    counts = sensor.simulate(scene, h, sensor.Spad(pile_up=True), seed=2)
    assert lam.shape == h.shape == counts.shape and lam.sum() > 0 and counts.sum() > 0
    assert h.ndim == (6 if capture == "exhaustive" else 4)


def test_tal_reads_the_counts_back_exactly(z, tmp_path):
    tal = pytest.importorskip("tal")
    scene, h = z
    spad = sensor.Spad()
    counts = sensor.simulate(scene, h, spad, seed=4)
    path = tmp_path / "counts.hdf5"
    nlos_rs.io.write_capture(path, scene, counts, scene_info={"spad": spad.params()})
    data = tal.io.read_capture(str(path))
    assert data.H.dtype.kind == "i"
    assert np.array_equal(data.H, np.transpose(counts[..., 0], (2, 1, 0)))
    assert data.scene_info["spad"]["exposure_s"] == spad.exposure_s


def test_cli_writes_counts(tmp_path):
    from nlos_rs.__main__ import main

    out = tmp_path / "c.hdf5"
    assert main(["render", "z_nlos_1corner", "--width", "4", "--height", "4", "--spp", "16", "--quiet",
                 "--spad", "exposure_s=1e-3,pile_up=true", "--out", str(out)]) == 0
    import h5py

    with h5py.File(out) as f:
        assert f["H"].dtype.kind == "i" and f["H"][()].sum() > 0
    assert main(["render", "z_nlos_1corner", "--spad", "exposure_s=-1", "--out", str(tmp_path / "x.hdf5")]) == 2
    assert not (tmp_path / "x.hdf5").exists()


@pytest.mark.parametrize("kw,key", [
    ({"exposure_s": -1.0}, "exposure_s"),
    ({"exposure_s": float("nan")}, "exposure_s"),
    ({"laser_power_w": float("inf")}, "laser_power_w"),
    ({"efficiency": 1.5}, "efficiency"),
    ({"irf": [0.0, 0.0]}, "irf"),
    ({"irf": [1.0, -1.0, 2.0]}, "irf"),
    ({"irf": [1.0, float("nan")]}, "irf"),
    ({"irf": [[1.0, 2.0]]}, "irf"),
    ({"afterpulse_prob": 0.1}, "afterpulse_prob"),
    ({"dead_time_ns": 1000.0}, "dead_time_ns"),
    ({"pile_up": 1}, "pile_up"),
])
def test_bad_parameters_raise_scene_error_naming_the_key(kw, key):
    with pytest.raises(SceneError, match=f"'spad'.*'{key}'"):
        sensor.Spad(**kw)


def test_bad_input_raises_scene_error(z):
    scene, h = z
    with pytest.raises(SceneError, match="rgb"):
        sensor.expected_counts(scene, np.repeat(h, 3, axis=-1), sensor.Spad())
    with pytest.raises(SceneError, match="do not match"):
        sensor.simulate(scene, h[:4], sensor.Spad())
    for bad in (np.nan, np.inf, -1.0):
        with pytest.raises(SceneError, match="'transient'.*not finite"):
            sensor.expected_counts(scene, np.where(h > 0, bad, h), sensor.Spad())
    with pytest.raises(SceneError, match="overflow"):
        sensor.expected_counts(scene, h * np.float32(3e38), sensor.Spad(laser_power_w=1e300))
    with pytest.raises(SceneError, match="counts"):
        sensor.coates(-np.ones(h.shape, np.int64), scene, sensor.Spad(pile_up=True))
    with pytest.raises(SceneError, match="counts"):
        sensor.coates(h, scene, sensor.Spad(pile_up=True))
    nee = nlos_rs.load_dict(scenes.z_nlos_1corner(width=8, height=8, spp=4, temporal_bins=300, bin_width_opl=0.006,
                                                  nlos_laser_sampling=False))
    with pytest.raises(SceneError, match="nlos_laser_sampling"):
        sensor.expected_counts(nee, h, sensor.Spad())
    with pytest.raises(SceneError, match="longer than the laser period"):
        sensor.expected_counts(scene, h, sensor.Spad(rep_rate_hz=1e9))

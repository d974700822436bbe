"""The thesis' techniques: HGRS (transient_nlos_path_rs), temporal KDE, the two-corner T scenes."""

import numpy as np
import pytest

import nlos_rs
from nlos_rs import metrics
from nlos_rs.mitsuba_compat import render_mitransient
from stats import agreement, ratio_with_error, rebin

REPS = 6


def z(**kw):
    """The Z with the thesis' baseline: one path per scan point (no sample reuse)."""
    kw.setdefault("width", 8)
    kw.setdefault("height", 8)
    kw.setdefault("nlos_sample_reuse", False)
    return nlos_rs.scenes.z_nlos_1corner(**kw)


def reps(d, n=REPS, first_seed=0, **render_kw):
    seeds = range(first_seed, first_seed + n)
    return np.array([nlos_rs.render(d, seed=k, progress=False, **render_kw)[1][..., 0] for k in seeds])


def features(t):
    return np.concatenate([t.sum(-1).reshape(len(t), -1), rebin(t.sum((1, 2)), 10, -1)], axis=1)


# ---- temporal kernel density estimation


KERNELS = [{"kernel_sigma": 2.0}, {"kernel_bandwidth": 3.0}] + [
    {"kernel": k, "kernel_bandwidth": 2.6} for k in ("triangular", "biweight", "triweight", "cosine")]


@pytest.mark.parametrize("kw", KERNELS)
def test_kde_conserves_each_pixels_energy(kw):
    d = z(spp=512)
    box = nlos_rs.render(d, seed=1, progress=False)[1]
    kde = nlos_rs.render(d, seed=1, progress=False, **kw)[1]
    # Same seed, same paths; the Z's signal stays > 8 bins inside the window.
    np.testing.assert_allclose(kde.sum(2), box.sum(2), rtol=1e-5, atol=1e-9)
    assert np.abs(kde - box).max() > 0


FINE = 16  # sub-bins per bin of the reference histogram


def smoothing_matrix(kind, width, n):
    """Weights taking a histogram with FINE sub-bins per bin to E[kernel bins]: a contribution in
    sub-bin i, placed uniformly inside it, gives bin j the kernel's integral over bin j."""
    v = lambda u: np.clip(u / width, -1, 1)  # noqa: E731
    f = {"gaussian": lambda u: np.exp(-u * u / (2 * width**2)) * (np.abs(u) <= 4 * width),
         "epanechnikov": lambda u: 1 - v(u) ** 2,
         "triangular": lambda u: 1 - np.abs(v(u)),
         "biweight": lambda u: (1 - v(u) ** 2) ** 2,
         "triweight": lambda u: (1 - v(u) ** 2) ** 3,
         "cosine": lambda u: np.cos(np.pi / 2 * v(u)) * (np.abs(u) < width)}[kind]
    u = np.linspace(-14, 14, 28 * 256 + 1)
    cdf = np.concatenate([[0.0], np.cumsum((f(u[1:]) + f(u[:-1])) / 2)])
    cdf /= cdf[-1]
    big_f = lambda v: np.interp(v, u, cdf)  # noqa: E731
    m = np.zeros((n, n * FINE))
    sub = (np.arange(8) + 0.5) / 8  # positions inside a sub-bin
    for i in range(n * FINE):
        x = (i + sub) / FINE  # arrival positions, in bins
        for j in range(max(0, int(x[0]) - 13), min(n, int(x[-1]) + 14)):
            m[j, i] = np.mean(big_f(j + 1 - x) - big_f(j - x))
    return m


@pytest.mark.parametrize("kind, width", [("gaussian", 2.0), ("epanechnikov", 3.0), ("triangular", 2.5),
                                         ("biweight", 3.5), ("triweight", 4.0), ("cosine", 3.0)])
def test_kde_shape_is_the_box_result_smoothed_by_the_bin_integrated_kernel(kind, width):
    """E[KDE] equals a finely binned box result smoothed by the bin-integrated kernel (Jarabo et
    al. 2014's shapes, integrated numerically here); compared across independent replicates."""
    kw = {"kernel_sigma": width} if kind == "gaussian" else {"kernel": kind, "kernel_bandwidth": width}
    d = z(width=4, height=4, spp=4096)
    fine = z(width=4, height=4, spp=4096, temporal_bins=300 * FINE, bin_width_opl=0.006 / FINE)
    box = reps(fine, n=12).sum((1, 2))
    kde = reps(d, n=12, first_seed=100, **kw).sum((1, 2))  # independent of the box replicates
    smoothed = box @ smoothing_matrix(kind, width, kde.shape[-1]).T
    res = agreement(rebin(kde, 2, -1), rebin(smoothed, 2, -1))
    print(f"\n{kind}: {res}")
    assert res["agree"], res


def test_integrator_temporal_filter_gaussian_is_the_kernel():
    d = z(spp=64)
    ref = nlos_rs.render(d, progress=False, kernel_sigma=1.5)[1]
    d["integrator"].update(temporal_filter="gaussian", gaussian_stddev=1.5)
    assert nlos_rs.load_dict(d).temporal_kernel == ("gaussian", 1.5)
    assert np.array_equal(nlos_rs.render(d, progress=False)[1], ref)
    d2 = z(spp=64)
    d2["relay_wall"]["nlos_sensor"]["film"]["kernel_bandwidth"] = 2.0
    assert np.array_equal(nlos_rs.render(d2, progress=False)[1], nlos_rs.render(z(spp=64), progress=False, kernel_bandwidth=2.0)[1])


def test_kde_works_in_rgb_and_every_capture_type():
    for cap, size in [("single", 4), ("confocal", 4), ("exhaustive", 2)]:
        # A window holding the whole signal (kernels spill energy past the window's ends).
        d = z(width=size, height=size, spp=64, capture_type=cap, temporal_bins=600, start_opl=0.5)
        box = nlos_rs.render(d, progress=False, variant="rgb")[1]
        kde = nlos_rs.render(d, progress=False, variant="rgb", kernel_bandwidth=2.5)[1]
        np.testing.assert_allclose(kde.sum(-2), box.sum(-2), rtol=1e-5, atol=1e-9)


# ---- Hidden Geometry Rejection Sampling


def test_hgrs_resampled_matches_the_baseline_on_z():
    d = z(width=4, height=4, spp=2048)
    base = reps(d)
    rs = reps(d, integrator="transient_nlos_path_rs")
    res = agreement(features(rs), features(base))
    r, se = ratio_with_error(rs.sum((1, 2, 3)), base.sum((1, 2, 3)))
    print(f"\nZ: HGRS resampled / baseline = {r:.4f} ± {se:.4f}; {res}")
    assert res["agree"] and abs(r - 1) < 4 * se


def two_corner(spp, **kw):
    return nlos_rs.scenes.t_nlos_2corner("small", width=4, height=4, spp=spp, filter_bounces=4, nlos_sample_reuse=False, **kw)


def test_hgrs_resampled_matches_the_baseline_on_two_corners():
    base = reps(two_corner(131072))
    rs = reps(two_corner(131072), integrator="transient_nlos_path_rs")
    r, se = ratio_with_error(rs.sum((1, 2, 3)), base.sum((1, 2, 3)))
    res = agreement(features(rs), features(base))
    print(f"\nT small, five vertices: HGRS resampled / baseline = {r:.4f} ± {se:.4f}; {res}")
    assert res["agree"] and abs(r - 1) < 4 * se


@pytest.mark.parametrize("reuse", [False, True])
def test_hgrs_candidate_roulette_matches_the_baseline_and_casts_fewer_rays(reuse):
    """hgrs_candidate_roulette=0.25: after a vertex's first visible candidate, each later one is
    drawn with probability 1/4 and counts 4 — unbiased (against the baseline, one path per scan
    point and on a shared light subpath), and cheaper than testing all ten."""
    def rs(roulette, **kw):
        d = z(width=4, height=4, spp=2048, nlos_sample_reuse=reuse, **kw)
        d["integrator"].update(type="transient_nlos_path_rs", hgrs_candidate_roulette=roulette)
        return d
    base = reps(z(width=4, height=4, spp=2048, nlos_sample_reuse=reuse), n=10)
    rr = reps(rs(0.25), n=10, first_seed=100)
    res = agreement(features(rr), features(base))
    r, se = ratio_with_error(rr.sum((1, 2, 3)), base.sum((1, 2, 3)))
    print(f"\nZ (reuse={reuse}): HGRS with candidate roulette / baseline = {r:.4f} ± {se:.4f}; {res}")
    assert res["agree"] and abs(r - 1) < 4 * se
    # Fewer candidates tested, so faster than all ten (time is not asserted: it is printed).
    import time
    for q in (1.0, 0.25):
        scene = nlos_rs.load_dict(rs(q))
        t0 = time.perf_counter()
        nlos_rs.render(scene, progress=False)
        print(f"roulette {q}: {time.perf_counter() - t0:.3f} s")
    with pytest.raises(nlos_rs.SceneError, match="hgrs_candidate_roulette"):
        nlos_rs.load_dict(rs(0.0))
    bad = rs(0.5)
    bad["integrator"]["hgrs_estimator"] = "rejection"
    with pytest.raises(nlos_rs.SceneError, match="hgrs_candidate_roulette"):
        nlos_rs.load_dict(bad)


@pytest.mark.parametrize("scene", ["z", "two_corner"])
def test_rejection_estimator_bias_is_measured(scene):
    """The thesis' estimator over-weights visible points where part of the hidden geometry is not
    visible; the bias is reported (docs/thesis-reproduction.md), not hidden."""
    d = z(width=4, height=4, spp=4096) if scene == "z" else two_corner(16384)
    base = reps(d).sum((1, 2, 3))
    rej = reps(d, integrator="transient_nlos_path_rs", hgrs_estimator="rejection").sum((1, 2, 3))
    r, se = ratio_with_error(rej, base)
    print(f"\n{scene}: HGRS rejection / unbiased = {r:.4f} ± {se:.4f}")
    assert r - 1 > 4 * se


def test_integrator_switch_keeps_the_other_parameters():
    d = z(spp=64)
    d["integrator"]["max_depth"] = 3
    scene = nlos_rs.load_dict(d).with_integrator("transient_nlos_path_rs", hgrs_max_iterations=4)
    assert scene.integrator == "transient_nlos_path_rs"
    d2 = z(spp=64)
    d2["integrator"].update(type="transient_nlos_path_rs", max_depth=3, hgrs_max_iterations=4)
    assert np.array_equal(nlos_rs.render(scene, progress=False)[1], nlos_rs.render(d2, progress=False)[1])
    with pytest.raises(nlos_rs.SceneError, match="hgrs_estimator"):
        nlos_rs.render(d, integrator="transient_nlos_path_rs", hgrs_estimator="magic")
    with pytest.raises(nlos_rs.SceneError, match="nlos_hidden_geometry_sampling"):
        nlos_rs.render(z(spp=8, nlos_hidden_geometry_sampling=False), integrator="transient_nlos_path_rs")
    d3 = z(spp=8)
    d3["integrator"]["hgrs_max_iterations"] = 5
    with pytest.raises(nlos_rs.SceneError, match="hgrs_max_iterations"):
        nlos_rs.load_dict(d3)  # only transient_nlos_path_rs has it


# ---- two-corner scenes


@pytest.mark.parametrize("secondary", ["small", "big"])
def test_the_t_is_seen_only_through_two_corners(secondary):
    def render(fb, t_reflectance):
        # Few paths reach the T (about 1 in 200,000 on the small scene, ~20 here): at 4096 spp
        # none may, which made this test depend on the random stream.
        # One path per scan point: 64 x 65536 independent paths (shared light subpaths would be
        # 65536, and the rare T paths then show in every pixel or in none).
        d = nlos_rs.scenes.t_nlos_2corner(secondary, width=8, height=8, spp=65536, filter_bounces=fb,
                                          nlos_sample_reuse=False)
        d["t"]["bsdf"]["reflectance"]["value"] = [t_reflectance] * 3
        return nlos_rs.render(d, progress=False)[1]

    # "Without" the T: a T that reflects next to nothing, not a black one, which hidden-geometry
    # sampling would leave out of its area, drawing other points.
    three_with, three_without = render(2, 1.0), render(2, 1e-20)
    assert three_with.sum() > 0 and np.array_equal(three_with, three_without)  # same paths, no T at 3 bounces
    five_with, five_without = render(4, 1.0), render(4, 1e-20)
    print(f"\n{secondary}: T share of the five-vertex signal {1 - five_without.sum() / five_with.sum():.4f}")
    assert five_with.sum() > five_without.sum()


@pytest.mark.peer
@pytest.mark.parametrize("secondary, fb, spp", [("small", 2, 16384), ("small", 4, 262144), ("big", 2, 4096), ("big", 4, 65536)])
def test_two_corner_scenes_match_mitransient(peer, secondary, fb, spp):
    """Laser + BSDF sampling, where mitransient is unbiased on these scenes."""
    d = nlos_rs.scenes.t_nlos_2corner(secondary, width=4, height=4, spp=spp, filter_bounces=fb,
                                      nlos_hidden_geometry_sampling=False)
    ours = np.array([nlos_rs.render(d, seed=k, progress=False)[1][..., 0] for k in range(8)])
    theirs = np.array([render_mitransient(d, spp=spp, seed=k)[1][..., 0] for k in range(8)])
    res = agreement(features(ours), features(theirs))
    r, se = ratio_with_error(ours.sum((1, 2, 3)), theirs.sum((1, 2, 3)))
    print(f"\n{secondary} fb={fb}: total ratio {r:.4f} ± {se:.4f}; {res}")
    assert theirs.sum() > 0 and res["agree"] and abs(r - 1) < 4 * se


# ---- the evaluation's claim at equal spp


def test_techniques_lower_the_mse_at_equal_spp_on_z():
    d = z(width=8, height=8, spp=128)
    gt = nlos_rs.render(d, spp=1 << 17, seed=999, progress=False)[1]
    runs = {
        "baseline": {},
        "hgrs": {"integrator": "transient_nlos_path_rs"},
        "gaussian": {"kernel_sigma": 1.0},
        "epanechnikov": {"kernel_bandwidth": 2.0},
    }
    errs = {name: np.array([metrics.mse(gt, nlos_rs.render(d, seed=k, progress=False, **kw)[1]) for k in range(8)])
            for name, kw in runs.items()}
    base = errs["baseline"]
    for name in ("hgrs", "gaussian", "epanechnikov"):
        e = errs[name]
        diff, se = base.mean() - e.mean(), np.sqrt(base.var(ddof=1) / len(base) + e.var(ddof=1) / len(e))
        print(f"\n{name}: MSE {e.mean():.3e} vs baseline {base.mean():.3e} ({100 * (1 - e.mean() / base.mean()):.1f} % lower, {diff / se:.1f} SE)")
        assert diff > 3 * se


# ---- metrics


def test_metrics():
    ref = np.zeros((2, 2, 4, 1))
    ref[0, 0, 1] = 2.0
    est = ref.copy()
    est[1, 1, 2] = 1.0
    assert metrics.mse(ref, est) == pytest.approx(1 / 16)
    assert metrics.psnr(ref, est) == pytest.approx(20 * np.log10(2) - 10 * np.log10(1 / 16))
    assert metrics.mse(ref, est, time_window=(0, 2)) == 0
    assert metrics.psnr(ref, ref) == float("inf")
    mask = np.array([[True, False], [False, True]])
    assert metrics.mse(ref, est, pixels=mask) == pytest.approx(1 / 8)
    with pytest.raises(ValueError):
        metrics.mse(ref, est[:1])

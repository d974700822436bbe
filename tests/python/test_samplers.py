"""Mitsuba's sampler plugins: `stratified`, `multijitter`, `orthogonal` and `ldsampler` are accepted,
with Mitsuba 3's rounding of `sample_count`, and draw from one Owen-scrambled Sobol' sequence
(docs/techniques.md). The estimate stays unbiased (agrees with `independent` across seeds), is
deterministic whatever the threads, and at equal spp its error is lower."""

import copy

import numpy as np
import pytest

import nlos_rs
from nlos_rs import metrics, scenes
from stats import agreement, rebin


def z(sampler="independent", **kw):
    kw.setdefault("width", 6)
    kw.setdefault("height", 6)
    d = scenes.z_nlos_1corner(**kw)
    d["relay_wall"]["nlos_sensor"]["sampler"]["type"] = sampler
    return d


# Mitsuba 3.9's sample_count after rounding (measured with mi.load_dict(...).sample_count()).
ROUNDED = {
    "stratified": {1: 1, 2: 4, 10: 16, 26: 36, 1000: 1024, 5000: 5041},
    "multijitter": {1: 1, 2: 2, 10: 12, 17: 20, 1000: 1023, 5000: 5040},
    "orthogonal": {1: 4, 10: 25, 26: 49, 50: 121, 1000: 1369, 5000: 5041},
    "ldsampler": {1: 4, 10: 16, 17: 64, 1000: 1024, 5000: 16384},
}


@pytest.mark.parametrize("sampler", list(ROUNDED))
def test_sample_count_is_rounded_as_mitsuba_does(sampler):
    for n, spp in ROUNDED[sampler].items():
        d = z(sampler, spp=n)
        assert nlos_rs.load_dict(d).spp == spp, (sampler, n)


def test_low_discrepancy_agrees_with_independent_and_is_deterministic():
    reps = {name: np.array([nlos_rs.render(z(name, spp=4096), seed=s, progress=False)[1][..., 0] for s in range(10)])
            for name in ("independent", "stratified")}
    feats = {k: np.concatenate([v.sum(-1).reshape(len(v), -1), rebin(v.sum((1, 2)), 10, -1)], axis=1)
             for k, v in reps.items()}
    res = agreement(feats["stratified"], feats["independent"])
    print(f"\nstratified vs independent: {res}")
    assert res["agree"]
    d = z("ldsampler", width=5, height=3, spp=3000, capture_type="confocal")
    a = nlos_rs.render(d, threads=1, progress=False)
    b = nlos_rs.render(d, threads=2, progress=False)
    assert all(np.array_equal(x, y) for x, y in zip(a, b))


@pytest.mark.parametrize("reuse", [True, False])
def test_low_discrepancy_lowers_the_error_at_equal_spp(reuse):
    d = z(width=8, height=8, nlos_sample_reuse=reuse)
    gt = nlos_rs.render(d, spp=1 << 20, seed=999, progress=False)[1]
    err = {}
    for name in ("independent", "stratified"):
        dd = copy.deepcopy(d)
        dd["relay_wall"]["nlos_sensor"]["sampler"]["type"] = name
        err[name] = np.mean([metrics.mse(gt, nlos_rs.render(dd, spp=4096, seed=s, progress=False)[1]) for s in range(6)])
    print(f"\nreuse={reuse}: MSE stratified / independent = {err['stratified'] / err['independent']:.3f}")
    assert err["stratified"] < err["independent"]


def test_the_sampler_can_be_chosen_per_render():
    d = z(spp=512)
    a = nlos_rs.render(d, sampler="orthogonal", progress=False)[1]
    b = nlos_rs.render(z("orthogonal", spp=512), spp=512, progress=False)[1]
    assert np.array_equal(a, b) and not np.array_equal(a, nlos_rs.render(d, progress=False)[1])
    with pytest.raises(nlos_rs.SceneError, match="sampler"):
        nlos_rs.render(d, sampler="sobol", progress=False)


def test_jitter_false_is_accepted_with_a_warning():
    d = z("stratified", spp=16)
    d["relay_wall"]["nlos_sensor"]["sampler"]["jitter"] = False
    with pytest.warns(UserWarning, match="jitter"):
        nlos_rs.load_dict(d)

"""Golden outputs: fixed seeds must give bit-identical arrays across refactors.

Each case renders a small scene (single, confocal, exhaustive, HGRS with both estimators, both
temporal kernels, rgb, two corners, line of sight) and compares the SHA-256 of its steady and
transient arrays with the digest recorded in ``golden_digests.json``. A change that is meant to
alter results (new physics, a new random stream) re-records them explicitly:
``NLOS_RS_GOLDEN_UPDATE=1 python -m pytest tests/python/test_golden.py`` — never as a side effect.
"""

import hashlib
import json
import os
from pathlib import Path

import numpy as np
import pytest

import nlos_rs
from nlos_rs import scenes

DIGESTS = Path(__file__).with_name("golden_digests.json")


def _z(**kw):
    return scenes.z_nlos_1corner(width=6, height=5, spp=96, temporal_bins=120, bin_width_opl=0.02, **kw)


CASES = {
    "single": lambda: (_z(), {}),
    # One path per scan point (nlos_sample_reuse=False), mitransient's estimator: single captures
    # share light subpaths by default.
    "single_per_point": lambda: (_z(nlos_sample_reuse=False), {}),
    "kde_gaussian_per_point": lambda: (_z(nlos_sample_reuse=False), {"kernel_sigma": 1.5}),
    "rgb_per_point": lambda: (_z(nlos_sample_reuse=False), {"variant": "rgb"}),
    "hgrs_resampled_per_point": lambda: (_z(nlos_sample_reuse=False), {"integrator": "transient_nlos_path_rs"}),
    "two_corners_per_point": lambda: (scenes.t_nlos_2corner("small", width=4, height=4, spp=128, temporal_bins=200,
                                                            bin_width_opl=0.04, nlos_sample_reuse=False), {}),
    "confocal_per_point": lambda: (_z(capture_type="confocal", nlos_sample_reuse=False), {}),
    "exhaustive_per_point": lambda: (scenes.z_nlos_1corner(width=3, height=3, spp=64, temporal_bins=80,
                                                           bin_width_opl=0.03, capture_type="exhaustive",
                                                           nlos_sample_reuse=False), {}),
    "kde_epanechnikov_per_point": lambda: (_z(capture_type="confocal", nlos_sample_reuse=False),
                                           {"kernel_bandwidth": 2.5}),
    "single_sobol": lambda: (_z(), {"sampler": "stratified"}),
    # Shared subpaths with a uniform first hidden vertex (nlos_visibility_guiding=False): the
    # digests "single", "confocal" and "two_corners" had before the guide existed.
    "single_unguided": lambda: (_z(nlos_visibility_guiding=False), {}),
    "confocal_unguided": lambda: (_z(capture_type="confocal", nlos_visibility_guiding=False), {}),
    "two_corners_unguided": lambda: (scenes.t_nlos_2corner("small", width=4, height=4, spp=128, temporal_bins=200,
                                                           bin_width_opl=0.04, nlos_visibility_guiding=False), {}),
    "confocal": lambda: (_z(capture_type="confocal"), {}),
    "exhaustive": lambda: (scenes.z_nlos_1corner(width=3, height=3, spp=64, temporal_bins=80, bin_width_opl=0.03,
                                                 capture_type="exhaustive"), {}),
    "nee_bsdf": lambda: (_z(nlos_laser_sampling=False, nlos_hidden_geometry_sampling=False, laser_fov=20.0), {}),
    "hgs_rroulette_depth": lambda: (_z(nlos_hidden_geometry_sampling_do_rroulette=True, max_depth=5, rr_depth=2,
                                       account_first_and_last_bounces=True), {}),
    "hgrs_resampled": lambda: (_z(), {"integrator": "transient_nlos_path_rs"}),
    "hgrs_rejection": lambda: (_z(), {"integrator": "transient_nlos_path_rs", "hgrs_estimator": "rejection",
                                      "hgrs_max_iterations": 4}),
    "kde_gaussian": lambda: (_z(), {"kernel_sigma": 1.5}),
    "kde_epanechnikov": lambda: (_z(capture_type="confocal"), {"kernel_bandwidth": 2.5}),
    "rgb": lambda: (_z(), {"variant": "rgb"}),
    "two_corners": lambda: (scenes.t_nlos_2corner("small", width=4, height=4, spp=128, temporal_bins=200,
                                                  bin_width_opl=0.04), {}),
    "los_cornell": lambda: (scenes.cornell_box(width=8, height=6, spp=32, temporal_bins=100), {"variant": "rgb"}),
    # 64 pixels or more: each pixel's samples in one task, two camera paths in flight per thread.
    "los_cornell_film": lambda: (scenes.cornell_box(width=10, height=8, spp=48, temporal_bins=100), {}),
    "los_cornell_adaptive": lambda: (scenes.cornell_box(width=9, height=8, spp=2048, temporal_bins=50),
                                     {"target_rel_error": 0.05}),
    "los_cornell_unwarp_kde": lambda: (
        {**scenes.cornell_box(width=6, height=6, spp=32, temporal_bins=100),
         "integrator": {"type": "transient_path", "max_depth": 5, "camera_unwarp": True}},
        {"kernel_sigma": 1.0}),
}


def digest(name):
    scene, kw = CASES[name]()
    steady, transient = nlos_rs.render(scene, seed=3, threads=2, progress=False, **kw)
    h = hashlib.sha256()
    for a in (steady, transient):
        h.update(str(a.shape).encode())
        h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()


@pytest.mark.parametrize("name", sorted(CASES))
def test_golden(name):
    if os.environ.get("NLOS_RS_GOLDEN_UPDATE"):
        recorded = json.loads(DIGESTS.read_text()) if DIGESTS.exists() else {}
        recorded[name] = digest(name)
        DIGESTS.write_text(json.dumps(dict(sorted(recorded.items())), indent=1) + "\n")
        return
    recorded = json.loads(DIGESTS.read_text())
    assert digest(name) == recorded[name], f"{name}: output changed for a fixed seed"

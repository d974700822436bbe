"""Hidden-geometry sampling behind two-sided surfaces.

A `twosided` diffuse patch turns its back (the side its normal does not point to) to the relay wall.
mitransient's hidden-geometry sampling (HGS) keeps a one-sided facing test for every BSDF and
renders such a patch black; nlos_rs accepts both sides where the BSDF scatters on both. BSDF
sampling, which has no facing test, is the independent reference.
"""

import numpy as np

import nlos_rs
from stats import assert_same_capture

REPS = 32


def scene(spp: int, **integrator) -> dict:
    def patch(c, half, bsdf, tilt):
        return {"type": "rectangle", "bsdf": bsdf,
                "to_world": nlos_rs.Transform4f().translate(c).rotate([0, 1, 0], tilt).scale(half)}

    diffuse = {"type": "diffuse", "reflectance": 0.8}
    return nlos_rs.scenes.nlos_scene(
        {
            # Its normal points away from the wall (+z): only its back is seen.
            "two_sided_back": patch([-0.15, 0.0, 0.7], 0.25, {"type": "twosided", "bsdf": diffuse}, 30),
            # Facing the wall, behind it: light bounces between the two.
            "one_sided_front": patch([0.1, 0.05, 1.1], 0.4, diffuse, 180),
        },
        width=4, height=4, spp=spp, temporal_bins=400, bin_width_opl=0.01, start_opl=0.5, capture_type="single",
        max_depth=5, **integrator)


def ours(spp, **kw):
    # The reference (BSDF sampling) draws from seeds of its own.
    first = 0 if kw["nlos_hidden_geometry_sampling"] else 1000
    return np.array([nlos_rs.render(scene(spp, **kw), seed=first + k, progress=False)[1][..., 0]
                     for k in range(REPS)])


def test_back_of_a_two_sided_surface_is_lit():
    # The direct term (one hidden vertex) comes from the two-sided patch's back and the one-sided
    # patch's front.
    kw = dict(filter_bounces=2)
    assert_same_capture(ours(4096, nlos_hidden_geometry_sampling=True, **kw),
                        ours(65536, nlos_hidden_geometry_sampling=False, **kw), "direct: HGS / BSDF")


def test_interreflections_behind_two_sided_surfaces():
    # Every order, the relay wall among the sampled geometry (by default HGS leaves out light that
    # bounces off the wall between hidden vertices, by design), with and without sample reuse.
    kw = dict(nlos_hidden_geometry_sampling_includes_relay_wall=True)
    bsdf = ours(65536, nlos_hidden_geometry_sampling=False, **kw)
    assert_same_capture(ours(4096, nlos_hidden_geometry_sampling=True, **kw), bsdf,
                        "all orders, sample reuse: HGS / BSDF")
    assert_same_capture(ours(4096, nlos_hidden_geometry_sampling=True, nlos_sample_reuse=False, **kw), bsdf,
                        "all orders, one path per scan point: HGS / BSDF")

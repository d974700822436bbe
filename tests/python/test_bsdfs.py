"""BSDFs beyond `diffuse`, against Mitsuba and mitransient (replicate statistics, stats.py):

* steady images against Mitsuba's own `path` integrator on mi.cornell_box() with the two blocks'
  BSDF replaced (box pixel filter, so pixel integrals match);
* transients against mitransient's transient_path on the same scene;
* NLOS captures against mitransient's transient_nlos_path with the hidden Z's BSDF replaced (laser
  and hidden-geometry sampling connect through glossy BSDFs; delta BSDFs are covered by the
  line-of-sight scenes, where mitransient is right about them).

χ² tests of each BSDF's sampling against its pdf are in tests/bsdf.rs."""

import numpy as np
import pytest

import nlos_rs
from nlos_rs.mitsuba_compat import render_mitransient
from stats import agreement, ratio_with_error, rebin

REPS = 8
# NLOS captures share light subpaths among scan points: one replicate moves every pixel together
# and glossy lobes give heavy tails, so Welch's t needs more than 8 replicates to hold its level
# (measured: 8 gave max |t| 6.7 on the GGX case, 16 gave 2.4 with mean t² 1.1).
NLOS_REPS = 16

BSDFS = {
    "conductor_au": {"type": "conductor", "material": "Au"},
    "conductor_none": {"type": "conductor"},
    "roughconductor_cu_beckmann": {"type": "roughconductor", "material": "Cu", "alpha": 0.3},
    "roughconductor_ggx_eta_k": {"type": "roughconductor", "distribution": "ggx", "alpha": 0.15,
                                 "eta": {"type": "rgb", "value": [0.2, 0.9, 1.1]},
                                 "k": {"type": "rgb", "value": [3.9, 2.4, 2.1]},
                                 "specular_reflectance": {"type": "rgb", "value": [0.9, 0.8, 0.7]}},
    "twosided_diffuse": {"type": "twosided", "bsdf": {"type": "diffuse", "reflectance": 0.7}},
    "dielectric_bk7": {"type": "dielectric"},
    "dielectric_water_tinted": {"type": "dielectric", "int_ior": "water", "ext_ior": 1.0,
                                "specular_transmittance": {"type": "rgb", "value": [0.9, 0.7, 0.5]}},
    "thindielectric": {"type": "thindielectric", "int_ior": 1.6},
    "plastic": {"type": "plastic", "diffuse_reflectance": {"type": "rgb", "value": [0.6, 0.3, 0.1]}},
    "plastic_nonlinear": {"type": "plastic", "nonlinear": True, "int_ior": "pet",
                          "diffuse_reflectance": {"type": "rgb", "value": [0.2, 0.5, 0.8]}},
    "roughplastic_ggx": {"type": "roughplastic", "distribution": "ggx", "alpha": 0.2,
                         "diffuse_reflectance": {"type": "rgb", "value": [0.6, 0.3, 0.1]}},
    "roughplastic_beckmann_nonlinear": {"type": "roughplastic", "alpha": 0.5, "nonlinear": True,
                                        "diffuse_reflectance": {"type": "rgb", "value": [0.2, 0.5, 0.8]}},
    "blendbsdf_diffuse_roughconductor": {"type": "blendbsdf", "weight": 0.3,
                                         "a": {"type": "diffuse", "reflectance": 0.8},
                                         "b": {"type": "roughconductor", "material": "Al", "alpha": 0.2}},
    "mask_diffuse": {"type": "mask", "opacity": 0.6, "bsdf": {"type": "diffuse", "reflectance": 0.7}},
}
# NLOS: (BSDF, hidden-geometry sampling). mitransient's hidden-geometry sampling evaluates only a
# BSDF's smooth part, so it drops the coating reflection of plastic: compare that with BSDF
# sampling, where mitransient is right (nlos_rs samples the BSDF at such vertices either way).
NLOS = [("roughconductor_cu_beckmann", True), ("roughconductor_ggx_eta_k", True), ("twosided_diffuse", True),
        ("plastic", False), ("roughplastic_ggx", True), ("blendbsdf_diffuse_roughconductor", True)]


def cornell(peer, bsdf, size=16):
    cb = peer.cornell_box()
    cb["sensor"]["film"].update(width=size, height=size, rfilter={"type": "box"})
    for block in ("small-box", "large-box"):
        cb[block]["bsdf"] = bsdf
    return cb


@pytest.mark.peer
@pytest.mark.parametrize("name", sorted(BSDFS))
def test_steady_matches_mitsuba_path(peer, name):
    mi = peer
    cb = cornell(mi, BSDFS[name])
    scene = mi.load_dict(nlos_rs.mitsuba_compat.to_mitsuba(cb))
    theirs = np.array([np.array(mi.render(scene, spp=256, seed=k))[..., 0] for k in range(REPS)])
    ours = np.array([nlos_rs.render(nlos_rs.scenes.to_transient(cb), spp=256, seed=k, progress=False)[0][..., 0]
                     for k in range(REPS)])
    res = agreement(rebin(rebin(ours, 2, 1), 2, 2).reshape(REPS, -1), rebin(rebin(theirs, 2, 1), 2, 2).reshape(REPS, -1))
    r, se = ratio_with_error(ours.sum((1, 2)), theirs.sum((1, 2)))
    print(f"\n{name}: steady vs Mitsuba path {r:.4f} ± {se:.4f}; {res}")
    assert res["agree"] and abs(r - 1) < 4 * se + 1e-3


@pytest.mark.peer
@pytest.mark.parametrize("name", sorted(BSDFS))
def test_transient_matches_mitransient(peer, name):
    d = nlos_rs.scenes.to_transient(cornell(peer, BSDFS[name], size=8))
    ours = np.array([nlos_rs.render(d, spp=1024, seed=k, progress=False)[1][..., 0] for k in range(REPS)])
    theirs = np.array([render_mitransient(d, spp=1024, seed=k)[1][..., 0] for k in range(REPS)])
    f = lambda t: np.concatenate([t.sum(-1).reshape(REPS, -1), rebin(t.sum((1, 2)), 16, -1)], axis=1)  # noqa: E731
    res = agreement(f(ours), f(theirs))
    r, se = ratio_with_error(ours.sum((1, 2, 3)), theirs.sum((1, 2, 3)))
    print(f"\n{name}: transient vs mitransient {r:.4f} ± {se:.4f}; {res}")
    assert res["agree"] and abs(r - 1) < 4 * se + 1e-3


@pytest.mark.peer
@pytest.mark.parametrize("name, hgs", NLOS)
def test_nlos_hidden_object_matches_mitransient(peer, name, hgs):
    d = nlos_rs.scenes.z_nlos_1corner(width=4, height=4, spp=2048 if hgs else 8192,
                                       nlos_hidden_geometry_sampling=hgs,
                                       nlos_hidden_geometry_sampling_includes_relay_wall=not hgs)
    d["z"]["bsdf"] = BSDFS[name]
    spp = d["relay_wall"]["nlos_sensor"]["sampler"]["sample_count"]
    ours = np.array([nlos_rs.render(d, seed=k, progress=False)[1][..., 0] for k in range(NLOS_REPS)])
    theirs = np.array([render_mitransient(d, spp=spp, seed=k)[1][..., 0] for k in range(NLOS_REPS)])
    f = lambda t: np.concatenate([t.sum(-1).reshape(NLOS_REPS, -1), rebin(t.sum((1, 2)), 10, -1)], axis=1)  # noqa: E731
    res = agreement(f(ours), f(theirs))
    r, se = ratio_with_error(ours.sum((1, 2, 3)), theirs.sum((1, 2, 3)))
    print(f"\n{name}: NLOS vs mitransient {r:.4f} ± {se:.4f}; {res}")
    assert theirs.sum() > 0 and res["agree"] and abs(r - 1) < 4 * se + 1e-3


def test_named_materials_and_bad_conductors():
    d = nlos_rs.scenes.z_nlos_1corner(width=2, height=2, spp=16)
    for bad, key in [({"type": "conductor", "material": "Unobtainium"}, "material"),
                     ({"type": "conductor", "material": "Au", "eta": 1.0}, "material"),
                     ({"type": "roughconductor", "distribution": "phong"}, "distribution"),
                     ({"type": "roughconductor", "alpha_u": 0.1, "alpha_v": 0.2}, "alpha_u"),
                     ({"type": "roughconductor", "alpha": -1.0}, "alpha"),
                     ({"type": "twosided"}, "bsdf")]:
        d["z"]["bsdf"] = bad
        with pytest.raises(nlos_rs.SceneError, match=key):
            nlos_rs.load_dict(d)


@pytest.mark.parametrize("name", ["dielectric_bk7", "conductor_au", "thindielectric"])
def test_delta_hidden_geometry_alone_adds_nothing(name):
    """Under hidden-geometry sampling every vertex after a path's first lies on hidden geometry, and
    a delta BSDF connects to nothing: where every hidden surface is a delta (the Z in glass, a
    mirror), no path adds anything past its first vertex, which on the flat relay wall connects
    to nothing either, and each path ends there (the capture is zero, as mitransient's is). A
    diffuse floor beside the Z is connected to, through the Z or not."""
    d = nlos_rs.scenes.z_nlos_1corner(width=4, height=4, spp=256)
    d["z"]["bsdf"] = BSDFS[name]
    steady, transient = nlos_rs.render(d, progress=False)
    assert not steady.any() and not transient.any()
    d["floor"] = {"type": "rectangle", "bsdf": {"type": "diffuse"},
                  "to_world": nlos_rs.Transform4f().translate([0.0, -0.5, 1.0]).rotate([1, 0, 0], -90).scale(0.5)}
    assert nlos_rs.render(d, progress=False)[1].sum() > 0

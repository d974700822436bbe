"""Line-of-sight transient rendering: transient_path, perspective camera, area and point lights."""

import numpy as np
import pytest

import nlos_rs
from nlos_rs.mitsuba_compat import render_mitransient
from stats import agreement, ratio_with_error, rebin

REPS = 8


def features(steady, transient):
    """Per-pixel steady values and the pixel-summed time profile in 8-bin groups."""
    return np.concatenate([steady.reshape(len(steady), -1), rebin(transient.sum((1, 2)), 8, -1)], axis=1)


def matches_mitransient(d, what):
    """Renders of the scene dict `d` (512 spp, REPS seeds) agree with mitransient's transient_path
    per feature and in their steady totals."""
    ours = [nlos_rs.render(d, seed=k, progress=False) for k in range(REPS)]
    theirs = [render_mitransient(d, spp=512, seed=k)[:2] for k in range(REPS)]
    fo = features(np.array([s[..., 0] for s, _ in ours]), np.array([t[..., 0] for _, t in ours]))
    ft = features(np.array([s[..., 0] for s, _ in theirs]), np.array([t[..., 0] for _, t in theirs]))
    res = agreement(fo, ft)
    r, se = ratio_with_error(np.array([s.sum() for s, _ in ours]), np.array([s.sum() for s, _ in theirs]))
    print(f"\n{what} vs mitransient transient_path: steady ratio {r:.4f} ± {se:.4f}; {res}")
    assert res["agree"] and abs(r - 1) < 4 * se


@pytest.mark.peer
def test_cornell_box_matches_mitransient(peer):
    matches_mitransient(nlos_rs.scenes.cornell_box(width=16, height=16, spp=512), "Cornell box")


@pytest.mark.peer
def test_cornell_box_with_a_sphere_and_a_gold_box_matches_mitransient(peer):
    """The lockstep lanes' tree part (an analytic sphere on the small box) and their mirrors (the
    large box a smooth gold conductor) against mitransient's transient_path."""
    d = nlos_rs.scenes.cornell_box(width=16, height=16, spp=512)
    d["ball"] = {"type": "sphere", "center": [0.335, -0.15, 0.38], "radius": 0.25, "bsdf": {"type": "ref", "id": "white"}}
    d["large-box"]["bsdf"] = {"type": "conductor", "material": "Au"}
    matches_mitransient(d, "Cornell box, sphere and gold box")


@pytest.mark.peer
def test_steady_image_matches_mitsuba_path_on_mi_cornell_box(peer):
    """Mitsuba's own mi.cornell_box() with its steady `path` integrator (box pixel filter, so the
    pixel integrals match) against nlos_rs on to_transient(mi.cornell_box())."""
    mi = peer
    cb = mi.cornell_box()
    cb["sensor"]["film"].update(width=16, height=16, rfilter={"type": "box"})
    scene = mi.load_dict(cb)
    theirs = np.array([np.array(mi.render(scene, spp=512, seed=k))[..., 0] for k in range(REPS)])
    d = nlos_rs.scenes.to_transient(cb)
    ours = np.array([nlos_rs.render(d, spp=512, seed=k, progress=False)[0][..., 0] for k in range(REPS)])
    res = agreement(ours.reshape(REPS, -1), theirs.reshape(REPS, -1))
    r, se = ratio_with_error(ours.sum((1, 2)), theirs.sum((1, 2)))
    print(f"\nsteady vs Mitsuba path: ratio {r:.4f} ± {se:.4f}; {res}")
    assert res["agree"] and abs(r - 1) < 4 * se


def point_light_scene(unwarp=False, max_depth=2):
    """A 1-pixel camera with a 0.2° field of view looking at a diffuse plane lit by a point light."""
    T = nlos_rs.Transform4f
    return {
        "type": "scene",
        "integrator": {"type": "transient_path", "max_depth": max_depth, "camera_unwarp": unwarp},
        "plane": {"type": "rectangle", "to_world": T().scale(5.0), "bsdf": {"type": "diffuse", "reflectance": 0.6}},
        "lamp": {"type": "point", "position": [1.0, 0.5, 2.0], "intensity": 3.0},
        "camera": {"type": "perspective", "fov": 0.2, "to_world": T().look_at([0.0, -1.0, 3.0], [0.0, 0.0, 0.0], [0, 1, 0]),
                   "sampler": {"type": "independent", "sample_count": 256},
                   "film": {"type": "transient_hdr_film", "width": 1, "height": 1, "temporal_bins": 2000,
                            "bin_width_opl": 0.002, "start_opl": 2.0, "rfilter": {"type": "box"}}},
    }


def test_point_light_on_a_plane_is_analytic():
    p, cam, lamp = np.zeros(3), np.array([0.0, -1.0, 3.0]), np.array([1.0, 0.5, 2.0])
    r = np.linalg.norm(lamp - p)
    radiance = 0.6 / np.pi * 3.0 * (lamp[2] / r) / r**2  # rho/pi * I cos / r^2
    steady, transient = nlos_rs.render(point_light_scene(), progress=False)
    assert steady[0, 0, 0] == pytest.approx(radiance, rel=2e-3)
    opl = np.linalg.norm(cam - p) + r
    assert abs(np.argmax(transient[0, 0, :, 0]) - (opl - 2.0) / 0.002) <= 1.5
    _, unwarped = nlos_rs.render(point_light_scene(unwarp=True), progress=False)
    assert abs(np.argmax(unwarped[0, 0, :, 0]) - (r - 2.0) / 0.002) <= 1.5


@pytest.mark.parametrize("kw", [{"kernel_sigma": 3.0}, {"kernel_bandwidth": 3.0}])
def test_kde_keeps_energy_on_los_renders(kw):
    d = nlos_rs.scenes.cornell_box(width=8, height=8, spp=64, temporal_bins=1500, start_opl=3.0, max_depth=4)
    box = nlos_rs.render(d, seed=3, progress=False, variant="rgb")[1]
    kde = nlos_rs.render(d, seed=3, progress=False, variant="rgb", **kw)[1]
    np.testing.assert_allclose(kde.sum(2), box.sum(2), rtol=1e-5, atol=1e-9)
    assert np.abs(kde - box).max() > 0


def test_rgb_is_three_channels_and_mono_is_luminance():
    d = nlos_rs.scenes.cornell_box(width=8, height=8, spp=16)
    s3 = nlos_rs.render(d, variant="rgb", progress=False)[0]
    assert s3.shape == (8, 8, 3) and (s3[..., 0].mean() > s3[..., 2].mean())  # warm light


@pytest.mark.parametrize(
    "edit, words",
    [
        (lambda d: d.pop("sensor"), ["perspective"]),
        (lambda d: d["sensor"].pop("fov"), ["perspective", "fov"]),
        (lambda d: d["sensor"].update(focal_length="50mm"), ["focal_length"]),
        (lambda d: d["sensor"].update(fov_axis="z"), ["fov_axis"]),
        (lambda d: d["sensor"].update(near_clip=0.0), ["near_clip"]),
        (lambda d: d["light"].pop("emitter"), ["area or point lights"]),
        (lambda d: d["light"]["emitter"].update(power=1.0), ["area", "power"]),
        (lambda d: d["integrator"].update(max_dpeth=3), ["transient_path", "max_dpeth"]),
        (lambda d: d.update(laser={"type": "projector", "fov": 1.0}), ["projector"]),
        (lambda d: d.update(env={"type": "constant"}), ["constant"]),
        (lambda d: d["sensor"]["film"].update(exhaustive_scan=True, laser_scan_width=2, laser_scan_height=2), ["exhaustive"]),
        (lambda d: d.update(integrator2={"type": "transient_nlos_path"}), ["exactly one integrator"]),
    ],
)
def test_bad_los_scenes(edit, words):
    d = nlos_rs.scenes.cornell_box(width=4, height=4, spp=4)
    edit(d)
    with pytest.raises(nlos_rs.SceneError) as e:
        nlos_rs.load_dict(d)
    for w in words:
        assert w in str(e.value), (w, str(e.value))


def test_nlos_only_helpers_say_so():
    scene = nlos_rs.load_dict(nlos_rs.scenes.cornell_box(width=4, height=4, spp=4))
    assert scene.integrator == "transient_path" and scene.capture_type == "camera"
    with pytest.raises(nlos_rs.SceneError, match="line-of-sight"):
        nlos_rs.nlos.focus_emitter_at_relay_wall_uv((0.5, 0.5), scene)

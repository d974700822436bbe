"""Sample reuse across scan points (``nlos_sample_reuse``, on by default): a light subpath through
the hidden geometry is connected to every scan point (and, for confocal and exhaustive captures,
linked to every laser spot). It must be unbiased (agree with
one path per scan point, the estimator mitransient uses, across independent replicates), stay
bit-identical whatever the threads or the split into parts, and fall back where it does not apply."""

import copy
import os
import tempfile

import numpy as np
import pytest

import nlos_rs
from nlos_rs import _core, scenes
from nlos_rs.transform import Transform4f
from stats import agreement, rebin

REPS = 10


def z(**kw):
    kw.setdefault("width", 6)
    kw.setdefault("height", 6)
    return scenes.z_nlos_1corner(**kw)


def glossy_wall_one_sided_box(**kw):
    """A rough-conductor relay wall (the spot's radiance depends on direction), a one-sided
    diffuse box behind it with two-sided faces inside, depth capped at 6."""
    d = glossy_wall(z(max_depth=6, **kw))
    d["box"] = {"type": "cube", "to_world": Transform4f().translate([0.3, 0.0, 1.3]).scale(0.25),
                "bsdf": {"type": "twosided", "bsdf": {"type": "diffuse", "reflectance": 0.7}}}
    return d


def glossy_box(d):
    """The same scene with a two-sided rough-conductor box."""
    d["box"]["bsdf"] = {"type": "twosided", "bsdf": {"type": "roughconductor", "alpha": 0.5}}
    return d


def glossy_hidden_z(**kw):
    """A rough-conductor hidden Z (its BSDF at the first hidden vertex depends on which spot lights
    it), depth capped at 5."""
    d = z(max_depth=5, **kw)
    d["z"]["bsdf"] = {"type": "roughconductor", "alpha": 0.4}
    return d


def glossy_wall(d):
    """The same scene with a rough-conductor relay wall (each spot's radiance depends on direction)."""
    d["relay_wall"]["bsdf"] = {"type": "roughconductor", "alpha": 0.3}
    return d


def plastic_sheet(**kw):
    """A smooth-plastic square (a delta coating) facing the relay wall with a larger diffuse one
    behind it: nothing hidden lies before the plastic, so no path goes on from it and the render
    shares light subpaths despite the delta BSDF (its connections take the diffuse part)."""
    d = z(**kw)
    d["z"] = {"type": "rectangle", "to_world": Transform4f().translate([0.1, 0.0, 0.9]).rotate([1, 0, 0], 180).scale(0.3),
              "bsdf": {"type": "plastic"}}
    d["back"] = {"type": "rectangle", "to_world": Transform4f().translate([-0.2, 0.1, 1.4]).rotate([1, 0, 0], 180).scale(0.5),
                 "bsdf": {"type": "diffuse"}}
    return d


def glass_cube(**kw):
    """A glass cube between two diffuse panels that face the relay wall and each other, cutting
    into the cube: light reaches the scan points through the glass (paths whose vertex after the
    scan point is on the glass, traced from each pixel) and from one panel to the other through it
    (light subpaths that refract), and some paths connect two points inside the glass."""
    d = z(**kw)
    d["z"] = {"type": "cube", "to_world": Transform4f().translate([0.0, 0.0, 1.0]).scale(0.2),
              "bsdf": {"type": "dielectric"}}
    for name, x, angle in (("left", -0.45, 135), ("right", 0.45, -135)):
        d[name] = {"type": "rectangle", "to_world": Transform4f().translate([x, 0.0, 1.0]).rotate([0, 1, 0], angle).scale(0.35),
                   "bsdf": {"type": "diffuse", "reflectance": 0.8}}
    return d


def panels_in_glass(**kw):
    """The glass cube larger, with two two-sided diffuse panels inside it facing each other: paths
    from a pixel refract into the glass and connect, inside it, to light subpaths that did."""
    d = glass_cube(**kw)
    d["z"]["to_world"] = Transform4f().translate([0.0, 0.0, 1.0]).scale(0.25)
    for name, x in (("in_a", -0.12), ("in_b", 0.12)):
        d[name] = {"type": "rectangle", "to_world": Transform4f().translate([x, 0.0, 1.0]).rotate([0, 1, 0], 90).scale(0.2),
                   "bsdf": {"type": "twosided", "bsdf": {"type": "diffuse", "reflectance": 0.8}}}
    return d


SIMPLE = os.path.join(os.path.dirname(__file__), "..", "data", "mitransient", "transient-nlos", "nlos-z-simple.xml")
ROOM = os.path.join(os.path.dirname(__file__), "..", "data", "mitransient", "transient-nlos", "nlos-z-room.xml")


def room_in_glass(nlos_sample_reuse):
    """mitransient's room (a camera, hidden-geometry sampling on) with its Z in smooth glass."""
    text = open(ROOM).read()
    z_mesh = '<string name="filename" value="meshes/hidden_geometry_Z.ply"/>'
    start = text.index(z_mesh)
    text = text[:start] + z_mesh + '<bsdf type="dielectric"/>' + text[text.index("</shape>", start):]
    text = text.replace('value="meshes/', f'value="{os.path.dirname(ROOM)}/meshes/')
    path = os.path.join(tempfile.mkdtemp(), "room_in_glass.xml")
    with open(path, "w") as f:
        f.write(text)
    return nlos_rs.load_file(path).with_sample_reuse(nlos_sample_reuse)

CASES = {
    "Z, unbounded depth": lambda **kw: z(spp=4096, **kw),
    # mitransient's own file: a perspective camera looks at the relay wall (a jittered first vertex).
    "mitransient nlos-z-simple.xml (camera)": lambda nlos_sample_reuse: nlos_rs.load_file(
        SIMPLE).with_sample_reuse(nlos_sample_reuse),
    "Z, rgb, first and last legs, no direct paths": lambda **kw: z(spp=4096, account_first_and_last_bounces=True,
                                                                  discard_direct_paths=True, **kw),
    "T small, five-vertex signal": lambda **kw: scenes.t_nlos_2corner("small", width=6, height=6, spp=8192,
                                                                      filter_bounces=4, **kw),
    "glossy relay wall, box, depth 6": lambda **kw: glossy_wall_one_sided_box(spp=4096, **kw),
    # Many spots: the subpath starts at its first hidden vertex, linked to each spot.
    "Z confocal, unbounded depth": lambda **kw: z(spp=4096, capture_type="confocal", **kw),
    "glossy hidden Z, confocal, depth 5": lambda **kw: glossy_hidden_z(spp=4096, capture_type="confocal", **kw),
    # Chains of several hidden vertices inside a glossy box: the first vertex's BSDF towards the
    # second depends on the spot.
    "glossy box inside, confocal, depth 6": lambda **kw: glossy_box(glossy_wall_one_sided_box(
        spp=4096, capture_type="confocal", **kw)),
    "Z exhaustive 3x3, unbounded depth": lambda **kw: z(width=3, height=3, spp=4096, capture_type="exhaustive", **kw),
    "glossy wall and hidden Z, exhaustive 3x3": lambda **kw: glossy_wall(glossy_hidden_z(
        width=3, height=3, spp=2048, capture_type="exhaustive", **kw)),
    # Glass among diffuse hidden surfaces: light subpaths refract through it, and the paths whose
    # vertex after the scan point lies on it are traced from each pixel.
    "glass cube between panels": lambda **kw: glass_cube(spp=4096, **kw),
    "glass cube between panels, confocal": lambda **kw: glass_cube(spp=4096, capture_type="confocal", **kw),
    "glass cube between panels, exhaustive 3x3": lambda **kw: glass_cube(width=3, height=3, spp=4096,
                                                                          capture_type="exhaustive", **kw),
    "mitransient nlos-z-room.xml, Z in glass (camera)": room_in_glass,
    "panels inside glass, confocal": lambda **kw: panels_in_glass(spp=4096, capture_type="confocal", **kw),
    "plastic sheet before a diffuse one": lambda **kw: plastic_sheet(spp=4096, **kw),
    "plastic sheet before a diffuse one, confocal": lambda **kw: plastic_sheet(spp=4096, capture_type="confocal", **kw),
    # HGRS (resampled) on the light subpath: N candidates per vertex, paid once for all points.
    "T small, five-vertex, HGRS": lambda **kw: scenes.t_nlos_2corner("small", width=6, height=6, spp=2048, filter_bounces=4,
                                                                     type="transient_nlos_path_rs", **kw),
}


def features(t):
    """Per replicate: each pixel's (and laser point's) total and the capture's time profile (bins
    in tens)."""
    if t.ndim == 6:  # exhaustive (rep, H, W, LH, LW, T): (scan point, laser point) pairs as pixels
        t = t.reshape(len(t), t.shape[1] * t.shape[2], t.shape[3] * t.shape[4], t.shape[5])
    return np.concatenate([t.sum(-1).reshape(len(t), -1), rebin(t.sum((1, 2)), 10, -1)], axis=1)


@pytest.mark.parametrize("case", list(CASES))
def test_reuse_agrees_with_one_path_per_scan_point(case):
    variant = "rgb" if "rgb" in case else "mono"
    # The five-vertex signal of one path per scan point is heavy-tailed (most renders of a pixel
    # are zero): ten replicates' spread understates its variance, forty do not.
    # Paths that refract into glass and connect inside it are rare and heavy-tailed too: thirty.
    reps = 4 * REPS if "five-vertex" in case else 3 * REPS if "inside glass" in case else REPS
    runs = {}
    for reuse, first_seed in ((False, 0), (True, 1000)):
        d = CASES[case](nlos_sample_reuse=reuse)
        spp = 256 if "room" in case else 1024 if "camera" in case else None
        runs[reuse] = np.array([nlos_rs.render(d, spp=spp, seed=first_seed + k, variant=variant, progress=False)[1].sum(-1)
                                for k in range(reps)])
    assert runs[True].sum() > 0 and runs[True].shape == runs[False].shape
    a, b = features(runs[True]), features(runs[False])
    # Quantities below 1e-9 of the largest are not compared: with a camera the two estimators'
    # late tails (~1e-14 of the signal, grazing paths along the relay plane) differ at float level.
    keep = np.maximum(a.mean(0), b.mean(0)) > 1e-9 * b.mean(0).max()
    res = agreement(a[:, keep], b[:, keep])
    print(f"\n{case}: {res}")
    assert res["agree"], res


@pytest.mark.parametrize("capture", ["confocal", "exhaustive", "camera", "glass"])
def test_many_spots_reuse_is_bit_identical_whatever_the_threads(capture):
    # A camera draws one jittered first vertex per pixel and tile of light samples (301 samples:
    # a last tile of one); hidden glass makes each pixel draw its delta prefixes from its stream.
    if capture == "camera":
        scene, spp = nlos_rs.load_file(SIMPLE), 301
    elif capture == "glass":
        scene, spp = nlos_rs.load_dict(glass_cube(width=5, height=3, spp=600)), None
    else:
        scene, spp = nlos_rs.load_dict(z(width=5, height=3, spp=600, capture_type=capture)), None
    ref = nlos_rs.render(scene, spp=spp, threads=1, progress=False, return_variance=True)
    for threads in (2, 3):
        out = nlos_rs.render(scene, spp=spp, threads=threads, progress=False, return_variance=True)
        assert all(np.array_equal(a, b) for a, b in zip(out, ref))


def test_reuse_is_bit_identical_whatever_the_threads_and_parts():
    scene = nlos_rs.load_dict(z(width=5, height=3, spp=3000))
    ref = nlos_rs.render(scene, threads=1, progress=False)
    for threads in (2, 3):
        out = nlos_rs.render(scene, threads=threads, progress=False)
        assert all(np.array_equal(a, b) for a, b in zip(out, ref))
    # Parts of any run of pixels, as workers render them, assemble to the same values.
    opts = {"mono": True, "spp": 3000}
    plan = _core.render_plan(scene, opts)
    k = plan["chunks"]
    parts = [((p0, p1), (c0, c1), *_core.render_part(scene, (p0, p1), (c0, c1), {**opts, "threads": 1}))
             for p0, p1 in ((0, 4), (4, 5), (5, 15)) for c0, c1 in ((0, 1), (1, k))]
    t, s = _core.assemble(scene, parts, opts)
    assert np.array_equal(t.reshape(ref[1].shape), ref[1]) and np.array_equal(s.reshape(ref[0].shape), ref[0])


def test_reuse_is_on_by_default_and_off_where_it_does_not_apply():
    def same(d, **kw):
        off = copy.deepcopy(d)
        off["integrator"]["nlos_sample_reuse"] = False
        return np.array_equal(nlos_rs.render(d, progress=False, **kw)[1], nlos_rs.render(off, progress=False, **kw)[1])

    assert not same(z(spp=256))  # single capture: shared
    assert not same(z(spp=256, max_depth=4))
    assert not same(z(spp=256, capture_type="confocal"))
    assert not same(z(width=2, height=2, spp=64, capture_type="exhaustive"))
    # HGRS judges a first vertex's candidates from its one spot: single captures only.
    assert not same(z(spp=256, type="transient_nlos_path_rs"))
    for d, kw in [(z(spp=256, capture_type="confocal", type="transient_nlos_path_rs"), {}),
                  (z(width=2, height=2, spp=64, capture_type="exhaustive", type="transient_nlos_path_rs"), {}),
                  (z(spp=256, nlos_hidden_geometry_sampling_do_rroulette=True), {}),
                  (z(spp=256), {"target_rel_error": 0.5})]:
        assert same(d, **kw), (d["integrator"], kw)
    # Hidden glass among diffuse surfaces is shared; hidden geometry all in glass or mirrors connects
    # nothing past the first vertex and is not.
    assert not same(glass_cube(spp=64))
    mirror = z(spp=256)
    mirror["z"]["bsdf"] = {"type": "conductor"}
    assert same(mirror)
    # More laser points than a block of subpaths can hold links for (4,096): one path per scan point.
    many = z(width=2, height=2, spp=8, temporal_bins=8, bin_width_opl=0.5, start_opl=1.0, capture_type="exhaustive")
    film = many["relay_wall"]["nlos_sensor"]["film"]
    film.update(laser_scan_width=72, laser_scan_height=64)
    many["integrator"]["force_equal_illumination_scanning"] = False
    assert same(many)
    film.update(laser_scan_width=64)
    assert not same(many)

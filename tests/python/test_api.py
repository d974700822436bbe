"""The Python surface: layout, variants, determinism, XML = dict, transforms, aiming, GIL and Ctrl-C."""

import _thread
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

import nlos_rs


def small(**kw):
    return nlos_rs.scenes.z_nlos_1corner(width=4, height=4, spp=64, **kw)


def test_import_does_not_import_mitsuba():
    code = "import sys, nlos_rs; nlos_rs.render(nlos_rs.scenes.z_nlos_1corner(width=2, height=2, spp=4)); print('mitsuba' in sys.modules)"
    assert subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip() == "False"


@pytest.mark.parametrize("variant, c", [("mono", 1), ("rgb", 3), ("llvm_ad_mono", 1), ("llvm_ad_rgb", 3)])
def test_layout(variant, c):
    steady, transient = nlos_rs.render(small(), variant=variant, progress=False)
    assert steady.dtype == np.float32 and transient.dtype == np.float32
    assert steady.shape == (4, 4, c) and transient.shape == (4, 4, 300, c)
    assert transient.sum() > 0


def test_rgb_channels_follow_reflectance_and_mono_is_luminance():
    d = small()
    d["z"]["bsdf"]["reflectance"] = {"type": "rgb", "value": [1.0, 0.5, 0.25]}
    _, rgb = nlos_rs.render(d, variant="rgb", progress=False)
    _, mono = nlos_rs.render(d, variant="mono", progress=False)
    tot = rgb.sum((0, 1, 2))
    # Three-vertex paths touch the Z once: channel ratios are the reflectance ratios.
    np.testing.assert_allclose(tot / tot[0], [1.0, 0.5, 0.25], rtol=1e-5)
    lum = 0.212671 * 1.0 + 0.715160 * 0.5 + 0.072169 * 0.25
    np.testing.assert_allclose(mono.sum() / tot[0], lum, rtol=1e-5)


def test_deterministic_whatever_the_thread_count():
    d = small()
    a = nlos_rs.render(d, seed=5, threads=1, progress=False)
    b = nlos_rs.render(d, seed=5, threads=2, progress=False)
    c = nlos_rs.render(d, seed=6, threads=2, progress=False)
    assert np.array_equal(a[1], b[1]) and np.array_equal(a[0], b[0])
    assert not np.array_equal(a[1], c[1])


def test_a_freed_film_used_again_changes_nothing():
    # A transient of 4.9 MB, kept by the core once its arrays are freed and written over by the
    # next render (src/film/memory.rs); a view into a freed render's array keeps its memory.
    scene = nlos_rs.load_dict(nlos_rs.scenes.z_nlos_1corner(width=64, height=64, spp=2))
    first = nlos_rs.render(scene, seed=5, threads=2, progress=False, return_variance=True)
    want = [a.copy() for a in first]
    view = first[1][10:20]
    for a in first:
        a[...] = 7.0  # the caller's arrays are theirs to write
    del first
    at = []
    for _ in range(3):
        again = nlos_rs.render(scene, seed=5, threads=2, progress=False, return_variance=True)
        assert again[1].shape == (64, 64, 300, 1)
        assert all(np.array_equal(a, b) for a, b in zip(again, want))
        at.append({a.__array_interface__["data"][0] for a in again[1:]})
        again[1][...] = np.nan
        del again
    assert np.all(view == 7.0)
    assert at[2] & at[1], "the last render's film was not used again"


@pytest.mark.parametrize("capture_type", ["single", "confocal"])
def test_runs_of_turned_down_samples_change_no_bits(capture_type):
    # With hidden-geometry sampling off most samples are turned down by their scan point's cone
    # at their first random numbers. Without variance the render loop passes over runs of them;
    # with it, each sample is finished alone (its values are kept). 600 samples: past a block of
    # 256, where a run stops. A hidden sphere (no triangles) keeps both renders in the scalar
    # tracer, which this is about (the Z would take the lockstep lanes without variance: other
    # numbers).
    d = nlos_rs.scenes.z_nlos_1corner(width=6, height=5, spp=600, capture_type=capture_type)
    d["integrator"]["nlos_hidden_geometry_sampling"] = False
    d["z"] = {"type": "sphere", "center": [0.0, 0.0, 1.0], "radius": 0.4, "bsdf": {"type": "roughplastic"}}
    scene = nlos_rs.load_dict(d)
    runs = nlos_rs.render(scene, seed=4, threads=2, progress=False)
    alone = nlos_rs.render(scene, seed=4, threads=1, progress=False, return_variance=True)
    assert np.array_equal(runs[1], alone[1]) and np.array_equal(runs[0], alone[0])
    assert runs[1].sum() > 0


def test_xml_route_equals_dict_route(tmp_path):
    d = small()
    xml = f"""<scene version="3.5.0">
  <default name="spp" value="64"/>
  <integrator type="transient_nlos_path">
    <boolean name="nlos_laser_sampling" value="true"/><boolean name="nlos_hidden_geometry_sampling" value="true"/>
    <boolean name="nlos_hidden_geometry_sampling_includes_relay_wall" value="false"/>
    <integer name="max_depth" value="-1"/><string name="capture_type" value="single"/>
  </integrator>
  <bsdf type="diffuse" id="white"><rgb name="reflectance" value="1, 1, 1"/></bsdf>
  <shape type="obj" id="z"><string name="filename" value="{d['z']['filename']}"/><ref id="white"/>
    <transform name="to_world"><translate z="1.0"/></transform></shape>
  <emitter type="projector" id="laser"><rgb name="irradiance" value="1, 1, 1"/><float name="fov" value="0.2"/>
    <transform name="to_world"><lookat origin="-0.5, 0, 0.25" target="0, 0, 0" up="0, 1, 0"/></transform></emitter>
  <shape type="rectangle" id="relay_wall"><ref id="white"/>
    <sensor type="nlos_capture_meter"><point name="sensor_origin" value="-0.5, 0, 0.25"/>
      <sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>
      <film type="transient_hdr_film"><integer name="width" value="4"/><integer name="height" value="4"/>
        <integer name="temporal_bins" value="300"/><float name="bin_width_opl" value="0.006"/>
        <float name="start_opl" value="1.85"/><rfilter type="box"/></film></sensor></shape>
</scene>"""
    path = tmp_path / "z.xml"
    path.write_text(xml)
    a = nlos_rs.render(d, progress=False)
    b = nlos_rs.render(nlos_rs.load_file(path, spp=64), progress=False)
    c = nlos_rs.render(str(path), spp=64, progress=False)  # an XML path in place of a Scene
    assert np.array_equal(a[1], b[1]) and np.array_equal(a[1], c[1])


def test_transforms_match_mitsuba(peer):
    mi = peer
    T, M = nlos_rs.Transform4f, mi.ScalarTransform4f
    axis = (np.array([0.3, 1, 0.2]) / np.linalg.norm([0.3, 1, 0.2])).tolist()  # Mitsuba does not normalise it
    pairs = [
        (T().translate([1, 2, 3]), M().translate([1, 2, 3])),
        (T().rotate(axis, 37), M().rotate(axis, 37)),
        (T().scale([1, 2, 3]), M().scale([1, 2, 3])),
        (T().look_at([-0.5, 0, 0.25], [0, 0, 0], [0, 1, 0]), M().look_at([-0.5, 0, 0.25], [0, 0, 0], [0, 1, 0])),
        (T().translate([0, 0, 1]).rotate([1, 0, 0], 90).scale(0.5), M().translate([0, 0, 1]).rotate([1, 0, 0], 90).scale(0.5)),
    ]
    for ours, theirs in pairs:
        np.testing.assert_allclose(ours.matrix, np.array(theirs.matrix), atol=1e-6)
    # Mitsuba transform objects are accepted in scene dicts.
    d = small()
    d["z"]["to_world"] = M().translate([0, 0, 1])
    assert np.array_equal(nlos_rs.render(d, progress=False)[1], nlos_rs.render(small(), progress=False)[1])


def test_focus_functions():
    scene = nlos_rs.load_dict(small())
    nlos_rs.nlos.focus_emitter_at_relay_wall_pixel((4, 2), scene)  # uv (1, 0.5): the wall's +x edge
    m = np.array(scene.laser_to_world)
    axis = m[:3, 2]
    target = np.array([1.0, 0.0, 0.0]) - np.array([-0.5, 0, 0.25])
    np.testing.assert_allclose(axis, target / np.linalg.norm(target), atol=1e-6)
    nlos_rs.nlos.focus_emitter_at_relay_wall_3dpoint((0.2, 0.1, 0.0), scene, scene)
    nlos_rs.nlos.focus_emitter_at_relay_wall_uv((0.5, 0.5), scene)
    np.testing.assert_allclose(np.array(scene.laser_to_world)[:3, 3], [-0.5, 0, 0.25], atol=1e-6)
    with pytest.raises(TypeError):
        nlos_rs.nlos.focus_emitter_at_relay_wall_uv((0.5, 0.5), "wall", "laser")


def long_render():
    return nlos_rs.scenes.z_nlos_1corner(width=32, height=32, spp=1 << 20)


def test_ctrl_c_stops_within_a_second(python_handles_sigint):
    timer = threading.Timer(0.5, _thread.interrupt_main)
    t0 = time.monotonic()
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        nlos_rs.render(long_render(), progress=False)
    assert time.monotonic() - t0 < 1.5


def test_gil_is_released():
    ticks = []
    stop = threading.Event()

    def count():
        while not stop.is_set():
            ticks.append(1)
            time.sleep(0.001)

    th = threading.Thread(target=count)
    th.start()
    try:
        nlos_rs.render(nlos_rs.scenes.z_nlos_1corner(width=32, height=32, spp=1 << 14), progress=False)
    finally:
        stop.set()
        th.join()
    assert len(ticks) > 20


def test_progress_bar(capsys, monkeypatch):
    # The bar appears once a render has run for a second: a clock that runs ten seconds a reading
    # makes that so whatever the machine's speed (a render timed to last a second stopped
    # showing one when renders got faster).
    clock = iter(range(0, 1 << 30, 10))
    monkeypatch.setattr(nlos_rs.time, "monotonic", lambda: float(next(clock)))
    nlos_rs.render(nlos_rs.scenes.z_nlos_1corner(width=32, height=32, spp=1 << 14), progress=True)
    assert "nlos_rs" in capsys.readouterr().err


def test_sensor_flag_is_deprecated_and_ignored_like_mitransient():
    d = small()
    d["relay_wall"]["nlos_sensor"]["account_first_and_last_bounces"] = True
    with pytest.warns(UserWarning, match="deprecated and ignored"):
        scene = nlos_rs.load_dict(d)
    assert np.array_equal(nlos_rs.render(scene, progress=False)[1], nlos_rs.render(small(), progress=False)[1])


def test_shutter_time_does_not_leak_into_the_optical_path():
    """mitransient starts the optical path at shutter_open (seconds added to metres, docs/mitransient-model.md
    §5 item 5); a sensor's shutter has nothing to do with the optical path length."""
    d = small()
    d["relay_wall"]["nlos_sensor"]["shutter_open"] = 0.5
    assert np.array_equal(nlos_rs.render(d, progress=False)[1], nlos_rs.render(small(), progress=False)[1])


@pytest.mark.parametrize("w", [25, 29, 49, 64])
def test_scan_points_are_pixel_centres_for_any_grid_width(w):
    """mitransient snaps x/W with float32 floor((x/W)·W) + 0.5, which for W = 25 sends columns
    5, 10, 15, 20, 23 to the previous pixel's point (docs/mitransient-model.md §5 item 4); these points are also the
    confocal laser targets."""
    scene = nlos_rs.load_dict(nlos_rs.scenes.z_nlos_1corner(width=w, height=3, spp=1))
    pts = np.array(scene.scan_points())
    xs = 2 * (np.arange(w) + 0.5) / w - 1
    ys = 2 * (np.arange(3) + 0.5) / 3 - 1
    np.testing.assert_allclose(pts[..., 0], np.broadcast_to(xs, (3, w)), atol=2e-6)
    np.testing.assert_allclose(pts[..., 1], np.broadcast_to(ys[:, None], (3, w)), atol=2e-6)
    np.testing.assert_allclose(pts[..., 2], 0, atol=1e-6)


def test_ply_and_relative_paths(tmp_path):
    """A PLY copy of the Z renders exactly like the OBJ, and XML mesh paths resolve against the
    XML file's folder."""
    from nlos_rs.scenes import z_letter

    verts, faces = z_letter()
    ply = ["ply", "format ascii 1.0", f"element vertex {len(verts)}", "property float x", "property float y",
           "property float z", f"element face {len(faces)}", "property list uchar int vertex_indices", "end_header"]
    ply += [f"{x!r} {y!r} {z!r}" for x, y, z in verts.astype(np.float32).tolist()] + [f"3 {a} {b} {c}" for a, b, c in faces]
    (tmp_path / "meshes").mkdir()
    (tmp_path / "meshes" / "z.ply").write_text("\n".join(ply) + "\n")
    d = small()
    ref = nlos_rs.render(d, progress=False)[1]
    d["z"].update(type="ply", filename=str(tmp_path / "meshes" / "z.ply"))
    assert np.array_equal(nlos_rs.render(d, progress=False)[1], ref)
    xml = f"""<scene version="3.5.0">
  <integrator type="transient_nlos_path"><boolean name="nlos_laser_sampling" value="true"/>
    <boolean name="nlos_hidden_geometry_sampling" value="true"/><integer name="max_depth" value="-1"/></integrator>
  <shape type="ply"><string name="filename" value="meshes/z.ply"/>
    <bsdf type="diffuse"><rgb name="reflectance" value="1"/></bsdf><transform name="to_world"><translate z="1"/></transform></shape>
  <emitter type="projector"><rgb name="irradiance" value="1"/><float name="fov" value="0.2"/>
    <transform name="to_world"><lookat origin="-0.5, 0, 0.25" target="0, 0, 0" up="0, 1, 0"/></transform></emitter>
  <shape type="rectangle"><bsdf type="diffuse"><rgb name="reflectance" value="1"/></bsdf>
    <sensor type="nlos_capture_meter"><point name="sensor_origin" x="-0.5" y="0" z="0.25"/>
      <sampler type="independent"><integer name="sample_count" value="64"/></sampler>
      <film type="transient_hdr_film"><integer name="width" value="4"/><integer name="height" value="4"/>
        <integer name="temporal_bins" value="300"/><float name="bin_width_opl" value="0.006"/>
        <float name="start_opl" value="1.85"/><rfilter type="box"/></film></sensor></shape>
</scene>"""
    (tmp_path / "scene.xml").write_text(xml)
    assert np.array_equal(nlos_rs.render(str(tmp_path / "scene.xml"), progress=False)[1], ref)


def test_hidden_geometry_sampling_without_hidden_geometry_names_its_key():
    # The relay wall alone: hidden-geometry sampling has nothing of area to draw from.
    scene = small()
    del scene["z"]
    with pytest.raises(nlos_rs.SceneError, match="nlos_hidden_geometry_sampling.*no hidden geometry"):
        nlos_rs.render(scene, progress=False)

"""Bad input is a clear Python exception naming the plugin and key: never a crash or a default."""

import copy

import numpy as np
import pytest

import nlos_rs
from nlos_rs import SceneError


@pytest.fixture
def z():
    return nlos_rs.scenes.z_nlos_1corner(width=4, height=4, spp=16)


def sensor(d):
    return d["relay_wall"]["nlos_sensor"]


@pytest.mark.parametrize(
    "edit, words",
    [
        (lambda d: d["integrator"].update(max_dpeth=3), ["transient_nlos_path", "max_dpeth", "unreferenced"]),
        (lambda d: d["integrator"].update(max_depth=2.5), ["transient_nlos_path", "max_depth", "integer"]),
        (lambda d: d["integrator"].update(max_depth=-2), ["max_depth"]),
        (lambda d: d["integrator"].update(rr_depth=0), ["rr_depth"]),
        (lambda d: d["integrator"].update(capture_type="spiral"), ["capture_type"]),
        (lambda d: d["integrator"].update(filter_bounces=2, filter_depth=3), ["filter_depth"]),
        (lambda d: d["integrator"].update(nlos_laser_sampling=False, capture_type="confocal"), ["capture_type"]),
        (lambda d: d["integrator"].update(temporal_filter="cubic"), ["temporal_filter"]),
        (lambda d: d["integrator"].update(camera_unwarp=True), ["camera_unwarp"]),
        (lambda d: sensor(d)["film"].update(width=0), ["transient_hdr_film", "width"]),
        (lambda d: sensor(d)["film"].update(bin_width_opl=-1.0), ["bin_width_opl"]),
        (lambda d: sensor(d)["film"].update(pixel_fromat="rgb"), ["transient_hdr_film", "pixel_fromat"]),
        (lambda d: sensor(d)["film"].pop("rfilter"), ["rfilter", "box"]),
        (lambda d: sensor(d)["film"].update(rfilter={"type": "gaussian"}), ["rfilter", "gaussian"]),
        (lambda d: sensor(d)["film"].update(exhaustive_scan=True, laser_scan_width=4, laser_scan_height=4), ["exhaustive"]),
        (lambda d: sensor(d).update(laser_origin=[0, 0, 1]), ["nlos_capture_meter", "laser_origin"]),
        (lambda d: sensor(d).update(sampler={"type": "stratified", "jiter": True}), ["stratified", "jiter"]),
        (lambda d: sensor(d).update(sampler={"type": "ldsampler", "sample_count": 0}), ["ldsampler", "sample_count"]),
        (lambda d: sensor(d)["sampler"].update(sample_count=0), ["independent", "sample_count"]),
        (lambda d: d["laser"].update(fov=0.0), ["projector", "fov"]),
        (lambda d: d["laser"].update(irradiance={"type": "rgb", "value": [1, 2]}), ["rgb", "value"]),
        (lambda d: d["laser"].update(to_world=[[1, 0], [0, 1]]), ["projector", "to_world"]),
        (lambda d: d["laser"].update(to_world=np.zeros((4, 4))), ["to_world", "invertible"]),
        (lambda d: d["z"].update(bsdf={"type": "roughdielectric"}), ["roughdielectric"]),
        (lambda d: d["z"].update(bsdf={"type": "ref", "id": "nope"}), ["nope"]),
        (lambda d: d["z"].update(filename=""), ["obj", "filename"]),
        (lambda d: d.update(extra={"type": "nlos_capture_meter"}), ["relay-wall"]),
        (lambda d: d.update(laser2=copy.deepcopy(d["laser"])), ["exactly one emitter"]),
        (lambda d: d.pop("laser"), ["exactly one emitter"]),
        (lambda d: d.pop("integrator"), ["integrator"]),
        (lambda d: d.update(integrator={"type": "path"}), ["path", "not supported"]),
        (lambda d: d.update(thing={"type": "teapot"}), ["teapot"]),
        (lambda d: d["relay_wall"].update(type="disk"), ["relay wall", "rectangle"]),
    ],
)
def test_bad_dict(z, edit, words):
    edit(z)
    with pytest.raises(SceneError) as e:
        nlos_rs.load_dict(z)
    for w in words:
        assert w in str(e.value), (w, str(e.value))


def test_scene_error_is_a_value_error():
    assert issubclass(SceneError, ValueError)


def test_missing_mesh(z, tmp_path):
    z["z"]["filename"] = str(tmp_path / "missing.obj")
    with pytest.raises(FileNotFoundError, match="missing.obj"):
        nlos_rs.load_dict(z)


@pytest.mark.parametrize(
    "name, text, words",
    [
        ("garbage.obj", "v 0 0 0\nv 1 0 0\nf 1 2 x\n", ["garbage.obj"]),
        ("outofrange.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n", ["outofrange.obj"]),
        ("empty.obj", "# nothing\n", ["no triangles"]),
        ("flat.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n", ["zero surface area"]),
        ("nan.obj", "v 0 0 nan\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", ["nan.obj"]),
        ("bad.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nend_header\n0\n1\n", ["bad.ply"]),
        ("noface.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n", ["face"]),
    ],
)
def test_broken_mesh(z, tmp_path, name, text, words):
    path = tmp_path / name
    path.write_text(text)
    z["z"].update(type="ply" if name.endswith(".ply") else "obj", filename=str(path))
    if name.endswith(".ply"):
        z["z"].pop("filename")
        z["z"]["filename"] = str(path)
    with pytest.raises(SceneError) as e:
        nlos_rs.load_dict(z)
    for w in words:
        assert w in str(e.value), (w, str(e.value))


XML_OK = """<scene version="3.5.0">
  <default name="spp" value="8"/>
  <integrator type="transient_nlos_path"><boolean name="nlos_laser_sampling" value="true"/></integrator>
  <emitter type="projector"><float name="fov" value="0.2"/>
    <transform name="to_world"><lookat origin="-0.5, 0, 0.25" target="0, 0, 0" up="0, 1, 0"/></transform></emitter>
  <shape type="rectangle"><transform name="to_world"><translate z="1"/><rotate x="1" angle="180"/></transform></shape>
  <shape type="rectangle" id="relay_wall">
    <sensor type="nlos_capture_meter"><point name="sensor_origin" x="-0.5" y="0" z="0.25"/>
      <sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>
      <film type="transient_hdr_film"><integer name="width" value="2"/><integer name="height" value="2"/>
        <integer name="temporal_bins" value="10"/><rfilter type="box"/></film></sensor></shape>
</scene>"""


@pytest.mark.parametrize(
    "old, new, words",
    [
        ("<scene version", "<scen version", ["XML"]),
        ('value="$spp"', 'value="$nope"', ["nope", "line 9"]),
        ('<float name="fov" value="0.2"/>', '<float name="fov" value="wide"/>', ["line 4", "wide"]),
        ('<rotate x="1" angle="180"/>', '<shear x="1"/>', ["shear"]),
        ('<rotate x="1" angle="180"/>', '<rotate x="1"/>', ["angle"]),
        ('<boolean name="nlos_laser_sampling" value="true"/>', '<boolean name="nlos_laser_sampling" value="yes"/>', ["yes", "boolean"]),
        ('<integer name="width" value="2"/>', '<integer name="width" value="2"/><integer name="width" value="3"/>', ["width", "twice"]),
        ("<rfilter type=\"box\"/>", "<rfilter type=\"box\"/><banana/>", ["banana"]),
    ],
)
def test_bad_xml(tmp_path, old, new, words):
    path = tmp_path / "scene.xml"
    path.write_text(XML_OK.replace(old, new))
    with pytest.raises(SceneError) as e:
        nlos_rs.load_file(path)
    for w in words:
        assert w in str(e.value), (w, str(e.value))


def test_xml_parameters(tmp_path):
    path = tmp_path / "scene.xml"
    path.write_text(XML_OK)
    assert nlos_rs.load_file(path).spp == 8
    assert nlos_rs.load_file(path, spp=32).spp == 32
    with pytest.raises(SceneError, match="unused|not used"):
        nlos_rs.load_file(path, spp=4, sp=3)
    with pytest.raises(FileNotFoundError):
        nlos_rs.load_file(tmp_path / "nope.xml")


def test_laser_missing_the_scene(z):
    z["laser"]["to_world"] = nlos_rs.Transform4f().look_at([-0.5, 0, 0.25], [-0.5, 0, 5.0], [0, 1, 0])
    with pytest.raises(SceneError, match="laser does not point"):
        nlos_rs.render(z, progress=False)


@pytest.mark.parametrize("kw", [{"variant": "spectral"}, {"spp": 0}, {"spp": 1.5}, {"threads": 0}, {"seed": -1}])
def test_bad_render_arguments(z, kw):
    with pytest.raises(ValueError):
        nlos_rs.render(z, progress=False, **kw)


def test_bad_render_target():
    with pytest.raises(TypeError):
        nlos_rs.render(42)

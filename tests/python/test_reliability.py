"""Nothing a user types or loads kills, hangs or silently corrupts a session: one regression test per
defect an adversarial run found (each now gets a SceneError naming plugin and key, or works).
Everything that could crash runs in a subprocess, so a regression fails the test instead of
killing the test runner."""

import os
import subprocess
import sys
import textwrap
import threading
import time

import numpy as np
import pytest

import nlos_rs
from nlos_rs import SceneError


def small(**kw):
    return nlos_rs.scenes.z_nlos_1corner(width=4, height=4, spp=16, **kw)


def run_isolated(code: str, timeout: float = 60.0) -> subprocess.CompletedProcess:
    """Run `code` in a fresh interpreter; a crash shows as a negative return code."""
    return subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True,
                          timeout=timeout, cwd=os.path.dirname(__file__))


def expect_scene_error(code: str, *words: str) -> str:
    """`code` must raise SceneError (caught, printed as 'SceneError: ...') whose message has `words`."""
    r = run_isolated(f"""
import nlos_rs, numpy as np
try:
{textwrap.indent(textwrap.dedent(code), '    ')}
    print("NO ERROR")
except nlos_rs.SceneError as e:
    print("SceneError:", e)
""")
    assert r.returncode == 0, (r.returncode, r.stderr[-2000:])
    out = r.stdout.strip().splitlines()[-1]
    assert out.startswith("SceneError:"), out
    assert len(out) < 500, len(out)
    for w in words:
        assert w in out, (w, out)
    return out


def expect_edited_z_error(edit: str, *words: str, then: str = "nlos_rs.load_dict(d)") -> str:
    """The 2×2 built-in Z with `edit` applied to its dict `d`; `then` must raise a SceneError with `words`."""
    return expect_scene_error(f"""
d = nlos_rs.scenes.z_nlos_1corner(width=2, height=2, spp=1)
{edit}
{then}
""", *words)


# ---- The process died


def test_deeply_nested_xml_is_refused(tmp_path):
    xml = "<scene version='3.0.0'>" + "<shape type='obj'>" * 10_000 + "</shape>" * 10_000 + "</scene>"
    (tmp_path / "deep.xml").write_text(xml)
    expect_scene_error(f"nlos_rs.load_file({str(tmp_path / 'deep.xml')!r})", "nested more than 64")


def test_deeply_nested_dict_is_refused():
    expect_scene_error("""
d = {"type": "scene"}
cur = d
for _ in range(8000):
    cur["x"] = {"type": "obj"}
    cur = cur["x"]
nlos_rs.load_dict(d)
""", "nested more than 64")


@pytest.mark.parametrize("film, words", [
    ({"width": 4096, "height": 4096, "temporal_bins": 4096}, ["transient_hdr_film", "max_memory"]),
    ({"width": 64, "height": 64, "temporal_bins": 2048, "exhaustive_scan": True, "laser_scan_width": 64,
      "laser_scan_height": 64}, ["max_memory"]),
    ({"width": 65536, "height": 65536, "temporal_bins": 1 << 24}, ["max_memory"]),  # 2^64 floats: no wrap-around
])
def test_huge_outputs_are_refused_before_allocating(film, words):
    capture = "exhaustive" if film.get("exhaustive_scan") else "single"
    expect_scene_error(f"""
d = nlos_rs.scenes.z_nlos_1corner(width=4, height=4, spp=1, capture_type={capture!r})
d["relay_wall"]["nlos_sensor"]["film"].update({film!r})
nlos_rs.render(d, progress=False)
""", *words)


def test_max_memory_can_be_raised_and_lowered():
    d = small()
    with pytest.raises(SceneError, match="max_memory"):
        nlos_rs.render(d, progress=False, max_memory="1KiB")
    assert nlos_rs.render(d, progress=False, max_memory="64MiB")[1].shape == (4, 4, 300, 1)
    with pytest.raises(SceneError, match="max_memory"):
        nlos_rs.render(d, progress=False, max_memory="lots")


def test_huge_kernel_is_refused_at_once():
    t = time.perf_counter()
    expect_scene_error("nlos_rs.render(nlos_rs.scenes.z_nlos_1corner(width=2, height=2, spp=1), kernel_sigma=1e6, progress=False)",
                       "kernel_sigma")
    assert time.perf_counter() - t < 20


@pytest.mark.parametrize("kind", ["dev_zero_mesh", "dev_zero_mtllib", "ply_no_properties", "ply_huge_count",
                                  "ply_long_version"])
def test_hostile_mesh_files(tmp_path, kind):
    if kind == "dev_zero_mesh":
        path = "/dev/zero"
    elif kind == "dev_zero_mtllib":
        path = tmp_path / "m.obj"
        path.write_text("mtllib /dev/zero\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    elif kind == "ply_no_properties":
        path = tmp_path / "m.ply"
        path.write_bytes(b"ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\nend_header\n")
    elif kind == "ply_huge_count":
        path = tmp_path / "m.ply"
        path.write_text("ply\nformat ascii 1.0\nelement vertex 99999999999999999999999\nproperty float x\nend_header\n")
    else:  # found by the ply fuzz target: ply-rs panicked on a 60-digit version number
        path = tmp_path / "m.ply"
        path.write_text("ply\nformat ascii 1." + "5" * 60 + "\nelement vertex 1\nproperty float x\nend_header\n0\n")
    code = f"""
d = nlos_rs.scenes.z_nlos_1corner(width=2, height=2, spp=1)
d["z"]["type"] = {'obj' if kind.startswith('dev_zero') and kind != 'dev_zero_mesh' else ('ply' if 'ply' in kind else 'obj')!r}
d["z"]["filename"] = {str(path)!r}
s = nlos_rs.load_dict(d)
"""
    if kind == "dev_zero_mtllib":  # materials are never read: the mesh loads
        r = run_isolated("import nlos_rs\n" + textwrap.dedent(code) + "print('loaded', len(s.shape_ids))")
        assert r.returncode == 0 and "loaded" in r.stdout, r.stderr[-2000:]
    else:
        expect_scene_error(code, "mesh")


def test_fork_and_multiprocessing_fork_children_render():
    r = run_isolated("""
import os, multiprocessing as mp, nlos_rs, numpy as np
d = nlos_rs.scenes.z_nlos_1corner(width=4, height=4, spp=32)
parent = nlos_rs.render(d, seed=1, progress=False)[1]
pid = os.fork()
if pid == 0:
    child = nlos_rs.render(nlos_rs.load_dict(d), seed=1, progress=False)[1]
    os._exit(0 if np.array_equal(child, parent) else 3)
_, status = os.waitpid(pid, 0)
assert os.WEXITSTATUS(status) == 0, status

def job(seed):
    return float(nlos_rs.render(d, seed=seed, progress=False)[1].sum())

with mp.get_context("fork").Pool(2) as pool:
    sums = pool.map(job, [1, 2])
assert abs(sums[0] - float(parent.sum())) < 1e-6 * abs(sums[0]), sums
print("forked ok")
""", timeout=120)
    assert r.returncode == 0 and "forked ok" in r.stdout, (r.returncode, r.stderr[-2000:])


def test_fork_child_assembles_parts():
    # Putting parts together (the Dask and out-of-core routes) runs outside any render's thread
    # pool; it must not start rayon's global pool either, whose threads a forked child lacks.
    r = run_isolated("""
import os, signal, nlos_rs, numpy as np
from nlos_rs import _core, distributed as nd
d = nlos_rs.scenes.z_nlos_1corner(width=16, height=16, spp=8)  # a 300 KB transient: work to split
src = nd.source(d)
opts = nd._options(8, 1, "mono", None, None, None)

def assembled():
    local = nd.load(src)
    plan = _core.render_plan(local, opts)
    return _core.assemble(local, nd.compute_parts(src, plan, opts, (0, plan["pixels"])), opts)[0]

parent = assembled()
pid = os.fork()
if pid == 0:
    signal.alarm(20)  # a hung child dies instead of outliving the test
    os._exit(0 if np.array_equal(assembled(), parent) else 3)
_, status = os.waitpid(pid, 0)
assert os.WIFEXITED(status) and os.WEXITSTATUS(status) == 0, status
print("assembled ok")
""", timeout=60)
    assert r.returncode == 0 and "assembled ok" in r.stdout, (r.returncode, r.stderr[-2000:])


# ---- Panics


@pytest.mark.parametrize("edit, words", [
    ("d['ball'] = {'type': 'sphere', 'radius': 1e19}", ["sphere", "radius"]),
    ("d['ball'] = {'type': 'sphere', 'radius': 1.0, 'center': [1e39, 0, 0]}", ["sphere", "center"]),
    ("d['z']['to_world'] = [[1e30, 0, 0, 0], [0, 1e30, 0, 0], [0, 0, 1, 1], [0, 0, 0, 1]]", ["obj", "to_world"]),
])
def test_out_of_range_geometry_gets_an_error(edit, words):
    expect_edited_z_error(edit, *words, then="nlos_rs.render(d, progress=False)")


def test_obj_with_out_of_range_indices(tmp_path):
    """Found by the obj fuzz target: tobj's index arithmetic overflowed on such faces."""
    path = tmp_path / "bad.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/-2 2/-999999999999999999 3\n")
    expect_edited_z_error(f'd["z"]["filename"] = {str(path)!r}', "index")


def test_obj_with_huge_coordinates(tmp_path):
    path = tmp_path / "big.obj"
    path.write_text("v 0 0 0\nv 1e20 0 0\nv 0 1e20 0\nf 1 2 3\n")
    expect_edited_z_error(f'd["z"]["filename"] = {str(path)!r}', "obj", "coordinates")


# ---- Hangs


def slow_scene():
    """Expensive samples: HGRS with the most draws, unbounded depth."""
    return small(nlos_hidden_geometry_sampling_includes_relay_wall=True,
                 type="transient_nlos_path_rs", hgrs_max_iterations=10_000)


def test_ctrl_c_stops_an_expensive_render_within_a_fifth_of_a_second(python_handles_sigint):
    import _thread

    d = nlos_rs.scenes.z_nlos_1corner(width=8, height=8, spp=1 << 20,
                                       nlos_hidden_geometry_sampling_includes_relay_wall=True)
    scene = nlos_rs.load_dict(d).with_integrator("transient_nlos_path_rs", hgrs_max_iterations=10_000)
    latencies = []
    for _ in range(3):
        timer = threading.Timer(0.5, _thread.interrupt_main)
        timer.start()
        t0 = time.perf_counter()
        with pytest.raises(KeyboardInterrupt):
            nlos_rs.render(scene, progress=False)
        latencies.append(time.perf_counter() - t0 - 0.5)
        timer.cancel()
    print(f"\nCtrl-C latency: {[round(x, 3) for x in latencies]} s")
    assert max(latencies) < 0.2, latencies


def test_other_threads_run_while_rendering():
    d = nlos_rs.scenes.z_nlos_1corner(width=8, height=8, spp=100_000)
    ticks = []
    stop = threading.Event()

    def ticker():
        while not stop.is_set():
            ticks.append(time.perf_counter())
            time.sleep(0.01)

    th = threading.Thread(target=ticker)
    th.start()
    nlos_rs.render(d, progress=False)
    stop.set()
    th.join()
    gaps = np.diff(ticks)
    assert len(ticks) > 5 and gaps.max() < 0.2, gaps.max()


def test_hgrs_draws_are_bounded():
    with pytest.raises(SceneError, match="hgrs_max_iterations"):
        nlos_rs.load_dict(small()).with_integrator("transient_nlos_path_rs", hgrs_max_iterations=1_000_000)


def test_a_large_laser_grid_is_interruptible():
    import _thread

    d = nlos_rs.scenes.z_nlos_1corner(width=512, height=512, spp=1, capture_type="confocal", temporal_bins=2)
    timer = threading.Timer(0.2, _thread.interrupt_main)
    timer.start()
    t0 = time.perf_counter()
    try:
        nlos_rs.render(d, progress=False)
    except KeyboardInterrupt:
        pass
    finally:
        timer.cancel()
    assert time.perf_counter() - t0 < 0.2 + 0.3


def test_loading_is_linear_in_scene_size():
    """100,000 objects: the dict's top-level entries and the scene built from them."""
    d = nlos_rs.scenes.z_nlos_1corner(width=2, height=2, spp=1)
    for i in range(100_000):
        d[f"s{i}"] = {"type": "sphere", "center": [float(i % 100), float(i // 100), 5.0], "radius": 0.1}
    t = time.perf_counter()
    scene = nlos_rs.load_dict(d)
    seconds = time.perf_counter() - t
    print(f"\n100,000 spheres load in {seconds:.2f} s")
    assert len(scene.shape_ids) == 100_002 and seconds < 10


def test_a_large_xml_scene_loads_in_linear_time(tmp_path):
    shapes = "".join(f'<shape type="sphere"><point name="center" x="{i % 400}" y="{i // 400}" z="5"/>'
                     f'<float name="radius" value="0.1"/></shape>' for i in range(200_000))
    nlos_rs.save_xml(nlos_rs.scenes.z_nlos_1corner(width=2, height=2, spp=1), tmp_path / "base.xml")
    text = (tmp_path / "base.xml").read_text().replace("</scene>", shapes + "</scene>")
    (tmp_path / "big.xml").write_text(text)
    t = time.perf_counter()
    scene = nlos_rs.load_file(tmp_path / "big.xml")
    print(f"\n200,000 XML shapes load in {time.perf_counter() - t:.2f} s")
    assert len(scene.shape_ids) == 200_002 and time.perf_counter() - t < 20


def test_a_mistyped_nested_object_is_named_for_what_it_is():
    d = small()
    d["z"]["bsdf"] = {"type": "cube"}
    with pytest.raises(SceneError, match="unexpected nested 'cube'"):
        nlos_rs.load_dict(d)


def test_threads_are_capped():
    with pytest.raises(SceneError, match="threads"):
        nlos_rs.render(small(), threads=10**6, progress=False)


# ---- Wrong results, silently


@pytest.mark.parametrize("edit, words", [
    ("d['laser']['irradiance'] = 1e300", ["projector", "irradiance"]),
    ("d['z']['bsdf']['reflectance'] = 1e39", ["diffuse", "reflectance"]),
    ("d['z']['bsdf']['reflectance'] = 50.0", ["diffuse", "reflectance"]),
])
def test_out_of_range_values_are_refused(edit, words):
    expect_edited_z_error(edit, *words)


def test_laser_power_beyond_single_precision_is_refused():
    d = small()
    d["laser"]["irradiance"] = 1e20
    d["laser"]["scale"] = 1e20
    with pytest.raises(SceneError, match="scale"):
        nlos_rs.load_dict(d)


def test_extreme_but_valid_values_never_put_nan_or_inf_in_the_film():
    d = small(max_depth=-1, nlos_hidden_geometry_sampling_includes_relay_wall=True)
    d["laser"]["irradiance"] = 1e20
    d["relay_wall"]["nlos_sensor"]["film"]["bin_width_opl"] = 1e-30
    steady, transient = nlos_rs.render(d, progress=False)
    assert np.isfinite(transient).all() and np.isfinite(steady).all() and steady.sum() > 0


# ---- Unclear errors


@pytest.mark.parametrize("kwargs, key", [({"spp": True}, "spp"), ({"seed": 2**70}, "seed"), ({"threads": 0}, "threads"),
                                         ({"integrator": ""}, "integrator")])
def test_render_arguments_get_scene_errors(kwargs, key):
    with pytest.raises(SceneError, match=key):
        nlos_rs.render(small(), progress=False, **kwargs)


def test_duplicate_ids_are_refused():
    d = small()
    d["a"] = {"type": "diffuse", "id": "white"}
    d["b"] = {"type": "diffuse", "id": "white"}
    with pytest.raises(SceneError, match="white"):
        nlos_rs.load_dict(d)


def test_huge_values_give_short_messages():
    d = small()
    d["z"]["bsdf"]["reflectance"] = "x" * 5_000_000
    with pytest.raises(SceneError) as e:
        nlos_rs.load_dict(d)
    assert len(str(e.value)) < 500


def test_cli_huge_numbers_exit_2(tmp_path):
    for args in (["--spp", str(2**64)], ["--seed", str(2**70)]):
        r = subprocess.run([sys.executable, "-m", "nlos_rs", "render", "z_nlos_1corner", "--quiet", "--out", "a.npz", *args],
                           capture_output=True, text=True, cwd=tmp_path)
        assert r.returncode == 2 and "Traceback" not in r.stderr and r.stderr.count("\n") == 1, r.stderr

"""nlos_rs.distributed and nlos_rs.render_to_file: bit-identical to nlos_rs.render with 1 and 2 Dask
worker processes (on 127.0.0.1, stopped after), a worker SIGKILLed mid-render changes nothing, an
exhaustive capture of 2 GiB streams to disk within 1 GiB of memory and equals the in-memory one, and
batch renders resume without mistaking an interrupted output for a complete one."""

import os
import signal
import subprocess
import sys
import textwrap
import threading
import time

import h5py
import numpy as np
import pytest

import nlos_rs
from nlos_rs import SceneError, _core, scenes

distributed = pytest.importorskip("distributed")
import nlos_rs.distributed as nd  # noqa: E402

CASES = {
    "8x8": lambda: scenes.z_nlos_1corner(width=8, height=8, spp=300),
    "1x1_chunks": lambda: scenes.z_nlos_1corner(width=1, height=1, spp=20000),
    "3x2_chunks": lambda: scenes.z_nlos_1corner(width=3, height=2, spp=3000),
    "exhaustive": lambda: scenes.z_nlos_1corner(width=3, height=3, spp=600, capture_type="exhaustive"),
    "two_corners": lambda: scenes.t_nlos_2corner("small", width=4, height=4, spp=512),
}


@pytest.fixture(scope="module", params=[1, 2], ids=["1 worker", "2 workers"])
def client(request):
    with distributed.LocalCluster(n_workers=request.param, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address="127.0.0.1:0") as cluster, distributed.Client(cluster) as c:
        yield c


@pytest.mark.parametrize("case", list(CASES))
def test_bit_identical_to_the_local_render(client, case):
    d = CASES[case]()
    steady, transient = nd.render(d, client=client, progress=False, tasks=7)
    ref = nlos_rs.render(d, progress=False)
    assert np.array_equal(transient, ref[1]) and np.array_equal(steady, ref[0])
    assert transient.shape == ref[1].shape and transient.sum() > 0


@pytest.mark.parametrize("xml,spp", [("transient-nlos/nlos-z-simple.xml", 195), ("cornell-box/cbox_diffuse.xml", 1)])
def test_bit_identical_on_mitransients_own_files(client, xml, spp):
    # Files from mitransient's repository (tests/data/mitransient): workers load the XML by path.
    path = os.path.join(os.path.dirname(__file__), "..", "data", "mitransient", xml)
    out = nd.render(path, spp=spp, client=client, progress=False)
    ref = nlos_rs.render(path, spp=spp, progress=False)
    assert all(np.array_equal(a, b) for a, b in zip(out, ref)) and ref[1].sum() > 0


def test_rgb_kernel_seed_and_scene_objects(client):
    scene = nlos_rs.load_dict(scenes.z_nlos_1corner(width=4, height=4, spp=400))
    kw = dict(spp=700, seed=3, variant="rgb", kernel_sigma=1.5)
    out = nd.render(scene, client=client, progress=False, **kw)
    ref = nlos_rs.render(scene, progress=False, **kw)
    assert all(np.array_equal(a, b) for a, b in zip(out, ref))
    scene.focus_laser_at(0.1, 0.0, 0.0)  # no longer what it was loaded from
    with pytest.raises(TypeError, match="focus_laser_at"):
        nd.render(scene, client=client, progress=False)


def test_parts_equal_the_whole_where_paths_leave_by_cones(tmp_path):
    # With hidden-geometry sampling off, a path's first direction is tested against its scan
    # point's or camera pixel's cone, which a part makes for its own pixels only.
    z_off = scenes.z_nlos_1corner(width=6, height=5, spp=256)
    z_off["integrator"]["nlos_hidden_geometry_sampling"] = False
    src = os.path.join(os.path.dirname(__file__), "..", "data", "mitransient", "transient-nlos")
    os.symlink(os.path.abspath(os.path.join(src, "meshes")), tmp_path / "meshes")
    xml = open(os.path.join(src, "nlos-z-simple.xml")).read()
    off = xml.replace('name="nlos_hidden_geometry_sampling" value="true"', 'name="nlos_hidden_geometry_sampling" value="false"')
    assert off != xml
    (tmp_path / "off.xml").write_text(off)
    for scene, spp in [(nlos_rs.load_dict(z_off), 256), (nlos_rs.load_file(str(tmp_path / "off.xml")), 64)]:
        ref = nlos_rs.render(scene, spp=spp, threads=1, progress=False)
        opts = {"mono": True, "spp": spp}
        plan = _core.render_plan(scene, opts)
        n, k = plan["pixels"], (0, plan["chunks"])
        runs = [(0, 7), (7, 8), (8, n // 2), (n // 2, n)]
        parts = [(p, k, *_core.render_part(scene, p, k, {**opts, "threads": 2})) for p in runs]
        t, s = _core.assemble(scene, parts, opts)
        assert np.array_equal(t.reshape(ref[1].shape), ref[1]) and np.array_equal(s.reshape(ref[0].shape), ref[0])
        assert ref[1].sum() > 0


def test_a_killed_worker_changes_nothing():
    d = scenes.z_nlos_1corner(width=1, height=1, spp=1 << 25)
    ref = nlos_rs.render(d, progress=False)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address="127.0.0.1:0") as cluster, distributed.Client(cluster) as c:
        pids = c.run(os.getpid)
        result = {}
        job = threading.Thread(target=lambda: result.update(out=nd.render(d, client=c, progress=False, tasks=48)))
        job.start()
        time.sleep(1.0)
        assert job.is_alive(), "the render ended before a worker could be killed"
        os.kill(next(iter(pids.values())), signal.SIGKILL)
        job.join(timeout=300)
        assert not job.is_alive()
    steady, transient = result["out"]
    assert np.array_equal(transient, ref[1]) and np.array_equal(steady, ref[0])


def test_render_refuses_a_film_beyond_max_memory_and_names_render_to_file():
    with pytest.raises(SceneError, match="render_to_file"):
        nlos_rs.render(scenes.z_nlos_1corner(width=64, height=64, spp=1), max_memory="1MiB", progress=False)


def test_render_to_file_of_2_gib_stays_within_1_gib_and_equals_the_in_memory_capture(tmp_path):
    # 32×32 scan points × 32×32 laser points × 512 bins × 4 bytes = 2 GiB.
    d = scenes.z_nlos_1corner(width=32, height=32, spp=1, temporal_bins=512, capture_type="exhaustive")
    path = tmp_path / "big.hdf5"
    code = f"""
        import nlos_rs
        from nlos_rs import scenes
        d = scenes.z_nlos_1corner(width=32, height=32, spp=1, temporal_bins=512, capture_type="exhaustive")
        nlos_rs.render_to_file(d, {str(path)!r}, max_memory="512MiB", progress=False)
        # VmHWM: this address space's peak (ru_maxrss would include the forking test process's).
        hwm = [l for l in open("/proc/self/status") if l.startswith("VmHWM:")][0]
        print("peak", int(hwm.split()[1]) * 1024)
    """
    r = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True, timeout=900)
    assert r.returncode == 0, r.stderr
    peak = int(r.stdout.split("peak")[-1])
    assert peak < 1 << 30, f"peak RSS {peak / 2**20:.0f} MiB"
    _, transient = nlos_rs.render(d, progress=False)
    assert transient.nbytes >= 2 << 30
    with h5py.File(path) as f:
        H = f["H"]
        assert H.shape == (512, 32, 32, 32, 32)
        for y in range(32):  # tal's (t, lx, ly, x, y) against mitransient's (y, x, ly, lx, t, 1)
            assert np.array_equal(H[..., y], np.transpose(transient[y, ..., 0], (3, 2, 1, 0)))
    assert transient.sum() > 0


def test_render_to_file_matches_write_capture_with_zero_t_start(tmp_path):
    scene = nlos_rs.load_dict(scenes.z_nlos_1corner(width=5, height=3, spp=300, start_opl=1.2, bin_width_opl=0.01))
    nlos_rs.render_to_file(scene, tmp_path / "a.hdf5", max_memory="64KiB", zero_t_start=True, progress=False)
    nlos_rs.io.write_capture(tmp_path / "b.hdf5", scene, nlos_rs.render(scene, progress=False)[1], zero_t_start=True)
    with h5py.File(tmp_path / "a.hdf5") as a, h5py.File(tmp_path / "b.hdf5") as b:
        assert set(a) == set(b)
        for key in a:
            if key != "scene_info":
                assert np.array_equal(a[key][()], b[key][()]), key
    with pytest.raises(SceneError, match="max_memory"):
        nlos_rs.render_to_file(scene, tmp_path / "c.hdf5", max_memory="1KiB", progress=False)


def test_batch_resumes_and_never_takes_an_interrupted_output_for_complete(tmp_path):
    out = tmp_path / "out"
    args = [sys.executable, "-m", "nlos_rs", "batch", "z_nlos_1corner", "t_nlos_2corner_small", "--out", str(out),
            "--spp", "64", "--quiet"]
    r = subprocess.run(args, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    done = {p.name: p.stat().st_mtime_ns for p in out.glob("*.hdf5")}
    assert set(done) == {"z_nlos_1corner.hdf5", "t_nlos_2corner_small.hdf5"}
    # A rerun skips complete outputs.
    assert subprocess.run(args, capture_output=True, timeout=600).returncode == 0
    assert {p.name: p.stat().st_mtime_ns for p in out.glob("*.hdf5")} == done
    # An interrupted render leaves only a partial file under a temporary name, which a rerun redoes.
    (out / "t_nlos_2corner_small.hdf5").unlink()
    slow = args[:4] + ["t_nlos_2corner_small", "--out", str(out), "--spp", str(1 << 22), "--quiet"]
    p = subprocess.Popen(slow)
    time.sleep(4.0)
    p.send_signal(signal.SIGKILL)
    p.wait()
    assert not (out / "t_nlos_2corner_small.hdf5").exists()
    assert subprocess.run(args, capture_output=True, timeout=600).returncode == 0
    assert (out / "t_nlos_2corner_small.hdf5").exists()
    assert (out / "z_nlos_1corner.hdf5").stat().st_mtime_ns == done["z_nlos_1corner.hdf5"]
    with h5py.File(out / "t_nlos_2corner_small.hdf5") as f:
        assert f["H"][()].sum() > 0


def test_batch_on_a_cluster(tmp_path):
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address="127.0.0.1:0") as cluster:
        paths = nd.batch(["z_nlos_1corner"], tmp_path, spp=64, client=cluster.scheduler_address, progress=False)
    local = tmp_path / "local"
    nd.batch(["z_nlos_1corner"], local, spp=64, progress=False)
    with h5py.File(paths[0]) as a, h5py.File(local / "z_nlos_1corner.hdf5") as b:
        assert np.array_equal(a["H"][()], b["H"][()])

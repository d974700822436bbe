"""The command line: render, evaluate, and errors as one line with exit status 2."""

import subprocess
import sys

import numpy as np


def run(*args, cwd):
    return subprocess.run([sys.executable, "-m", "nlos_rs", *args], cwd=cwd, capture_output=True, text=True)


def test_render_builtin_scene(tmp_path):
    (tmp_path / "o").mkdir()  # --out into a missing folder is an error (test_dropin.py)
    r = run("render", "z_nlos_1corner", "--spp", "8", "--quiet", "--figures", "figs", "--out", "o/a.npz", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert "rendered 32x32 x 300 bins, 8 spp" in r.stdout
    data = np.load(tmp_path / "o" / "a.npz")
    assert data["transient"].shape == (32, 32, 300, 1)
    assert (tmp_path / "figs" / "time_slices.png").exists()


def test_render_to_a_tal_capture_with_the_thesis_options(tmp_path):
    import tal

    r = run("render", "z_nlos_1corner", "--spp", "16", "--integrator", "transient_nlos_path_rs", "--kernel-sigma", "1.5",
            "--out", "z.hdf5", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    data = tal.io.read_capture(str(tmp_path / "z.hdf5"))
    assert data.H.shape == (300, 32, 32)
    assert data.scene_info["integrator"] == "transient_nlos_path_rs"
    assert data.scene_info["temporal_kernel"] == ["gaussian", 1.5]


def test_demo(tmp_path):
    r = run("demo", "--spp", "16", "--quiet", "--out", "d", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    for f in ("capture.npz", "steady.png", "time_slices.png", "pixel_transient.png"):
        assert (tmp_path / "d" / f).exists()


def test_errors_are_one_line(tmp_path):
    (tmp_path / "bad.xml").write_text("<scene version='3.5.0'><integrator type='transient_nlos_path'><integer name='max_dpeth' value='1'/></integrator></scene>")
    for args in (["render", "nope.xml"], ["render", "bad.xml"], ["render", "teapot"], ["render", "z_nlos_1corner", "--spp", "0"],
                 ["render", "z_nlos_1corner", "--spp", "4", "--out", "x.txt"]):
        r = run(*args, cwd=tmp_path)
        assert r.returncode == 2, (args, r.stderr)
        assert r.stderr.count("\n") == 1 and r.stderr.startswith("nlos-rs: error:") and "Traceback" not in r.stderr, r.stderr


def test_evaluate_writes_the_table(tmp_path):
    r = run("evaluate", "--scene", "z_nlos_1corner", "--size", "4", "--spp", "64", "--gt-spp", "2048", "--out", "ev", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    md = (tmp_path / "ev" / "results.md").read_text()
    for label in ("Baseline", "HGRS, resampled", "HGRS, rejection", "Gaussian kernel", "Epanechnikov kernel", "Equal time"):
        assert label in md
    assert (tmp_path / "ev" / "mse_psnr_equal_spp.png").exists()


def test_console_script_is_installed():
    import shutil

    exe = shutil.which("nlos-rs")
    assert exe, "the nlos-rs console script is not on PATH"
    r = subprocess.run([exe, "--help"], capture_output=True, text=True)
    assert r.returncode == 0 and "render" in r.stdout and "evaluate" in r.stdout

"""The type stubs (python/nlos_rs/_core.pyi) match the compiled module."""

import subprocess
import sys


def test_stubs_match_the_binary(tmp_path):
    r = subprocess.run([sys.executable, "-m", "mypy.stubtest", "nlos_rs._core"], capture_output=True, text=True, cwd=tmp_path)
    assert r.returncode == 0, r.stdout + r.stderr

"""Fuzzing in the test suite.

* Scene dicts: fuzz_dicts.py runs ≥ 10,000 hypothesis cases (derandomized: the same every run) in a
  subprocess; any exception other than SceneError/FileNotFoundError, a non-finite result, a crash
  or a hang fails this test. NLOS_RS_FUZZ_CASES changes the count.
* Mesh and XML loaders: the committed libFuzzer corpus (fuzz/corpus/, built by `cargo fuzz`, see
  fuzz/README.md) is replayed through the same entry points the fuzz targets call.
"""

import os
import subprocess
import sys
from pathlib import Path

import pytest

import nlos_rs

HERE = Path(__file__).parent
CORPUS = HERE.parent.parent / "fuzz" / "corpus"


def test_ten_thousand_mutated_scene_dicts():
    cases = int(os.environ.get("NLOS_RS_FUZZ_CASES", "10000"))
    r = subprocess.run([sys.executable, str(HERE / "fuzz_dicts.py"), str(cases)], capture_output=True, text=True,
                       timeout=1500, cwd=HERE)
    print(r.stdout[-500:])
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    assert f"fuzz cases: {cases}" in r.stdout


@pytest.mark.parametrize("target", ["obj", "ply", "xml"])
def test_fuzz_corpus_replays(target, tmp_path):
    files = sorted((CORPUS / target).glob("*"))
    assert files, f"no corpus for {target}"
    code = f"""
import sys, pathlib, nlos_rs
for f in sorted(pathlib.Path({str(CORPUS / target)!r}).glob("*")):
    data = f.read_bytes()
    suffix = {('.' + target)!r}
    p = pathlib.Path({str(tmp_path)!r}) / ("case" + suffix)
    p.write_bytes(data)
    try:
        if suffix == ".xml":
            nlos_rs.load_file(p)
        else:
            d = nlos_rs.scenes.z_nlos_1corner(width=2, height=2, spp=1)
            d["z"]["type"] = suffix[1:]
            d["z"]["filename"] = str(p)
            nlos_rs.load_dict(d)
    except (nlos_rs.SceneError, FileNotFoundError):
        pass
print("replayed", {len(files)})
"""
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600)
    assert r.returncode == 0 and f"replayed {len(files)}" in r.stdout, r.stderr[-3000:]

"""Property-based fuzzing of scene dicts (run by test_fuzz.py in a subprocess, so a crash fails the
test instead of killing the runner): the built-in scenes, mutated at random places with hostile
values, must load and render to a finite result or raise SceneError (FileNotFoundError for a
mesh file that is not there) — never another exception, a crash or a hang.

Usage: python fuzz_dicts.py CASES. Hypothesis runs derandomized: the same cases every run."""

import copy
import signal
import sys
from datetime import timedelta

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import nlos_rs

BASES = [
    nlos_rs.scenes.z_nlos_1corner(width=3, height=2, spp=2, temporal_bins=20, bin_width_opl=0.1),
    nlos_rs.scenes.z_nlos_1corner(width=2, height=2, spp=2, temporal_bins=20, bin_width_opl=0.1, capture_type="exhaustive"),
    nlos_rs.scenes.t_nlos_2corner("small", width=2, height=2, spp=2, temporal_bins=20, bin_width_opl=0.2),
    nlos_rs.scenes.cornell_box(width=3, height=3, spp=2, temporal_bins=20),
]
BASES = [nlos_rs.values.normalize(b) for b in BASES]

PLUGINS = ["diffuse", "twosided", "conductor", "roughconductor", "dielectric", "plastic", "roughplastic", "blendbsdf",
           "mask", "rectangle", "sphere", "disk", "cube", "obj", "ply", "projector", "area", "point", "angulararea",
           "perspective", "nlos_capture_meter", "transient_hdr_film", "phasor_hdr_film", "independent", "box", "rgb",
           "spectrum", "ref", "scene", "transient_nlos_path", "transient_nlos_path_rs", "transient_path", "regular",
           "teapot", ""]
STRINGS = ["single", "confocal", "exhaustive", "ggx", "beckmann", "Au", "bk7", "400:1, 700:1", "gaussian", "box", "x",
           "/dev/zero", "-1", "nan", "1e999", "Cu", "none", "air"]

numbers = st.one_of(
    st.integers(min_value=-(2**70), max_value=2**70),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0, 1, -1, 0.0, -0.0, 1e-45, 1e38, 3.5e38, 1e300, 2**31, 2**32, 2**63, 4096, 65536]),
)
leaves = st.one_of(
    st.none(), st.booleans(), numbers, st.text(max_size=12), st.sampled_from(STRINGS + PLUGINS),
    st.lists(numbers, max_size=5), st.lists(st.lists(numbers, min_size=4, max_size=4), min_size=4, max_size=4),
)
values = st.one_of(
    leaves,
    st.fixed_dictionaries({"type": st.sampled_from(PLUGINS)}, optional={"value": leaves, "id": st.sampled_from(["a", "z"])}),
)


def places(d, path=()):
    """Every (path) to a key in the nested dict."""
    for k, v in d.items():
        yield path + (k,)
        if isinstance(v, dict):
            yield from places(v, path + (k,))


@st.composite
def mutated(draw):
    d = copy.deepcopy(draw(st.sampled_from(BASES)))
    for _ in range(draw(st.integers(1, 3))):
        where = draw(st.sampled_from(list(places(d))))
        parent = d
        for k in where[:-1]:
            parent = parent[k]
        op = draw(st.sampled_from(["replace", "replace", "replace", "delete", "add"]))
        if op == "replace":
            parent[where[-1]] = draw(values)
        elif op == "delete":
            del parent[where[-1]]
        else:
            parent[draw(st.sampled_from(["extra", "type", "id", "to_world", "bsdf", "film", "value"]))] = draw(values)
    return d


class Hang(Exception):
    pass


def on_alarm(*_):
    raise Hang("a case took more than 20 s")


def main(cases: int) -> None:
    signal.signal(signal.SIGALRM, on_alarm)
    stats = {"ok": 0, "SceneError": 0, "FileNotFoundError": 0}

    @settings(max_examples=cases, derandomize=True, database=None, deadline=timedelta(seconds=30),
              suppress_health_check=list(HealthCheck))
    @given(mutated())
    def case(d):
        signal.alarm(20)
        try:
            steady, transient = nlos_rs.render(d, spp=2, threads=1, progress=False, max_memory="64MiB")
            assert np.isfinite(steady).all() and np.isfinite(transient).all(), "non-finite output"
            stats["ok"] += 1
        except nlos_rs.SceneError as e:
            assert len(str(e)) < 500, f"a {len(str(e))}-character message"
            stats["SceneError"] += 1
        except FileNotFoundError:
            stats["FileNotFoundError"] += 1
        finally:
            signal.alarm(0)

    case()
    print("fuzz cases:", sum(stats.values()), stats)


if __name__ == "__main__":
    main(int(sys.argv[1]))

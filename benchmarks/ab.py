"""A/B of two builds of nlos_rs in one process (not a test): both builds' cores are loaded side by
side and their renders of one workload alternate, so both meet the same machine state. On a
machine whose cores change speed from second to second (this project's drifts by up to 1.5x), two
builds timed in separate runs differ by more than most changes do. Alternated in one process, the
median ratio of each pair of renders is steadier but not exact: the same build on both sides gave
0.976, 1.074 and 1.015 (one run each of three workloads, 12 rounds), so one run resolves changes
of about 10 %; repeat it (each run is a fresh process) for smaller ones.

    pip install --no-deps --target /tmp/a .   # build A (then check out B and build it to /tmp/b)
    python benchmarks/ab.py /tmp/a /tmp/b cornell_los [--spp 256] [--rounds 20] [--threads 1]

The workload is one of benchmarks/suite.py's (its spp unless --spp). Prints each build's fastest
and median render and the median over rounds of time(A) / time(B): above 1, B is faster.
"""

from __future__ import annotations

import argparse
import glob
import importlib.machinery
import importlib.util
import os
import statistics
import sys
import time
import types
from pathlib import Path


def core(tag: str, build: str):
    """The `_core` extension of the build installed at `build` (a pip --target directory), loaded
    as `<tag>._core` beside any other build."""
    found = glob.glob(os.path.join(build, "nlos_rs", "_core*.so")) + glob.glob(os.path.join(build, "nlos_rs", "_core*.pyd"))
    if not found:
        sys.exit(f"no nlos_rs/_core extension under {build}")
    package = types.ModuleType(tag)
    package.__path__ = []
    sys.modules[tag] = package
    loader = importlib.machinery.ExtensionFileLoader(f"{tag}._core", found[0])
    spec = importlib.util.spec_from_file_location(f"{tag}._core", found[0], loader=loader)
    module = importlib.util.module_from_spec(spec)
    loader.exec_module(module)
    return module


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("a")
    ap.add_argument("b")
    ap.add_argument("workload")
    ap.add_argument("--spp", type=int)
    ap.add_argument("--rounds", type=int, default=20)
    ap.add_argument("--threads", type=int, default=1)
    args = ap.parse_args()
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import suite
    from nlos_rs import _Progress
    from nlos_rs.values import normalize

    made = suite.workloads(False)[args.workload][0]()
    if isinstance(made, tuple):  # a scene file, its spp and $parameters: both builds read it
        path, spp, params = (*made, {})[:3]
        made = None
    else:
        spp = suite.spp_of(made)
    opts = {"spp": args.spp or spp, "seed": 0, "threads": args.threads, "mono": True, "max_memory": None,
            "return_variance": False, "target_rel_error": None, "low_discrepancy": None}
    runs = []
    for tag, build in (("build_a", args.a), ("build_b", args.b)):
        c = core(tag, build)
        scene = c.load_file(path, {k: str(v) for k, v in params.items()}) if made is None else c.load_dict(normalize(made), os.getcwd())
        runs.append((c, scene))

    def render(k: int) -> float:
        c, scene = runs[k]
        t0 = time.perf_counter()
        c.render(scene, opts, _Progress(False))
        return time.perf_counter() - t0

    render(0), render(1)  # warm
    times = ([], [])
    for r in range(args.rounds):
        for k in ((0, 1) if r % 2 == 0 else (1, 0)):  # alternate which goes first
            times[k].append(render(k))
    ratio = statistics.median(a / b for a, b in zip(*times))
    for name, t in zip((args.a, args.b), times):
        print(f"{name}: fastest {min(t):.4f} s, median {statistics.median(t):.4f} s")
    print(f"{args.workload}: median time(A)/time(B) over {args.rounds} rounds = {ratio:.3f}")


if __name__ == "__main__":
    main()

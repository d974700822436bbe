"""Benchmark (not a test): the Z scene, 64x64 scan x 300 bins, laser + hidden-geometry sampling,
nlos_rs against mitransient 1.3.1 (llvm_ad_mono), both on the same two threads, in one run, warm.

    python benchmarks/bench_z.py [--spp 4096] [--threads 2] [--repeats 3]

Prints paths/s for each and the ratio (median over repeats). mitransient's time is the render call
with dr.eval + dr.sync_thread (its kernels are cached by a warm-up render first).
"""

from __future__ import annotations

import argparse
import os
import statistics
import time


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--spp", type=int, default=4096)
    ap.add_argument("--size", type=int, default=64)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--capture", default="single", choices=["single", "confocal"])
    args = ap.parse_args()

    import nlos_rs
    from nlos_rs.mitsuba_compat import import_mitransient, to_mitsuba

    mi, mitr = import_mitransient("llvm_ad_mono")
    import drjit as dr

    dr.set_thread_count(args.threads)
    d = nlos_rs.scenes.z_nlos_1corner(width=args.size, height=args.size, spp=args.spp, capture_type=args.capture)
    paths = args.size * args.size * args.spp

    ours_scene = nlos_rs.load_dict(d)
    theirs_scene = mi.load_dict(to_mitsuba(d))

    def run_ours() -> float:
        t0 = time.perf_counter()
        nlos_rs.render(ours_scene, threads=args.threads, progress=False)
        return time.perf_counter() - t0

    def run_theirs() -> float:
        t0 = time.perf_counter()
        steady, transient = mi.render(theirs_scene, spp=args.spp)
        dr.eval(steady, transient)
        dr.sync_thread()
        return time.perf_counter() - t0

    run_ours(), run_theirs()  # warm-up: page-in, kernel compilation and cache
    ours, theirs = [], []
    for _ in range(args.repeats):  # interleaved, so machine noise hits both alike
        ours.append(run_ours())
        theirs.append(run_theirs())
    to, tt = statistics.median(ours), statistics.median(theirs)
    print(f"Z scene {args.capture}, {args.size}x{args.size} x 300 bins, {args.spp} spp = {paths / 1e6:.1f} M paths, "
          f"{args.threads} threads, mitsuba {mi.__version__}, mitransient {mitr.__version__}")
    print(f"  nlos_rs     : {to:7.3f} s  {paths / to / 1e6:7.2f} M paths/s   (runs: {', '.join(f'{t:.3f}' for t in ours)})")
    print(f"  mitransient : {tt:7.3f} s  {paths / tt / 1e6:7.2f} M paths/s   (runs: {', '.join(f'{t:.3f}' for t in theirs)})")
    print(f"  ratio (nlos_rs speed / mitransient speed): {tt / to:.2f}x")


if __name__ == "__main__":
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    main()

"""Benchmark (not a test): nlos_rs.distributed on this machine.

    python benchmarks/dask_scaling.py

Prints the time of one render locally (all cores) and on a LocalCluster of 1 and 2 single-threaded
worker processes (127.0.0.1), the 1 → 2 worker speedup, and the overhead per task (many near-empty
tasks, against the same work done locally).
"""

from __future__ import annotations

import nlos_rs
import nlos_rs.distributed as nd
from distributed import Client, LocalCluster
from nlos_rs import scenes
from timing import best


def main() -> None:
    d = scenes.z_nlos_1corner(width=32, height=32, spp=8192)
    tiny = scenes.z_nlos_1corner(width=16, height=16, spp=1)
    one = best(lambda: nlos_rs.render(d, threads=1, progress=False))
    local = best(lambda: nlos_rs.render(d, progress=False))
    print(f"Z 32x32, 8192 spp: local 1 thread {one:.2f} s, all cores {local:.2f} s")
    times = {}
    for workers in (1, 2):
        with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, host="127.0.0.1",
                          dashboard_address="127.0.0.1:0") as cluster, Client(cluster) as c:
            nd.render(d, client=c, progress=False, tasks=4)  # warm: workers load the scene once
            times[workers] = best(lambda: nd.render(d, client=c, progress=False))
            print(f"  {workers} worker(s), default tasks (4 per worker): {times[workers]:.2f} s")
            if workers == 2:
                n = 256
                here = best(lambda: nlos_rs.render(tiny, progress=False))
                there = best(lambda: nd.render(tiny, client=c, progress=False, tasks=n))
                print(f"overhead per task: {(there - here) / n * 1e3:.1f} ms ({n} tasks of one pixel, 1 spp, "
                      f"{there:.2f} s on 2 workers vs {here * 1e3:.1f} ms locally)")
    print(f"speedup 1 -> 2 workers: {times[1] / times[2]:.2f}x")


if __name__ == "__main__":
    main()

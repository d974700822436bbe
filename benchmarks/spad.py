"""Benchmark (not a test): nlos_rs.sensor on a 64×64 × 1000-bin capture, on all cores.

    python benchmarks/spad.py

Prints the time of expected_counts and simulate (without and with pile-up, afterpulsing and
crosstalk) and of coates; the transient is a render of the built-in Z at 64 spp.
"""

from __future__ import annotations

import os

import nlos_rs
from nlos_rs import scenes, sensor
from timing import best


def main() -> None:
    scene = nlos_rs.load_dict(scenes.z_nlos_1corner(width=64, height=64, spp=64, temporal_bins=1000, bin_width_opl=0.0015))
    _, transient = nlos_rs.render(scene, progress=False)
    plain = sensor.Spad()
    full = sensor.Spad(pile_up=True, dead_time_ns=50.0, afterpulse_prob=0.05, crosstalk_prob=0.05, ambient_rate_hz=1e6)
    counts = sensor.simulate(scene, transient, full)
    print(f"64x64 x 1000 bins, {os.cpu_count()} cores")
    print(f"expected_counts                          {best(lambda: sensor.expected_counts(scene, transient, plain)):.3f} s")
    print(f"simulate (Poisson)                       {best(lambda: sensor.simulate(scene, transient, plain)):.3f} s")
    print(f"simulate (pile-up, afterpulse, crosstalk) {best(lambda: sensor.simulate(scene, transient, full)):.3f} s")
    print(f"coates                                   {best(lambda: sensor.coates(counts, scene, full)):.3f} s")


if __name__ == "__main__":
    main()

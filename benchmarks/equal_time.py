"""Equal-time error against mitransient (not a test): ``python -m nlos_rs.evaluate`` on scenes the
project did not tune for — a one-sided flat letter behind one corner (albedo 0.7, unbounded depth;
a single capture, and an exhaustive one of 8×8 scan points × 8×8 laser points),
the T behind two corners (small and big secondary wall, five-vertex signal) and mitransient's own
``nlos-z-simple.xml`` (a perspective camera as the sensor) — each technique given mitransient's
render time. Prints each scene's equal-time table (MSE against a high-spp ground truth whose own
noise is subtracted; mitransient's MSE over each technique's).

    python benchmarks/equal_time.py [--threads 2] [--out DIR] [--only NAME ...]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parent


def flat_letter_xml(out: Path, capture_type: str = "single", size: int = 32) -> Path:
    """The suite's one-sided flat 'F' 1 m behind the relay wall, size×size×300 (and as many laser
    points for an exhaustive capture), as a Mitsuba XML file."""
    import nlos_rs
    from nlos_rs.xml import save_xml

    sys.path.insert(0, str(HERE))
    from suite import flat_letter_mesh

    d = nlos_rs.scenes.z_nlos_1corner(width=size, height=size, spp=4096, capture_type=capture_type)
    d["z"] = {"type": "obj", "filename": flat_letter_mesh(out / "flat_f.obj"),
              "to_world": nlos_rs.Transform4f().translate([0.0, 0.0, 1.0]),
              "bsdf": {"type": "diffuse", "reflectance": 0.7}}
    path = out / ("flat_f_1corner.xml" if capture_type == "single" else f"flat_f_1corner_{capture_type}.xml")
    save_xml(d, path)
    return path


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--out", default="nlos_rs_equal_time")
    ap.add_argument("--only", nargs="*")
    args = ap.parse_args()
    from nlos_rs import evaluate

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    techniques = "baseline,gaussian,hgrs,reuse,reuse_hgrs,reuse_auto,reuse_ld,reuse_ld_auto,mitransient"
    runs = {  # name → (scene, spp, ground-truth spp)
        "flat_f_1corner": (str(flat_letter_xml(out)), 4096, 1 << 21),
        "flat_f_1corner_exhaustive": (str(flat_letter_xml(out, "exhaustive", 8)), 4096, 1 << 20),
        "t_small_five_vertex": ("t_nlos_2corner_small", 16384, 1 << 27),
        "t_big_five_vertex": ("t_nlos_2corner_big", 4096, 1 << 24),
        "mitransient_nlos_z_simple": (str(REPO / "tests" / "data" / "mitransient" / "transient-nlos" / "nlos-z-simple.xml"),
                                      4096, 1 << 20),
    }
    for name, (scene, spp, gt_spp) in runs.items():
        if args.only and name not in args.only:
            continue
        folder = out / name
        evaluate.main(["--scene", scene, "--spp", str(spp), "--gt-spp", str(gt_spp), "--threads", str(args.threads),
                       "--techniques", techniques, "--out", str(folder), "--quiet"])
        print((folder / "results.md").read_text(), flush=True)


if __name__ == "__main__":
    main()

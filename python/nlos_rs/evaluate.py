"""Reproduce the thesis' evaluation (Tables 5.1-5.3, Figures 5.7-5.12, 5.16-5.17, 5.20-5.21) of
I. Tienda Hernando, *Técnicas de muestreo para simulación de transporte de luz sin línea de
visión* (Sampling techniques for non-line-of-sight light transport simulation), bachelor's thesis
(Trabajo Fin de Grado), Universidad de Zaragoza, 2023.

    python -m nlos_rs.evaluate [--scene z_nlos_1corner | FILE.xml] [--spp N] [--gt-spp N] [--out DIR] ...

For a scene (built in, or any Mitsuba XML file such as mitransient's examples) it renders (and
caches) a ground truth with nlos_rs' defaults at ``--gt-spp``, then the thesis' techniques — the
baseline (``transient_nlos_path`` with laser + hidden-geometry sampling and one path per scan point,
or for the Cornell box ``transient_path``), HGRS with both estimators (``transient_nlos_path_rs``,
NLOS scenes only), the Gaussian kernel and the Epanechnikov kernel — and the techniques beyond it:
nlos_rs' defaults (sample reuse across scan points), the same with an automatic Gaussian width, and
mitransient itself (when installed):

* at equal samples per pixel (``--spp``), and
* at equal time: each technique gets mitransient's render time at ``--spp`` (the baseline's without
  mitransient, or ``--time-budget`` seconds), its spp scaled from the equal-spp render.

It writes ``results.md`` (spp, time, MSE and PSNR of thesis eq. 5.1/5.2 against the ground truth,
whose own noise is subtracted; change vs the baseline; mitransient's MSE over each), ``results.json``, and PNG plots (radiance against time at one pixel; MSE
and PSNR bars). Two-corner scenes are evaluated on their five-vertex signal (``filter_bounces=4``),
the light that went through both corners, as the thesis evaluates them.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import time
from pathlib import Path
from typing import Dict, List

import numpy as np

import nlos_rs
from nlos_rs import metrics

SCENES = {
    "z_nlos_1corner": lambda size: nlos_rs.scenes.z_nlos_1corner(width=size, height=size),
    "t_nlos_2corner_small": lambda size: nlos_rs.scenes.t_nlos_2corner("small", width=size, height=size, filter_bounces=4),
    "t_nlos_2corner_big": lambda size: nlos_rs.scenes.t_nlos_2corner("big", width=size, height=size, filter_bounces=4),
    "cornell_box": lambda size: nlos_rs.scenes.cornell_box(width=size, height=size),
}
# The thesis' settings per scene (its §5.3): spp of the compared renders, Gaussian sigma and
# Epanechnikov bandwidth; our scan size and a ground truth of at least 35x the spp.
DEFAULTS = {  # size, spp, ground-truth spp, sigma, bandwidth
    "z_nlos_1corner": (32, 30_000, 1 << 20, 1.0, 2.0),
    "t_nlos_2corner_small": (16, 100_000, 1 << 23, 2.0, 3.0),
    "t_nlos_2corner_big": (16, 10_000, 1 << 20, 2.0, 3.0),
    "cornell_box": (64, 1_000, 15_000, 3.0, 3.0),  # thesis §5.3.4: reference 15,000 spp
}
THESIS = ["baseline", "hgrs", "hgrs_rejection", "gaussian", "epanechnikov"]
# Beyond the thesis (docs/techniques.md): nlos_rs' defaults (sample reuse across scan points), the
# automatic kernel width on top, and mitransient itself on the same scene.
BEYOND = ["reuse", "reuse_hgrs", "reuse_auto", "reuse_ld", "reuse_ld_auto", "mitransient"]
TECHNIQUES = THESIS + BEYOND
LABELS = {"baseline": "Baseline", "hgrs": "HGRS, resampled (unbiased)", "hgrs_rejection": "HGRS, rejection (thesis)",
          "gaussian": "Gaussian kernel", "epanechnikov": "Epanechnikov kernel",
          "reuse": "Sample reuse (nlos_rs default)", "reuse_hgrs": "Sample reuse + HGRS (resampled)",
          "reuse_auto": "Sample reuse + auto Gaussian width",
          "reuse_ld": "Sample reuse + Sobol'",
          "reuse_ld_auto": "Sample reuse + Sobol' + auto width",
          "mitransient": "mitransient 1.3.1"}


def options(name: str, args) -> dict:
    return {
        "baseline": {},
        "hgrs": {"integrator": "transient_nlos_path_rs", "hgrs_max_iterations": args.hgrs_iterations, "hgrs_estimator": "resampled"},
        "hgrs_rejection": {"integrator": "transient_nlos_path_rs", "hgrs_max_iterations": args.hgrs_iterations, "hgrs_estimator": "rejection"},
        "gaussian": {"kernel_sigma": args.sigma},
        "epanechnikov": {"kernel_bandwidth": args.bandwidth},
        "reuse": {},
        "reuse_hgrs": {"integrator": "transient_nlos_path_rs", "hgrs_max_iterations": args.hgrs_iterations,
                       "hgrs_estimator": "resampled"},
        "reuse_auto": {"kernel_sigma": "auto"},
        "reuse_ld": {"sampler": "stratified"},
        "reuse_ld_auto": {"kernel_sigma": "auto", "sampler": "stratified"},
        "mitransient": {},
    }[name]


def scene_of(name: str, scene):
    """The scene a technique renders: the thesis' techniques trace one path per scan point (as the
    thesis and mitransient do); the others take nlos_rs' defaults."""
    if name in THESIS and scene.integrator.startswith("transient_nlos"):
        return scene.with_sample_reuse(False)
    return scene


def timed(scene, spp: int, seed: int, threads, **kw):
    t0 = time.perf_counter()
    _, transient = nlos_rs.render(scene, spp=spp, seed=seed, threads=threads, progress=False, **kw)
    return transient, time.perf_counter() - t0


def timed_mitransient(src, spp: int, seed: int, threads, shape):
    """mitransient's render of the same scene (a dict or an XML file)."""
    import drjit as dr

    from .mitsuba_compat import import_mitransient, to_mitsuba

    mi, _ = import_mitransient("llvm_ad_mono")
    if threads:
        dr.set_thread_count(threads)
    scene = mi.load_file(str(src)) if isinstance(src, (str, Path)) else mi.load_dict(to_mitsuba(src))
    t0 = time.perf_counter()
    _, transient = mi.render(scene, spp=spp, seed=seed)
    dr.eval(transient)
    dr.sync_thread()
    seconds = time.perf_counter() - t0
    return np.asarray(transient, np.float32).reshape(shape), seconds


def ground_truth(scene, args, out: Path):
    """The ground truth and its own noise: the mean over values of its variance of the mean, which
    every MSE against it contains (E‖x − g‖² = E‖x − μ‖² + E‖g − μ‖² for independent x, g); the
    tables subtract it."""
    path = out / f"gt_{Path(args.scene).stem}_{args.size}px_{args.gt_spp}spp_v2.npz"
    if path.exists():
        f = np.load(path)
        return f["transient"], float(f["noise"])
    print(f"rendering the ground truth ({args.gt_spp} spp) ...", flush=True)
    _, transient, variance = nlos_rs.render(scene, spp=args.gt_spp, seed=10_000, threads=args.threads,
                                            progress=not args.quiet, return_variance=True)
    noise = float(np.mean(variance, dtype=np.float64))
    np.savez_compressed(path, transient=transient, noise=noise)
    return transient, noise


def fmt_time(s: float) -> str:
    return f"{s:.2f} s" if s < 60 else f"{int(s // 60)} min {s % 60:.0f} s"


def table(rows: List[Dict], title: str) -> str:
    base = next(r for r in rows if r["technique"] == "baseline")
    mitr = next((r for r in rows if r["technique"] == "mitransient"), None)
    cols = "| technique | spp | time | MSE ↓ | PSNR (dB) ↑ | MSE vs baseline |" + (" mitransient's MSE ÷ MSE |" if mitr else "")
    out = [f"#### {title}", "", cols, "|---|---:|---:|---:|---:|---:|" + ("---:|" if mitr else "")]
    for r in rows:
        change = "—" if r["technique"] == "baseline" else f"{100 * (r['mse'] / base['mse'] - 1):+.1f} %"
        row = f"| {LABELS[r['technique']]} | {r['spp']:,} | {fmt_time(r['time'])} | {r['mse']:.3g} | {r['psnr']:.2f} | {change} |"
        out.append(row + (f" **{mitr['mse'] / r['mse']:.2f}×** |" if mitr else ""))
    return "\n".join(out)


def plots(out: Path, gt: np.ndarray, curves: Dict[str, np.ndarray], rows: List[Dict], t0: float, dt: float, tag: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    # The brightest transient: of a scan point, or of a (scan point, laser point) pair.
    lead = gt.shape[:-2]
    flat = lambda a: a.reshape(-1, *a.shape[-2:])  # noqa: E731
    at = int(np.argmax(flat(gt)[..., 0].sum(-1)))
    opl = t0 + (np.arange(gt.shape[-2]) + 0.5) * dt
    nz = np.nonzero(flat(gt)[at, :, 0])[0]
    lo, hi = (nz[0], nz[-1] + 1) if len(nz) else (0, len(opl))
    fig, ax = plt.subplots(figsize=(8, 3.5))
    ax.plot(opl[lo:hi], flat(gt)[at, lo:hi, 0], "k", lw=2, label="ground truth")
    for name, t in curves.items():
        ax.plot(opl[lo:hi], flat(t)[at, lo:hi, 0], lw=1, label=LABELS[name])
    ax.set_xlabel("optical path length (m)")
    ax.set_ylabel("radiance per bin")
    ax.set_title(f"index {tuple(int(i) for i in np.unravel_index(at, lead))}, {tag}")
    ax.legend(fontsize=7)
    fig.savefig(out / f"radiance_time_{tag}.png", dpi=110, bbox_inches="tight")
    plt.close(fig)
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.2))
    names = [LABELS[r["technique"]] for r in rows]
    axes[0].bar(names, [r["mse"] for r in rows], color="tab:red")
    axes[0].set_yscale("log")
    axes[0].set_title(f"MSE ({tag})")
    axes[1].bar(names, [r["psnr"] for r in rows], color="tab:blue")
    axes[1].set_title(f"PSNR, dB ({tag})")
    for a in axes:
        a.tick_params(axis="x", rotation=30, labelsize=7)
    fig.savefig(out / f"mse_psnr_{tag}.png", dpi=110, bbox_inches="tight")
    plt.close(fig)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m nlos_rs.evaluate", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", default="z_nlos_1corner",
                    help=f"a built-in scene ({', '.join(SCENES)}; default z_nlos_1corner) or a Mitsuba XML file")
    ap.add_argument("--size", type=int, help="scan grid / image size (default: 32 for Z, 16 for the T scenes, 64 for the Cornell box)")
    ap.add_argument("--spp", type=int, help="samples per pixel of the compared renders (default: the thesis' 30,000 Z, 100,000 T small, 10,000 T big)")
    ap.add_argument("--gt-spp", type=int, help="samples per pixel of the ground truth (default: 2^20; 2^23 for T small)")
    ap.add_argument("--techniques", default=",".join(TECHNIQUES), help=f"comma-separated subset of {','.join(TECHNIQUES)}")
    ap.add_argument("--sigma", type=float, help="Gaussian kernel sigma in bins (default: the thesis' 1 for Z, 2 for T)")
    ap.add_argument("--bandwidth", type=float, help="Epanechnikov bandwidth in bins (default: the thesis' 2 for Z, 3 for T)")
    ap.add_argument("--hgrs-iterations", type=int, default=10, help="HGRS draws per vertex (default 10, as the thesis)")
    ap.add_argument("--time-budget", type=float, help="seconds per technique at equal time (default: mitransient's time at --spp, else the baseline's)")
    ap.add_argument("--threads", type=int, help="worker threads (default: all cores)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--quiet", action="store_true", help="no progress bar")
    ap.add_argument("--out", default="nlos_rs_evaluation", help="output folder (ground truth cached there)")
    args = ap.parse_args(argv)
    is_file = args.scene not in SCENES
    if is_file and not Path(args.scene).is_file():
        ap.error(f"--scene must be one of {list(SCENES)} or an XML file, got {args.scene!r}")
    size, spp, gt_spp, sigma, bandwidth = DEFAULTS.get(args.scene, (0, 4096, 1 << 18, 1.0, 2.0))
    args.size, args.spp, args.gt_spp = args.size or size, args.spp or spp, args.gt_spp or gt_spp
    args.sigma, args.bandwidth = args.sigma or sigma, args.bandwidth or bandwidth
    techniques = [t.strip() for t in args.techniques.split(",") if t.strip()]
    unknown = set(techniques) - set(TECHNIQUES)
    if unknown or "baseline" not in techniques:
        ap.error(f"techniques must include 'baseline' and come from {TECHNIQUES}; got {techniques}")
    if "mitransient" in techniques and importlib.util.find_spec("mitransient") is None:
        print("mitransient is not installed: leaving it out (pip install nlos_rs[peer])")
        techniques.remove("mitransient")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    src = Path(args.scene) if is_file else SCENES[args.scene](args.size)
    loaded = nlos_rs.load_file(src) if is_file else nlos_rs.load_dict(src)
    if is_file:
        args.size = loaded.film_size[0]
    scenes = {name: scene_of(name, loaded) for name in techniques if name != "mitransient"}
    scene = scenes["baseline"]
    if scene.integrator == "transient_path":  # HGRS and sample reuse are NLOS techniques
        techniques = [t for t in techniques if not t.startswith(("hgrs", "reuse"))]
    bins, dt, t0 = scene.temporal
    gt, gt_noise = ground_truth(scenes.get("reuse", scene), args, out)

    def evaluate(name: str, n: int):
        if name == "mitransient":
            t, seconds = timed_mitransient(src, n, args.seed, args.threads, gt.shape)
        else:
            t, seconds = timed(scenes[name], n, args.seed, args.threads, **options(name, args))
        raw = metrics.mse(gt, t)
        if raw < 4 * gt_noise:
            print(f"warning: {name}'s MSE {raw:.3g} is within 4x the ground truth's own noise {gt_noise:.3g}: raise --gt-spp")
        mse = raw - gt_noise
        psnr = 20 * np.log10(float(gt.max())) - 10 * np.log10(mse)
        return t, {"technique": name, "spp": n, "time": seconds, "mse": mse, "psnr": float(psnr)}

    timed(scene, 16, args.seed, args.threads)  # warm-up
    if "mitransient" in techniques:
        timed_mitransient(src, 16, args.seed, args.threads, gt.shape)
    equal_spp, curves = [], {}
    for name in techniques:
        t, row = evaluate(name, args.spp)
        if name == "mitransient":  # its first render of a size compiles kernels; its time varies
            for _ in range(2):       # from run to run: the fastest of three more is its budget
                t2, row2 = evaluate(name, args.spp)
                row["time"] = min(row["time"], row2["time"])
        equal_spp.append(row)
        curves[name] = t
        print(f"equal spp  {name:15s} {row['spp']:>9,} spp {fmt_time(row['time']):>10s}  MSE {row['mse']:.3e}  PSNR {row['psnr']:.2f}", flush=True)
    # Equal time: mitransient's time at --spp where it runs, else the baseline's.
    budget = args.time_budget or next((r["time"] for r in equal_spp if r["technique"] == "mitransient"), equal_spp[0]["time"])
    equal_time = []
    for row in equal_spp:
        r = row
        # Scale spp to the budget; short renders time poorly, so re-scale from each attempt until
        # the time is within 10 % of the budget (three attempts at most).
        for _ in range(3):
            if row["technique"] == "mitransient" or abs(r["time"] / budget - 1) <= 0.1 and r is not row:
                break
            n = max(1, int(round(r["spp"] * budget / r["time"])))
            _, r = evaluate(row["technique"], n)
        equal_time.append(r)
        print(f"equal time {r['technique']:15s} {r['spp']:>9,} spp {fmt_time(r['time']):>10s}  MSE {r['mse']:.3e}  PSNR {r['psnr']:.2f}", flush=True)
    plots(out, gt, curves, equal_spp, t0, dt, "equal_spp")
    plots(out, gt, {}, equal_time, t0, dt, "equal_time")
    header = (f"### {args.scene}: {args.size}x{args.size} scan, {bins} bins x {dt} m from {t0} m; ground truth {args.gt_spp:,} spp "
              f"(nlos_rs defaults; its noise, {gt_noise:.3g}, is subtracted from every MSE); HGRS N = {args.hgrs_iterations}, Gaussian sigma = {args.sigma}, Epanechnikov b = {args.bandwidth} bins; "
              f"nlos_rs {nlos_rs.__version__}, {args.threads or 'all'} threads")
    md = "\n\n".join([header, table(equal_spp, "Equal samples per pixel"), table(equal_time, f"Equal time ({fmt_time(budget)} each)")])
    (out / "results.md").write_text(md + "\n")
    (out / "results.json").write_text(json.dumps({"args": vars(args), "equal_spp": equal_spp, "equal_time": equal_time}, indent=1))
    print(f"\nwrote {out}/results.md, results.json and PNG plots")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

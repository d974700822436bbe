"""Command line: ``python -m nlos_rs demo`` and ``python -m nlos_rs render SCENE``.

Errors are one readable line and exit status 2, not a traceback.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

import nlos_rs

BUILTIN = nlos_rs.scenes.BUILTIN

#: Film options of the built-in scenes: command-line flag -> keyword of the scene function.
FILM_OPTIONS = {"width": "width", "height": "height", "bins": "temporal_bins", "bin_width": "bin_width_opl",
                "start": "start_opl"}


def _load(args: argparse.Namespace) -> "nlos_rs.Scene":
    film = {kw: getattr(args, flag) for flag, kw in FILM_OPTIONS.items() if getattr(args, flag) is not None}
    if args.scene in BUILTIN:
        if args.define:
            raise ValueError("-D sets $parameters of XML scenes; built-in scenes take --width/--height/--bins/--bin-width/--start")
        return nlos_rs.load_dict(BUILTIN[args.scene](**film))
    if Path(args.scene).suffix.lower() == ".xml":
        if film:
            raise ValueError("--width/--height/--bins/--bin-width/--start are for built-in scenes; "
                             "an XML scene takes -D name=value for its $parameters")
        params = {}
        for d in args.define:
            name, eq, value = d.partition("=")
            if not eq or not name:
                raise ValueError(f"-D needs name=value, got {d!r}")
            params[name] = value
        return nlos_rs.load_file(args.scene, **params)
    raise ValueError(f"unknown scene {args.scene!r}: give an XML file or one of {', '.join(BUILTIN)}")


def _check_outputs(out: Path, figures: "Path | None") -> None:
    """Before rendering: the output's suffix is known and its folder (and the figures' parent) exist."""
    if out.suffix.lower() not in (".hdf5", ".h5", ".npz"):
        raise ValueError(f"--out must end in .hdf5/.h5 (tal capture) or .npz (arrays), got {out}")
    for what, folder in (("--out", out.parent), ("--figures", figures.parent if figures else None)):
        if folder is not None and not folder.is_dir():
            raise ValueError(f"{what}: folder {str(folder)!r} does not exist")


def write_figures(out: Path, steady: np.ndarray, transient: np.ndarray, t0: float, dt: float) -> None:
    """Steady image, a strip of time slices and one pixel's transient, as PNGs."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    img = steady[..., 0]
    fig, ax = plt.subplots(figsize=(4, 4))
    ax.imshow(img, origin="lower", cmap="inferno")
    ax.set_title("steady (time-integrated)")
    ax.set_xlabel("x (scan column)")
    ax.set_ylabel("y (scan row)")
    fig.savefig(out / "steady.png", dpi=100, bbox_inches="tight")
    plt.close(fig)

    profile = transient[..., 0].sum((0, 1))
    # Eight slices spread over where the energy arrives (its 1 % to 95 % quantiles).
    cdf = np.cumsum(profile) / max(profile.sum(), 1e-30)
    lo, hi = np.searchsorted(cdf, 0.01), np.searchsorted(cdf, 0.95)
    idx = np.linspace(lo, max(hi, lo + 7), 8).astype(int).clip(0, len(profile) - 1)
    vmax = transient[..., idx, 0].max() or 1.0
    fig, axes = plt.subplots(1, 8, figsize=(16, 2.4))
    for a, i in zip(axes, idx):
        a.imshow(transient[:, :, i, 0], origin="lower", cmap="inferno", vmin=0, vmax=vmax)
        a.set_title(f"OPL {t0 + (i + 0.5) * dt:.3f} m", fontsize=8)
        a.axis("off")
    fig.savefig(out / "time_slices.png", dpi=100, bbox_inches="tight")
    plt.close(fig)

    h, w = img.shape
    fig, ax = plt.subplots(figsize=(6, 3))
    opl = t0 + (np.arange(len(profile)) + 0.5) * dt
    ax.plot(opl, transient[h // 2, w // 2, :, 0])
    ax.set_xlabel("optical path length (m)")
    ax.set_ylabel("radiance per bin")
    ax.set_title(f"transient of pixel ({w // 2}, {h // 2})")
    fig.savefig(out / "pixel_transient.png", dpi=100, bbox_inches="tight")
    plt.close(fig)


def cmd_render(args: argparse.Namespace, scene: "nlos_rs.Scene", out: Path, figures: "Path | None") -> int:
    if args.integrator:
        scene = scene.with_integrator(args.integrator)
    spad = nlos_rs.sensor.Spad.from_string(args.spad) if getattr(args, "spad", None) is not None else None
    info = {}
    if args.kernel or args.kernel_sigma or args.kernel_bandwidth:
        name = args.kernel or ("gaussian" if args.kernel_sigma else "epanechnikov")
        info["temporal_kernel"] = [name, args.kernel_sigma or args.kernel_bandwidth or 0.0]
    t = time.perf_counter()
    steady, transient = nlos_rs.render(scene, spp=args.spp, seed=args.seed, threads=args.threads, progress=not args.quiet,
                                       variant=args.variant, kernel=args.kernel, kernel_sigma=args.kernel_sigma,
                                       kernel_bandwidth=args.kernel_bandwidth)
    seconds = time.perf_counter() - t
    bins, dt, t0 = scene.temporal
    if spad is not None:
        # Photon counts as a SPAD records them (docs/sensor.md).
        transient = nlos_rs.sensor.simulate(scene, transient, spad, seed=args.seed)
        info["spad"] = spad.params()
    if out.suffix.lower() in (".hdf5", ".h5"):
        nlos_rs.io.write_capture(out, scene, transient, scene_info=info)
    else:
        np.savez_compressed(out, steady=steady, transient=transient, bin_width_opl=dt, start_opl=t0)
    if figures is not None:
        figures.mkdir(exist_ok=True)
        write_figures(figures, steady, transient, t0, dt)
    w, h = scene.film_size
    spp = args.spp or scene.spp
    print(f"rendered {w}x{h} x {bins} bins, {spp} spp ({w * h * spp / seconds / 1e6:.1f} M paths/s, {seconds:.2f} s) "
          f"-> {out}{f' + PNGs in {figures}' if figures else ''}")
    return 0


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    if argv[:1] == ["evaluate"]:  # the thesis evaluation has its own options
        from . import evaluate

        return evaluate.main(argv[1:])
    ap = argparse.ArgumentParser(prog="nlos-rs", description="nlos_rs: transient NLOS rendering")
    sub = ap.add_subparsers(dest="cmd", required=True)
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("--spp", type=int, default=None, help="samples per scan point (default: the scene's)")
    common.add_argument("--seed", type=int, default=0)
    common.add_argument("--threads", type=int, default=None, help="worker threads (default: all cores)")
    common.add_argument("--variant", default="mono", choices=["mono", "rgb"])
    common.add_argument("--quiet", action="store_true", help="no progress bar")
    common.add_argument("--integrator", choices=["transient_nlos_path", "transient_nlos_path_rs"], help="switch the scene's integrator")
    common.add_argument("--kernel-sigma", type=float, help="Gaussian temporal kernel, sigma in bins")
    common.add_argument("--kernel-bandwidth", type=float,
                        help="temporal kernel half-width in bins (Epanechnikov unless --kernel names another)")
    common.add_argument("--kernel", choices=["box", "gaussian", "epanechnikov", "triangular", "biweight", "triweight", "cosine"],
                        help="temporal kernel (gaussian takes --kernel-sigma, the others --kernel-bandwidth)")
    demo = sub.add_parser("demo", parents=[common], help="render the built-in Z scene (64x64 x 300 bins) and write PNGs + arrays")
    demo.add_argument("--out", default="nlos_rs_demo", help="output folder (default: nlos_rs_demo)")
    rend = sub.add_parser("render", parents=[common], help="render an XML scene or a built-in scene name")
    rend.add_argument("scene", help=f"Mitsuba XML file or one of: {', '.join(BUILTIN)}")
    rend.add_argument("--out", default="capture.hdf5", help="tal capture (.hdf5) or arrays (.npz); default capture.hdf5")
    rend.add_argument("--spad", metavar="KEY=VALUE,...", help="write SPAD photon counts instead of the radiometric transient, "
                      "e.g. exposure_s=8e-3,pile_up=true (parameters of nlos_rs.sensor.Spad; mono only)")
    rend.add_argument("--figures", metavar="DIR", help="also write PNG figures to DIR (its parent must exist)")
    rend.add_argument("-D", dest="define", action="append", default=[], metavar="NAME=VALUE",
                      help="set an XML scene's $NAME parameter (repeatable)")
    rend.add_argument("--width", type=int, help="built-in scenes: scan grid width")
    rend.add_argument("--height", type=int, help="built-in scenes: scan grid height")
    rend.add_argument("--bins", type=int, help="built-in scenes: number of time bins")
    rend.add_argument("--bin-width", type=float, help="built-in scenes: bin width (optical path, m)")
    rend.add_argument("--start", type=float, help="built-in scenes: optical path at the start of bin 0 (m)")
    bat = sub.add_parser("batch", help="render one tal capture per scene into a folder (resumable; distributable)")
    bat.add_argument("scenes", nargs="+", metavar="SCENE", help=f"Mitsuba XML files or built-in names ({', '.join(BUILTIN)})")
    bat.add_argument("--out", required=True, help="folder for <name>.hdf5 (outputs already there are skipped)")
    bat.add_argument("--spp", type=int, default=None, help="samples per scan point (default: each scene's)")
    bat.add_argument("--seed", type=int, default=0)
    bat.add_argument("--scheduler", metavar="ADDRESS", help="a Dask scheduler (tcp://host:8786); default: render here")
    bat.add_argument("--max-memory", help="memory for one capture's tiles, e.g. 2GiB (default: 80%% of what is available)")
    bat.add_argument("--quiet", action="store_true", help="no progress bar")
    sub.add_parser("evaluate", help="reproduce the thesis evaluation (see: evaluate --help)")
    args = ap.parse_args(argv)
    try:
        if args.cmd == "batch":
            from . import distributed

            for path in distributed.batch(args.scenes, args.out, spp=args.spp, seed=args.seed, client=args.scheduler,
                                          progress=not args.quiet, max_memory=args.max_memory):
                print(path)
            return 0
        if args.cmd == "demo":
            args.spp = args.spp or 4096
            out = Path(args.out)
            out.mkdir(exist_ok=True)  # the demo's own folder
            return cmd_render(args, nlos_rs.load_dict(nlos_rs.scenes.z_nlos_1corner(width=64, height=64)), out / "capture.npz", out)
        out, figures = Path(args.out), Path(args.figures) if args.figures else None
        _check_outputs(out, figures)
        return cmd_render(args, _load(args), out, figures)
    except KeyboardInterrupt:
        print("nlos-rs: interrupted", file=sys.stderr)
        return 130
    except (ValueError, OSError, OverflowError) as e:
        print(f"nlos-rs: error: {e}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())

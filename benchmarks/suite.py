"""Benchmark suite (not a test): nlos_rs against mitransient 1.3.1 on several workloads, in one run,
both on the same threads, warm, interleaved, best of repeats (the machine's speed drifts by up to
1.5x between runs, alike for both). Prints paths/s and the ratio per
workload as a Markdown table, and nlos_rs's scaling from 1 to 2 threads from renders at each
count, alternately (at least 9 of each, and for at least 4 s: short renders take more): the best of
each, their total time (which averages over the machine's speed changes instead of catching its
fastest moments) and the median of the paired ratios
(each 1-thread render over the 2-thread render right after it, which met about the same machine
state; one fast or slow moment moves it least); beside them the machine's own ceiling for the
workload, from two 1-thread renders run at once in each round (no sharing, nothing to wait for:
the most a split of one render can reach in that machine state); with the cores the fastest
2-thread render kept busy (process CPU time over wall time): the scaling is what a user sees, the
busy cores whether the render leaves a core idle (on a machine whose cores change speed independently the two
differ).

    python benchmarks/suite.py [--threads 2] [--repeats 5] [--only NAME ...] [--quick]

Workloads (most were not tuned for): the built-in Z (single, confocal, exhaustive); a one-sided
flat letter at 1 m, unbounded depth, albedo 0.7, and a 200k-triangle bumpy sphere (single and
confocal each); the T behind two
corners (five-vertex signal); Mitsuba's own mi.cornell_box() made transient (line of sight); a
1×1 capture; rgb; mitransient's example files nlos-z-simple.xml (a perspective camera),
nlos-z-room.xml (the Z among walls) and cornell-box/cbox_diffuse.xml (line of sight, 64×64), a
confocal capture tal wrote (tests/data/tal021, unbounded depth), and the Z's confocal capture, the
200k-triangle sphere (single and confocal) and mitransient's camera and room files with
hidden-geometry sampling off (the default of mitransient's plugin and of tal's generator): BSDF sampling from
the relay wall, whose rays mostly miss the hidden object (in the room, walls meet every one); and
three of tal's own examples (tal_example): the bunny, confocal and exhaustive, and the plane,
exhaustive, at 750 bins; and two other hidden objects, confocal: a disk (an analytic primitive,
not triangles) and the Z in Mitsuba's smooth `plastic` (a delta coating over a diffuse base, so
no light subpath is shared among scan points); rough BSDFs: the Cornell box with a rough
metal and a rough plastic box (line of sight) and the Z in rough plastic (confocal,
hidden-geometry sampling off).
mitransient's time is its render call with dr.eval + dr.sync_thread.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import threading
import time
from pathlib import Path

import numpy as np


def flat_letter_mesh(path: Path) -> str:
    """A one-sided flat 'F' (front faces towards -z), 0.6 × 0.8 m, as OBJ."""
    import nlos_rs

    rects = [(-0.3, -0.4, -0.15, 0.4), (-0.15, 0.25, 0.3, 0.4), (-0.15, -0.05, 0.2, 0.1)]
    v, f = [], []
    for x0, y0, x1, y1 in rects:
        b = len(v)
        v += [(x0, y0, 0.0), (x1, y0, 0.0), (x1, y1, 0.0), (x0, y1, 0.0)]
        f += [(b, b + 2, b + 1), (b, b + 3, b + 2)]  # normal -z, towards the wall
    return str(nlos_rs.scenes.write_obj(path, np.array(v), np.array(f)))


def bumpy_sphere_mesh(path: Path, n: int = 317) -> str:
    """A latitude–longitude sphere of radius 0.3 with bumps: ~2n² ≈ 200k triangles."""
    import nlos_rs

    th, ph = np.meshgrid(np.linspace(0, np.pi, n), np.linspace(0, 2 * np.pi, n, endpoint=False), indexing="ij")
    r = 0.3 * (1 + 0.05 * np.sin(7 * th) * np.cos(9 * ph))
    v = np.stack([r * np.sin(th) * np.cos(ph), r * np.sin(th) * np.sin(ph), r * np.cos(th)], -1).reshape(-1, 3)
    f = []
    for i in range(n - 1):
        for j in range(n):
            a, b, c, d = i * n + j, i * n + (j + 1) % n, (i + 1) * n + j, (i + 1) * n + (j + 1) % n
            f += [(a, c, b), (b, c, d)]
    return str(nlos_rs.scenes.write_obj(path, v, np.array(f)))


def icosphere_mesh(path: Path, subdivisions: int = 4, center=(186, 255, 169), radius: float = 90) -> str:
    """An icosphere of 20·4^subdivisions triangles (5,120 by default), by default of radius 90
    resting on the Cornell box's small box, as OBJ."""
    import nlos_rs

    t = (1 + 5**0.5) / 2
    v = [np.array(p, float) / np.linalg.norm(p) for p in
         [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t), (0, -1, -t), (0, 1, -t),
          (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]]
    f = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4), (11, 10, 2), (10, 7, 6),
         (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10),
         (8, 6, 7), (9, 8, 1)]
    for _ in range(subdivisions):
        middle: dict = {}

        def mid(a, b):
            key = (min(a, b), max(a, b))
            if key not in middle:
                m = v[a] + v[b]
                v.append(m / np.linalg.norm(m))
                middle[key] = len(v) - 1
            return middle[key]

        f = [g for a, b, c in f for g in
             ((a, mid(a, b), mid(c, a)), (b, mid(b, c), mid(a, b)), (c, mid(c, a), mid(b, c)),
              (mid(a, b), mid(b, c), mid(c, a)))]
    return str(nlos_rs.scenes.write_obj(path, np.array(v) * radius + np.array(center), np.array(f)))


def cbox_with(out: Path, shape: str = "", bsdfs: dict | None = None) -> str:
    """mitransient's cbox_diffuse.xml with `shape` (XML) added and the BSDFs of the boxes named in
    `bsdfs` ("smallbox", "largebox") replaced by the XML given, its file names made absolute."""
    path = Path(__file__).resolve().parent.parent / "tests" / "data" / "mitransient" / "cornell-box" / "cbox_diffuse.xml"
    text = path.read_text()
    for box, bsdf in (bsdfs or {}).items():
        old = f'value="meshes/cbox_{box}.obj"/>\n        <ref id="gray"/>'
        assert old in text, box
        text = text.replace(old, f'value="meshes/cbox_{box}.obj"/>{bsdf}')
    text = text.replace('value="meshes/', f'value="{path.parent / "meshes"}/')
    out.write_text(text.replace("</scene>", shape + "\n</scene>"))
    return str(out)


def cbox_all_rough(out: Path) -> str:
    """mitransient's cbox_diffuse.xml with every surface but the light rough: the boxes and the
    coloured walls rough plastic (Beckmann, α 0.2), the floor a rough conductor (α 0.3), the back
    wall and the ceiling GGX rough plastic (α 0.3)."""
    import re

    text = Path(cbox_with(out)).read_text()

    def rough(m):
        body = m.group(2).replace('name="reflectance"', 'name="diffuse_reflectance"')
        return f'<bsdf type="roughplastic"{m.group(1) or ""}><float name="alpha" value="0.2"/>{body}</bsdf>'

    text = re.sub(r'<bsdf type="diffuse"( id="gray")?>(.*?)</bsdf>', rough, text, flags=re.S)
    ggx = '<bsdf type="roughplastic"><string name="distribution" value="ggx"/><float name="alpha" value="0.3"/></bsdf>'
    for shape, bsdf in (("floor", '<bsdf type="roughconductor"><float name="alpha" value="0.3"/></bsdf>'),
                        ("ceiling", ggx), ("back", ggx)):
        at = text.index('<ref id="white"/>', text.index(f'id="{shape}"'))
        text = text[:at] + bsdf + text[at + len('<ref id="white"/>'):]
    out.write_text(text)
    return str(out)


def scene_copy(path: Path, out: Path, hgs: bool = False, z_bsdf: str | None = None, extra: str = "") -> str:
    """A copy of a mitransient scene file, with hidden-geometry sampling off (its plugin default)
    unless `hgs`, the Z's BSDF (its mesh hidden_geometry_Z.ply) replaced by `z_bsdf` (XML) if
    given and the shapes `extra` (XML) added, its relative file names made absolute so that it
    loads from `out`."""
    text = path.read_text().replace("</scene>", extra + "</scene>")
    if not hgs:
        text = text.replace('name="nlos_hidden_geometry_sampling" value="true"', 'name="nlos_hidden_geometry_sampling" value="false"')
    if z_bsdf is not None:
        z_mesh = '<string name="filename" value="meshes/hidden_geometry_Z.ply"/>'
        start = text.index(z_mesh)
        end = text.index("</shape>", start)
        text = text[:start] + z_mesh + z_bsdf + text[end:]
    text = text.replace('value="meshes/', f'value="{path.parent / "meshes"}/')
    out.write_text(text)
    return str(out)


def tal_example(out_dir: Path, example: str) -> str:
    """One of tal's example scenes (its `examples/render/*/` configurations), written as tal 0.21's
    generator writes a simultaneous confocal or exhaustive scan (tests/data/tal021, with the
    example's mesh, scan and histogram), 750 bins of 3 mm, unbounded depth:

    - `bunny_confocal`: `1-bunny-confocal`, the scene of the one published mitransient timing: the
      Stanford bunny as tal ships it (13,145 triangles, placed 1 m behind the relay wall in the OBJ
      itself), a confocal 128×128 scan from 1.8 m, hidden-geometry sampling off;
    - `bunny_exhaustive`: `bunny-exhaustive-2x2x64x64`, the bunny seen from 64×64 scan points lit
      from 2×2 laser points (tal renders one laser point at a time; here one simultaneous scan),
      hidden-geometry sampling off;
    - `plane_exhaustive`: `plane-exhaustive-16x16x16x16`, tal's 2 m plane 1 m behind the wall,
      16×16 scan points × 16×16 laser points from 1.5 m (a 196 MB film), hidden-geometry sampling
      on."""
    import gzip
    import re

    here = Path(__file__).resolve().parent
    if example.startswith("bunny"):
        mesh = out_dir / "tal_bunny-single-1m.obj"
        if not mesh.exists():
            mesh.write_bytes(gzip.decompress((here / "data" / "tal_bunny-single-1m.obj.gz").read_bytes()))
        depth, hgs, start = 0.0, "false", 1.8
    else:  # tal's wall-2m-z0.obj: a 2 m square at z = 0 facing -z (the relay wall), moved 1 m back
        mesh = out_dir / "tal_wall-2m-z0.obj"
        mesh.write_text("v 1 -1 0\nv -1 -1 0\nv 1 1 0\nv -1 1 0\nf 2 3 1\nf 2 4 3\n")
        depth, hgs, start = 1.0, "true", 1.5
    scan = {"bunny_confocal": ("confocal", 128, 0), "bunny_exhaustive": ("exhaustive", 64, 2),
            "plane_exhaustive": ("exhaustive", 16, 16)}[example]
    text = (here.parent / "tests" / "data" / "tal021" / f"{scan[0]}.xml").read_text()
    text = text.replace('value="meshes/z.obj"', f'value="{mesh}"')
    text = text.replace('<translate x="0.0" y="0.0" z="1.0"/>', f'<translate x="0.0" y="0.0" z="{depth}"/>')
    text = text.replace('name="nlos_hidden_geometry_sampling" value="true"', f'name="nlos_hidden_geometry_sampling" value="{hgs}"')
    if example == "bunny_exhaustive":
        text = text.replace('name="force_equal_illumination_scanning" value="true"',
                            'name="force_equal_illumination_scanning" value="false"')
    for key, value in (("width", scan[1]), ("height", scan[1]), ("temporal_bins", 750), ("bin_width_opl", 0.003),
                       ("start_opl", start), ("laser_scan_width", scan[2]), ("laser_scan_height", scan[2])):
        text = re.sub(rf'(name="{key}" value=")[^"]*(")', rf"\g<1>{value}\g<2>", text)
    out = out_dir / f"bench_tal_{example}.xml"
    out.write_text(text)
    return str(out)


# Seconds each timed render waits before it starts, so that the other renderer's threads have
# gone idle.
SETTLE_S = 0.2


def workloads(quick: bool):
    """name → (a function making the scene dict, variant); scenes are made only when run."""
    import nlos_rs
    from nlos_rs import scenes

    div = 16 if quick else 1
    data = Path(__file__).resolve().parent.parent / "tests" / "data"
    T = nlos_rs.Transform4f

    def z(spp, **kw):
        return scenes.z_nlos_1corner(spp=max(1, spp // div), **kw)

    def flat(**kw):
        d = z(4096, width=64, height=64, **kw)
        d["z"] = {"type": "obj", "filename": flat_letter_mesh(scenes.cache_dir() / "bench_flat_f.obj"),
                  "to_world": T().translate([0.0, 0.0, 1.0]), "bsdf": {"type": "diffuse", "reflectance": 0.7}}
        return d

    def big(**kw):
        d = z(1024, width=64, height=64, **kw)
        d["z"] = {"type": "obj", "filename": bumpy_sphere_mesh(scenes.cache_dir() / "bench_bumpy_200k.obj"),
                  "to_world": T().translate([0.0, 0.0, 1.0]), "bsdf": {"type": "diffuse", "reflectance": 0.8}}
        return d

    def hidden(d, shape):
        d["z"] = shape
        return d

    def plastic(d):
        d["z"]["bsdf"] = {"type": "plastic", "diffuse_reflectance": {"type": "rgb", "value": [0.5, 0.5, 0.5]}}
        return d

    def rough_z(d):
        d["z"]["bsdf"] = {"type": "roughplastic", "alpha": 0.2}
        return d

    def glass(d):
        d["z"]["bsdf"] = {"type": "dielectric"}
        return d

    def bsdf_sampling(d):
        d["integrator"]["nlos_hidden_geometry_sampling"] = False
        return d

    def cornell():
        from nlos_rs.mitsuba_compat import import_mitransient

        mi, _ = import_mitransient("llvm_ad_mono")
        c = mi.cornell_box()
        c["sensor"]["film"].update(width=32, height=32, rfilter={"type": "box"})
        c["sensor"]["sampler"]["sample_count"] = max(1, 1024 // div)
        return scenes.to_transient(c)

    return {
        "z_single": (lambda: z(4096, width=64, height=64), "mono"),
        "z_confocal": (lambda: z(4096, width=64, height=64, capture_type="confocal"), "mono"),
        # The exhaustive and T workloads take 8192 spp: at 1024, nlos_rs renders them in 20-40 ms,
        # too short to time its thread scaling.
        "z_exhaustive": (lambda: z(8192, width=8, height=8, capture_type="exhaustive"), "mono"),
        "flat_onesided": (flat, "mono"),
        "flat_onesided_confocal": (lambda: flat(capture_type="confocal"), "mono"),
        "mesh_200k": (big, "mono"),
        "mesh_200k_confocal": (lambda: big(capture_type="confocal"), "mono"),
        "t_two_corners": (lambda: scenes.t_nlos_2corner("small", width=32, height=32, spp=max(1, 8192 // div),
                                                        filter_bounces=4), "mono"),
        # The T at unbounded depth (no filter_bounces, as tal's generator writes it), confocal and
        # exhaustive: light subpaths run on between the secondary wall and the T.
        "t_two_corners_confocal": (lambda: scenes.t_nlos_2corner("small", width=32, height=32, spp=max(1, 8192 // div),
                                                                 capture_type="confocal"), "mono"),
        "t_two_corners_exhaustive": (lambda: scenes.t_nlos_2corner("small", width=8, height=8, spp=max(1, 8192 // div),
                                                                   capture_type="exhaustive"), "mono"),
        # The T as tal's generator and mitransient's plugin default it: hidden-geometry sampling off.
        "t_two_corners_bsdf": (lambda: bsdf_sampling(scenes.t_nlos_2corner("small", width=32, height=32,
                                                                           spp=max(1, 8192 // div))), "mono"),
        "t_two_corners_confocal_bsdf": (lambda: bsdf_sampling(scenes.t_nlos_2corner(
            "small", width=32, height=32, spp=max(1, 8192 // div), capture_type="confocal")), "mono"),
        "cornell_los": (cornell, "mono"),
        "one_pixel": (lambda: z(1 << 22, width=1, height=1), "mono"),
        "z_rgb": (lambda: z(4096, width=32, height=32), "rgb"),
        # mitransient's own example file: a perspective camera looks at the relay wall.
        "mitransient_camera_file": (lambda: (str(data / "mitransient" / "transient-nlos" / "nlos-z-simple.xml"),
                                             max(1, 4096 // div)), "mono"),
        # mitransient's Z in a room (walls around the hidden Z) and its Cornell box file (line of sight,
        # $res and $spp set here), and a confocal capture written by tal (unbounded depth).
        "mitransient_room_file": (lambda: (str(data / "mitransient" / "transient-nlos" / "nlos-z-room.xml"),
                                           max(1, 8192 // div)), "mono"),
        "mitransient_cbox_file": (lambda: (str(data / "mitransient" / "cornell-box" / "cbox_diffuse.xml"),
                                           max(1, 256 // div), {"res": 64}), "mono"),
        # mitransient's other line-of-sight examples: a floor under an area light (short paths, most
        # leave the open scene after a bounce or two) and the Cornell box on its phasor film.
        "mitransient_area_1light_file": (lambda: (str(data / "mitransient" / "angulararea-emitter" / "area_1light.xml"),
                                                  max(1, 256 // div), {"res": 64}), "mono"),
        "mitransient_cbox_freq_file": (lambda: (str(data / "mitransient" / "cornell-box" / "cbox_diffuse_freq.xml"),
                                                max(1, 256 // div), {"res": 64}), "mono"),
        # The rest of mitransient's line-of-sight examples: the Cornell box with two water boxes
        # (`cbox_mirror.xml`, smooth dielectrics) and the floor under an angular area light.
        "mitransient_cbox_mirror_file": (lambda: (str(data / "mitransient" / "cornell-box" / "cbox_mirror.xml"),
                                                  max(1, 256 // div), {"res": 64}), "mono"),
        "mitransient_angular_1light_file": (lambda: (str(data / "mitransient" / "angulararea-emitter" / "angular_1light.xml"),
                                                     max(1, 256 // div), {"res": 64}), "mono"),
        # Line of sight past the lanes' 64 triangles: the Cornell box with a 5,120-triangle icosphere
        # on its small box, and with an analytic sphere there (no triangle).
        "cbox_icosphere": (lambda: (cbox_with(scenes.cache_dir() / "bench_cbox_icosphere.xml",
                                              '<shape type="obj"><string name="filename" value="'
                                              + icosphere_mesh(scenes.cache_dir() / "bench_icosphere.obj")
                                              + '"/><ref id="white"/></shape>'),
                                    max(1, 256 // div), {"res": 64}), "mono"),
        "cbox_sphere": (lambda: (cbox_with(scenes.cache_dir() / "bench_cbox_sphere.xml",
                                           '<shape type="sphere"><point name="center" x="186" y="255" z="169"/>'
                                           '<float name="radius" value="90"/><ref id="white"/></shape>'),
                                 max(1, 256 // div), {"res": 64}), "mono"),
        # The Cornell box with a mirror small box and a gold large box (smooth conductors).
        "cbox_conductors": (lambda: (cbox_with(scenes.cache_dir() / "bench_cbox_conductors.xml", bsdfs={
            "smallbox": '<bsdf type="conductor"/>',
            "largebox": '<bsdf type="conductor"><string name="material" value="Au"/></bsdf>'}),
            max(1, 256 // div), {"res": 64}), "mono"),
        # Rough BSDFs (each lane evaluates and samples its own): the Cornell box with a rough
        # metal small box and a rough plastic large box, and the Z in rough plastic, confocal,
        # hidden-geometry sampling off.
        "cbox_rough": (lambda: (cbox_with(scenes.cache_dir() / "bench_cbox_rough.xml", bsdfs={
            "smallbox": '<bsdf type="roughconductor"><float name="alpha" value="0.2"/></bsdf>',
            "largebox": '<bsdf type="roughplastic"><float name="alpha" value="0.1"/></bsdf>'}),
            max(1, 256 // div), {"res": 64}), "mono"),
        # The same box with every surface but the light rough: all its lanes are rough ones.
        "cbox_all_rough": (lambda: (cbox_all_rough(scenes.cache_dir() / "bench_cbox_all_rough.xml"),
                                    max(1, 256 // div), {"res": 64}), "mono"),
        "z_roughplastic_confocal_bsdf": (lambda: bsdf_sampling(rough_z(z(4096, width=64, height=64,
                                                                         capture_type="confocal"))), "mono"),
        "tal_confocal_file": (lambda: (str(data / "tal021" / "confocal.xml"), max(1, (1 << 19) // div)), "mono"),
        # Hidden-geometry sampling off, the default of mitransient's plugin and of tal's generator.
        "z_confocal_bsdf": (lambda: bsdf_sampling(z(4096, width=64, height=64, capture_type="confocal")), "mono"),
        "mesh_200k_bsdf": (lambda: bsdf_sampling(big()), "mono"),
        "mesh_200k_confocal_bsdf": (lambda: bsdf_sampling(big(capture_type="confocal")), "mono"),
        "mitransient_camera_file_bsdf": (lambda: (scene_copy(data / "mitransient" / "transient-nlos" / "nlos-z-simple.xml",
                                                               scenes.cache_dir() / "bench_nlos-z-simple_hgs_off.xml"),
                                                  max(1, 4096 // div)), "mono"),
        # tal's own examples (tal_example): the bunny, confocal and exhaustive, and the plane.
        "tal_bunny_confocal_file": (lambda: (tal_example(scenes.cache_dir(), "bunny_confocal"), max(1, 256 // div)), "mono"),
        "tal_bunny_exhaustive_file": (lambda: (tal_example(scenes.cache_dir(), "bunny_exhaustive"), max(1, 256 // div)),
                                      "mono"),
        "tal_plane_exhaustive_file": (lambda: (tal_example(scenes.cache_dir(), "plane_exhaustive"), max(1, 256 // div)),
                                      "mono"),
        # mitransient's room with hidden-geometry sampling off: the walls surround the Z, so every
        # direction from the relay wall meets something and no cone turns a path down.
        # The room, hidden-geometry sampling off, with a 5,120-triangle icosphere beside the Z.
        "mitransient_room_icosphere_bsdf": (lambda: (scene_copy(
            data / "mitransient" / "transient-nlos" / "nlos-z-room.xml", scenes.cache_dir() / "bench_room_icosphere.xml",
            extra='<shape type="obj"><string name="filename" value="' + icosphere_mesh(
                scenes.cache_dir() / "bench_room_icosphere.obj", center=(0.5, -0.5, 2.4), radius=0.3) + '"/></shape>'),
            max(1, 8192 // div)), "mono"),
        "mitransient_room_file_bsdf": (lambda: (scene_copy(data / "mitransient" / "transient-nlos" / "nlos-z-room.xml",
                                                             scenes.cache_dir() / "bench_nlos-z-room_hgs_off.xml"),
                                                max(1, 8192 // div)), "mono"),
        # Other hidden objects: a disk of radius 0.3 m facing the wall at 0.8 m, albedo 0.5 (a
        # primitive of its own, not triangles), and the Z in smooth plastic, both confocal.
        "disk_confocal": (lambda: hidden(z(4096, width=64, height=64, capture_type="confocal"), {
            "type": "disk", "to_world": T().translate([0.2, 0.1, 0.8]).scale([0.3, 0.3, 0.3]).rotate([1, 0, 0], 180),
            "bsdf": {"type": "diffuse", "reflectance": 0.5}}), "mono"),
        "z_plastic_confocal": (lambda: plastic(z(4096, width=64, height=64, capture_type="confocal")), "mono"),
        # The Z in smooth glass: behind one corner (its capture is zero: under hidden-geometry
        # sampling every vertex past the first lies on the glass, which connects to nothing), and
        # in mitransient's room, where light reaches the walls through it (hidden-geometry sampling
        # on and off).
        "z_glass": (lambda: glass(z(4096, width=64, height=64)), "mono"),
        "mitransient_room_glass": (lambda: (scene_copy(data / "mitransient" / "transient-nlos" / "nlos-z-room.xml",
                                                         scenes.cache_dir() / "bench_nlos-z-room_glass.xml", hgs=True,
                                                         z_bsdf='<bsdf type="dielectric"/>'),
                                            max(1, 8192 // div)), "mono"),
        "mitransient_room_glass_bsdf": (lambda: (scene_copy(data / "mitransient" / "transient-nlos" / "nlos-z-room.xml",
                                                              scenes.cache_dir() / "bench_nlos-z-room_glass_hgs_off.xml",
                                                              z_bsdf='<bsdf type="dielectric"/>'),
                                                 max(1, 8192 // div)), "mono"),
    }


def cpu_name() -> str:
    """The CPU's model name and widest SIMD extension (mitransient's LLVM backend runs sixteen lanes
    wide with AVX-512 and eight with AVX2, and the ratios move with it), from /proc/cpuinfo."""
    try:
        info = Path("/proc/cpuinfo").read_text()
    except OSError:
        return platform.processor() or platform.machine()
    model = next((line.split(":", 1)[1].strip() for line in info.splitlines() if line.startswith("model name")), "")
    flags = next((set(line.split(":", 1)[1].split()) for line in info.splitlines() if line.startswith("flags")), set())
    simd = "AVX-512" if "avx512f" in flags else "AVX2" if "avx2" in flags else "no AVX2"
    return f"{model or platform.machine()} ({simd})"


def spp_of(d) -> int:
    for v in d.values():
        if isinstance(v, dict):
            if v.get("type") == "independent":
                return v["sample_count"]
            found = spp_of(v)
            if found:
                return found
    return 0


def pixels(d) -> int:
    for v in d.values():
        if isinstance(v, dict):
            if v.get("type") == "transient_hdr_film":
                return v["width"] * v["height"]
            found = pixels(v)
            if found:
                return found
    return 0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--only", nargs="*")
    ap.add_argument("--quick", action="store_true", help="16x fewer samples (a smoke run)")
    ap.add_argument("--one", help=argparse.SUPPRESS)  # internal: run one workload in this process
    args = ap.parse_args()
    if args.one is None:
        # Each workload in a fresh process: mitransient registers its plugins for one Mitsuba
        # variant only, and no run's caches or pools help the next.
        import subprocess
        import sys

        names = args.only or list(workloads(args.quick))
        rows = []
        for name in names:
            cmd = [sys.executable, __file__, "--one", name, "--threads", str(args.threads), "--repeats", str(args.repeats)]
            out = subprocess.run(cmd + (["--quick"] if args.quick else []), capture_output=True, text=True).stdout
            row = [line for line in out.splitlines() if line.startswith("ROW ")]
            if row:
                rows.append(row[0][4:].split("\t"))
                # The row's own line (mitransient may print warnings before it, even on the same line).
                print(next(line[line.index(name):] for line in out.splitlines() if name + " " in line), flush=True)
        import nlos_rs

        print(f"\n{cpu_name()}, {os.cpu_count()} cores, {args.threads} threads, "
              f"nlos_rs {nlos_rs.__version__}, mitransient 1.3.1 (llvm_ad), best of {args.repeats}\n")
        print("| workload | paths | nlos_rs (M paths/s) | mitransient (M paths/s) | ratio | 1→2 threads, best | total | paired median "
              "| 2 renders at once, best | paired median | cores busy |")
        print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
        for name, paths, a, b, r, sc, total, paired, apart_best, apart_paired, busy in rows:
            print(f"| {name} | {float(paths) / 1e6:.1f} M | {float(a):.2f} | {float(b):.2f} | **{float(r):.2f}×** | {float(sc):.2f}× "
                  f"| {float(total):.2f}× | {float(paired):.2f}× | {float(apart_best):.2f}× | {float(apart_paired):.2f}× "
                  f"| {float(busy):.2f} |")
        return

    import nlos_rs
    from nlos_rs.mitsuba_compat import import_mitransient, to_mitsuba

    rows = []
    for name, (make, variant) in workloads(args.quick).items():
        if name != args.one:
            continue
        mi, mitr = import_mitransient(f"llvm_ad_{variant}")
        d = make()
        import drjit as dr

        dr.set_thread_count(args.threads)
        if isinstance(d, tuple):  # a scene file, the spp to render it at and its $parameters
            path, spp, params = (*d, {})[:3]
            ours_scene = nlos_rs.load_file(path, **params)
            npix = ours_scene.film_size[0] * ours_scene.film_size[1]
        else:
            spp, npix = spp_of(d), pixels(d)
            ours_scene = nlos_rs.load_dict(d)
        paths = spp * npix

        def ours(threads=args.threads) -> float:
            return ours_timed(threads)[0]

        def ours_timed(threads: int) -> tuple[float, float]:
            """Wall time and process CPU time of one render."""
            c0, t0 = time.process_time(), time.perf_counter()
            nlos_rs.render(ours_scene, spp=spp, threads=threads, progress=False, variant=variant)
            return time.perf_counter() - t0, time.process_time() - c0

        def theirs() -> float:
            t0 = time.perf_counter()
            steady, transient = mi.render(theirs_scene, spp=spp)
            dr.eval(steady, transient)
            dr.sync_thread()
            return time.perf_counter() - t0

        # Scaling: 9 renders at 1 and N threads, alternately (on this shared machine the same
        # render in one process takes anywhere from 0.27 to 0.48 s from run to run), before
        # mitransient loads or renders anything in this process (its worker threads go on
        # spinning after a render and take cores from ours).
        # At least 9 pairs, and pairs for at least 4 s: on this VM both cores can run slower for a
        # second or so at a time, which 9 pairs of the T's 35 ms renders fall inside whole.
        def apart() -> float:
            """Wall time of `args.threads` 1-thread renders at once, each on a Python thread of its
            own (a render releases the GIL): nothing shared, nothing to wait for."""
            workers = [threading.Thread(target=ours, args=(1,)) for _ in range(args.threads)]
            t0 = time.perf_counter()
            for w in workers:
                w.start()
            for w in workers:
                w.join()
            return time.perf_counter() - t0

        # The machine's own ceiling beside each pair: N independent 1-thread renders at once do
        # N renders' work with no sharing and no waiting, so N·t(1 render) / t(N at once) is the
        # most any split of one render over N threads can reach at that moment (on this VM it
        # reads anywhere from 1.3x to 2.0x from one minute to the next).
        ours()
        apart()
        one, many, ceiling = [], [], []
        started = time.perf_counter()
        while len(one) < max(9, args.repeats) or time.perf_counter() - started < 4.0:
            one.append(ours(1))
            many.append(ours_timed(args.threads))
            ceiling.append(apart())
        wall, cpu = min(many)
        scaling, busy = min(one) / wall, cpu / wall
        scaling_total = sum(one) / sum(w for w, _ in many)
        scaling_paired = statistics.median(a / w for a, (w, _) in zip(one, many))
        apart_best = args.threads * min(one) / min(ceiling)
        apart_paired = statistics.median(args.threads * a / c for a, c in zip(one, ceiling))
        theirs_scene = mi.load_file(path, **params) if isinstance(d, tuple) else mi.load_dict(to_mitsuba(d))
        theirs()
        to, tt = [], []
        for _ in range(args.repeats):
            # Each render after a pause: mitransient's worker threads spin on for a while after
            # its render returns and would take the cores from ours (short renders lost up to a
            # fifth of their speed), and the pause before its own render is the same.
            time.sleep(SETTLE_S)
            to.append(ours())
            time.sleep(SETTLE_S)
            tt.append(theirs())
        mo, mt = min(to), min(tt)
        rows.append((name, paths, paths / mo / 1e6, paths / mt / 1e6, mt / mo, scaling, scaling_total, scaling_paired,
                     apart_best, apart_paired, busy))
        print(f"{name:16s} {paths / 1e6:8.1f} M paths  nlos_rs {paths / mo / 1e6:7.2f}  mitransient {paths / mt / 1e6:7.2f} "
              f"M paths/s  ratio {mt / mo:5.2f}x  scaling 1->{args.threads} threads {scaling:4.2f}x (total {scaling_total:4.2f}x, paired median {scaling_paired:4.2f}x)  "
              f"independent renders {apart_best:4.2f}x (paired median {apart_paired:4.2f}x)  cores busy {busy:4.2f}",
              flush=True)

    for row in rows:
        print("ROW " + "\t".join(str(x) for x in row))


if __name__ == "__main__":
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    main()

"""Scenes written by tal's own generator (y-tal 0.20, ``tal.render.mitsuba3_transient_nlos.get_scene_xml``)
from its default configuration plus overrides, and the laser aims tal sets for them.

tal renders a single capture with the laser aimed at ``laser_lookat`` (default: the centre pixel),
and a confocal or exhaustive scan as one render per laser point (a 1x1 film with
``original_film_width/height`` for confocal), aiming the laser at each point in turn.
"""

from __future__ import annotations

import os
from pathlib import Path

import yaml

import nlos_rs


def config(z_material=None, **overrides) -> dict:
    """tal's defaults with our Z mesh 1 m behind the relay wall; `z_material` is one of tal's
    built-in materials for the Z (default white), e.g. {"id": "copper", "alpha": "0.3"}."""
    import tal

    with open(os.path.join(os.path.dirname(tal.__file__), "render", "scene_defaults.yaml")) as f:
        c = yaml.safe_load(f)
    c["mitsuba_variant"] = "llvm_ad_mono"
    c["geometry"] = [
        {"name": "Z", "mesh": {"type": "obj", "filename": nlos_rs.scenes.z_mesh_path()}, "displacement_z": 1.0,
         "material": z_material or {"id": "white"}},
        {"name": "relay_wall", "mesh": {"type": "rectangle"}, "material": {"id": "white"}},
    ]
    c.update(overrides)
    return c


def nlos_xml(tmp_path: Path, **overrides) -> Path:
    """The NLOS scene XML tal writes for its defaults + ``overrides``."""
    from tal.render.mitsuba3_transient_nlos import get_scene_xml

    _, _, xml = get_scene_xml(config(**overrides), random_seed=0)
    path = tmp_path / "nlos_scene.xml"
    path.write_text(xml)
    return path


def laser_lookats(c: dict):
    """(laser pixel) aims of tal's render loop for a configuration (``__write_metadata_and_get_laser_lookats``)."""
    w, h = c["sensor_width"], c["sensor_height"]
    if c["scan_type"] == "single":
        return [(c["laser_lookat_x"] or w / 2, c["laser_lookat_y"] or h / 2)]
    lw, lh = c["laser_width"], c["laser_height"]
    return [((x + 0.5) / lw * w, (y + 0.5) / lh * h) for y in range(lh) for x in range(lw)]

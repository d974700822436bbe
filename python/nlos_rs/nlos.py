"""Aiming the laser, as ``mitransient.nlos`` does.

mitransient's functions take ``(target, relay_wall, emitter)`` shape and emitter objects; an nlos_rs
scene owns exactly one relay wall and one laser, so pass the :class:`nlos_rs.Scene` for both (or
pass it once: ``focus_emitter_at_relay_wall_pixel(pixel, scene)``).
"""

from __future__ import annotations

from typing import Optional, Sequence

from ._core import Scene
from .values import numbers


def _scene(relay_wall: Scene, emitter: Optional[Scene]) -> Scene:
    if not isinstance(relay_wall, Scene) or (emitter is not None and emitter is not relay_wall):
        raise TypeError("pass the nlos_rs.Scene as relay_wall (and as emitter, or leave emitter out)")
    return relay_wall


def focus_emitter_at_relay_wall_3dpoint(target: Sequence[float], relay_wall: Scene, emitter: Optional[Scene] = None) -> None:
    """Aim the laser, from its current origin, at a 3D point (up = +y)."""
    x, y, z = numbers(target, 3, "target")
    _scene(relay_wall, emitter).focus_laser_at(x, y, z)


def focus_emitter_at_relay_wall_uv(uv: Sequence[float], relay_wall: Scene, emitter: Optional[Scene] = None) -> None:
    """Aim the laser at the relay-wall point of ``uv`` in [0, 1]^2."""
    scene = _scene(relay_wall, emitter)
    u, v = numbers(uv, 2, "uv")
    p, _ = scene.relay_wall_point(u, v)
    scene.focus_laser_at(*p)


def focus_emitter_at_relay_wall_pixel(pixel: Sequence[float], relay_wall: Scene, emitter: Optional[Scene] = None) -> None:
    """Aim the laser at a scan-grid pixel: uv = pixel / film size (no +0.5, as in mitransient,
    so ``(W/2, H/2)`` is the wall centre and ``(x + 0.5, y + 0.5)`` is pixel (x, y)'s centre)."""
    scene = _scene(relay_wall, emitter)
    w, h = scene.scan_grid
    x, y = numbers(pixel, 2, "pixel")
    focus_emitter_at_relay_wall_uv((x / w, y / h), scene)

"""nlos_rs against mitransient 1.3.1, live, on the Z scene (single, confocal, exhaustive).

Both renderers produce 8 independent replicates (different seeds); quantities (per-pixel totals
and the pixel-summed time profile in 6-bin groups) are compared with Welch's t at a Šidák-corrected
level (tests/python/stats.py). Grids are powers of two: mitransient mis-targets some scan points
of other sizes (spec §7 item 6).
"""

import numpy as np
import pytest

import nlos_rs
from nlos_rs.mitsuba_compat import render_mitransient
from stats import agreement, rebin

REPS = 8


def replicates(d, spp):
    ours = [nlos_rs.render(d, spp=spp, seed=k, progress=False)[1] for k in range(REPS)]
    theirs = [render_mitransient(d, spp=spp, seed=k)[1] for k in range(REPS)]
    return np.array(ours), np.array(theirs)


def features(t: np.ndarray) -> np.ndarray:
    """(reps, H, W, [LH, LW,] T, 1) → per-scan-point totals and a coarse time profile."""
    t = t[..., 0]
    totals = t.sum(-1).reshape(len(t), -1)
    profile = rebin(t.reshape(len(t), -1, t.shape[-1]).sum(1), 6, -1)
    return np.concatenate([totals, profile], axis=1)


@pytest.mark.peer
@pytest.mark.parametrize(
    "capture, size, spp",
    [("single", 8, 2048), ("confocal", 8, 2048), ("exhaustive", 4, 512)],
)
def test_z_scene_matches_mitransient(peer, capture, size, spp):
    d = nlos_rs.scenes.z_nlos_1corner(width=size, height=size, spp=spp, capture_type=capture)
    ours, theirs = replicates(d, spp)
    assert ours.shape == theirs.shape, (ours.shape, theirs.shape)
    res = agreement(features(ours), features(theirs))
    total_ratio = ours.sum() / theirs.sum()
    print(f"\n{capture}: {res}, total ratio {total_ratio:.5f}")
    assert res["agree"], res
    # The signal is really there and both see the same amount of it.
    assert theirs.sum() > 0 and abs(total_ratio - 1) < 0.02


@pytest.mark.peer
def test_exhaustive_steady_is_an_image(peer):
    """mitransient's exhaustive steady output is mean(transient, axis=-1) (spec §7 item 7); ours is
    the (H, W, C) image: the laser-averaged time integral of the transient."""
    d = nlos_rs.scenes.z_nlos_1corner(width=4, height=4, spp=256, capture_type="exhaustive")
    steady, transient = nlos_rs.render(d, progress=False)
    assert steady.shape == (4, 4, 1) and transient.shape == (4, 4, 4, 4, 300, 1)
    np.testing.assert_allclose(steady[..., 0], transient[..., 0].sum(-1).mean((2, 3)), rtol=2e-3)
    their_steady, _, _ = render_mitransient(d, spp=64)
    assert their_steady.shape == (4, 4, 4, 4, 300)

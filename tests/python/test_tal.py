"""Hand-off to tal 0.20: files read back by tal.io.read_capture field by field, and tal's
reconstructions (bp, fbp, pf_dev) put the Z where it is."""

import numpy as np
import pytest

import tal  # y-tal 0.20, a test dependency
from tal.enums import GridFormat, HFormat, VolumeFormat

import nlos_rs

tal.set_log_level(tal.LogLevel.WARNING)

Z_PLANE, Z_HALF_WIDTH, Z_HALF_HEIGHT = 1.0, 0.4, 0.5


def render(capture, size=8, **kw):
    d = nlos_rs.scenes.z_nlos_1corner(width=size, height=size, spp=kw.pop("spp", 64), capture_type=capture,
                                      start_opl=1.8, temporal_bins=300, **kw)
    scene = nlos_rs.load_dict(d)
    return scene, nlos_rs.render(scene, progress=False, variant="rgb")[1]


@pytest.mark.parametrize("capture", ["single", "confocal", "exhaustive"])
def test_capture_file_round_trip(tmp_path, capture):
    scene, t = render(capture, size=4 if capture == "exhaustive" else 6)
    path = tmp_path / "c.hdf5"
    nlos_rs.io.write_capture(path, scene, t, compression_level=4)
    data = tal.io.read_capture(str(path))
    w, h = scene.film_size
    if capture == "exhaustive":
        assert data.H_format == HFormat.T_Lx_Ly_Sx_Sy
        expect = np.transpose(t.sum(-1), (4, 3, 2, 1, 0))
    else:
        assert data.H_format == HFormat.T_Sx_Sy
        expect = np.transpose(t.sum(-1), (2, 1, 0))
    assert data.H.dtype == np.float32 and data.H.shape == expect.shape
    np.testing.assert_array_equal(data.H, expect.astype(np.float32))
    assert data.sensor_grid_format == GridFormat.X_Y_3 and data.laser_grid_format == GridFormat.X_Y_3
    xs = -1 + (2 * np.arange(w) + 1) / w
    ys = -1 + (2 * np.arange(h) + 1) / h
    np.testing.assert_allclose(data.sensor_grid_xyz[..., 0], np.broadcast_to(xs[:, None], (w, h)), atol=1e-6)
    np.testing.assert_allclose(data.sensor_grid_xyz[..., 1], np.broadcast_to(ys[None, :], (w, h)), atol=1e-6)
    np.testing.assert_allclose(data.sensor_grid_xyz[..., 2], 0, atol=1e-6)
    np.testing.assert_allclose(data.sensor_grid_normals, np.broadcast_to([0, 0, 1], (w, h, 3)), atol=1e-6)
    np.testing.assert_allclose(data.sensor_xyz, [-0.5, 0, 0.25], atol=1e-6)
    np.testing.assert_allclose(data.laser_xyz, [-0.5, 0, 0.25], atol=1e-6)
    if capture == "single":
        assert data.laser_grid_xyz.shape == (1, 1, 3)
        np.testing.assert_allclose(data.laser_grid_xyz[0, 0], [0, 0, 0], atol=1e-5)  # aimed at the wall centre
    else:
        np.testing.assert_allclose(data.laser_grid_xyz, data.sensor_grid_xyz, atol=1e-6)
        assert data.is_confocal() == (capture == "confocal")
    np.testing.assert_allclose(data.laser_grid_normals.reshape(-1, 3), np.broadcast_to([0, 0, 1], (data.laser_grid_normals.size // 3, 3)), atol=1e-6)
    assert data.delta_t == pytest.approx(0.006) and data.t_start == pytest.approx(1.8)
    assert not data.t_accounts_first_and_last_bounces
    assert data.volume_format in (None, VolumeFormat.UNKNOWN)  # written empty, as tal does
    assert data.scene_info["renderer"] == "nlos_rs" and data.scene_info["capture_type"] == capture


def test_to_tal_and_zero_start_padding(tmp_path):
    scene, t = render("single")
    data = nlos_rs.to_tal(scene, t, zero_t_start=True)
    assert isinstance(data, tal.io.NLOSCaptureData) and data.t_start == 0.0
    assert data.H.shape == (600, 8, 8) and not data.H[:300].any()
    np.testing.assert_array_equal(data.H[300:], np.transpose(t.sum(-1), (2, 1, 0)))
    tal.io.write_capture(str(tmp_path / "via_tal.hdf5"), data)  # tal's own writer accepts it
    back = tal.io.read_capture(str(tmp_path / "via_tal.hdf5"))
    np.testing.assert_array_equal(back.H, data.H)
    with pytest.raises(ValueError, match="whole number of bins"):
        nlos_rs.to_tal(nlos_rs.load_dict(nlos_rs.scenes.z_nlos_1corner(width=2, height=2, spp=4)), np.zeros((2, 2, 300, 1)), zero_t_start=True)
    with pytest.raises(ValueError, match="does not match"):
        nlos_rs.io.write_capture(tmp_path / "x.hdf5", scene, t[:, :4])


@pytest.fixture(scope="module")
def z_capture():
    scene, t = render("single", size=16, spp=512)
    return scene, t


def peak(rec, vol):
    i = np.unravel_index(np.argmax(np.abs(rec)), np.abs(rec).shape)
    return vol[i]


def assert_on_the_z(p, tol_z):
    print(f"\npeak at {np.round(p, 3)}")
    assert abs(p[2] - Z_PLANE) <= tol_z, p
    assert abs(p[0]) <= Z_HALF_WIDTH + 0.05 and abs(p[1]) <= Z_HALF_HEIGHT + 0.05, p


def test_backprojection_finds_the_z(z_capture):
    data = nlos_rs.to_tal(*z_capture)
    vol = tal.reconstruct.get_volume_min_max_resolution(np.array([-1, -1, 0.5]), np.array([1, 1, 1.5]), 0.05)
    rec = tal.reconstruct.bp.solve(data, volume_xyz=vol, progress=False)
    assert rec.shape == vol.shape[:-1]
    assert_on_the_z(peak(rec, vol), 0.05 + 1e-9)


def test_filtered_backprojection_finds_the_z(z_capture):
    data = nlos_rs.to_tal(*z_capture)
    vol = tal.reconstruct.get_volume_min_max_resolution(np.array([-1, -1, 0.5]), np.array([1, 1, 1.5]), 0.05)
    rec = tal.reconstruct.fbp.solve(data, wl_mean=0.12, wl_sigma=0.12, volume_xyz=vol, progress=False)
    assert_on_the_z(peak(rec, vol), 0.05 + 1e-9)


def test_phasor_fields_find_the_z(z_capture):
    """pf_dev with tal 0.20's workarounds: H padded to t_start = 0, nt given, one depth slice per call."""
    data = nlos_rs.to_tal(*z_capture, zero_t_start=True)
    depths = [0.8, 0.9, 1.0, 1.1, 1.2]
    slices = [tal.reconstruct.pf_dev.solve(data, wl_mean=0.12, wl_sigma=0.12, nt=data.H.shape[0], progress=False,
                                           volume_xyz=tal.reconstruct.get_volume_project_rw(data, [z]))[..., 0] for z in depths]
    rec = np.stack(slices, axis=-1)
    vol = tal.reconstruct.get_volume_project_rw(data, depths)
    assert_on_the_z(peak(rec, vol), 0.1 + 1e-9)

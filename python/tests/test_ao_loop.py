"""The camera inside a toy Shack-Hartmann loop written with numpy only: the measured noise map
of the bundled sCMOS darks read through `Readout("scmos-map")`, spots centroided by a
thresholded centre of gravity, tip-tilt closed by an integrator."""

import numpy as np

import detnoise

N_SUB, N_PX = 8, 8  # 8 x 8 sub-apertures of 8 x 8 px: a 64 x 64 px frame, the map's size
SIGNAL_PHOTONS = 300.0
SPOT_SIGMA_PX = 1.0


def spots_e(shift_px):
    """Expected photo-electrons of every sub-aperture's spot displaced by (x, y) px, (k, n, n),
    pixel-integrated Gaussian (the integral of each pixel by a fine sub-grid)."""
    fine = 8
    u = (np.arange(N_PX * fine) + 0.5) / fine - N_PX / 2.0
    gx = np.exp(-0.5 * ((u - shift_px[0]) / SPOT_SIGMA_PX) ** 2)
    gy = np.exp(-0.5 * ((u - shift_px[1]) / SPOT_SIGMA_PX) ** 2)
    spot = np.outer(gy, gx).reshape(N_PX, fine, N_PX, fine).sum(axis=(1, 3))
    spot *= SIGNAL_PHOTONS / spot.sum()
    return np.broadcast_to(spot, (N_SUB * N_SUB, N_PX, N_PX))


def to_frame(subaps):
    """(k, n, n) sub-apertures -> the (N_SUB n, N_SUB n) frame, and back (`from_frame`)."""
    return subaps.reshape(N_SUB, N_SUB, N_PX, N_PX).transpose(0, 2, 1, 3).reshape(64, 64)


def from_frame(frame):
    return frame.reshape(N_SUB, N_PX, N_SUB, N_PX).transpose(0, 2, 1, 3).reshape(-1, N_PX, N_PX)


def centroids_px(images, threshold_e):
    """Thresholded centre of gravity of each sub-aperture, px from its centre: (k, 2)."""
    w = np.clip(images - threshold_e, 0.0, None)
    u = np.arange(N_PX) - (N_PX - 1) / 2.0
    total = w.sum(axis=(1, 2))
    x = (w.sum(axis=1) * u).sum(axis=1) / total
    y = (w.sum(axis=2) * u).sum(axis=1) / total
    return np.stack([x, y], axis=1)


def run_loop(camera, threshold_e, frames, tilt_px, gain=0.5):
    """Close tip-tilt on a static tilt; returns the residual tilt (px) of every frame."""
    correction = np.zeros(2)
    residuals = []
    for _ in range(frames):
        residual = tilt_px - correction
        residuals.append(residual.copy())
        frame = camera.read(to_frame(spots_e(residual)))  # the camera's next frame
        slopes = centroids_px(from_frame(frame), threshold_e)
        correction += gain * slopes.mean(axis=0)
    return np.array(residuals)


def test_a_closed_loop_with_the_measured_camera_converges_to_zero_tilt(data):
    rms_e = detnoise.dark_maps(data / "scmos-darks-64x64.fits", gain_e_per_adu=0.25).rms_e
    threshold_e = 3.0 * np.median(rms_e)
    camera = detnoise.Readout("scmos-map", map_e=rms_e, seed=2015)
    tilt = np.array([1.5, -1.0])
    residuals = run_loop(camera, threshold_e, frames=60, tilt_px=tilt)
    assert np.allclose(residuals[0], tilt)
    # An integrator of gain 0.5 halves the error each frame: after 20 frames only the
    # measurement noise is left, r' = r / 2 - noise / 2, an AR(1) process of coefficient 1/2.
    # Its mean over the last 40 frames is 0 within 4 standard errors; the SE of the mean of
    # an AR(1) of coefficient phi is sd sqrt((1 + phi) / (1 - phi) / n) = sd sqrt(3 / n).
    settled = residuals[20:]
    se = settled.std(axis=0, ddof=1) * np.sqrt(3.0 / len(settled))
    assert np.all(np.abs(settled.mean(axis=0)) < 4 * se + 1e-12), (settled.mean(axis=0), se)
    assert np.all(np.abs(settled) < 0.1)
    # The camera is a real noise source: the residual moves from frame to frame...
    assert np.all(settled.std(axis=0) > 0)
    # ...and the same seed replays the same loop.
    again = detnoise.Readout("scmos-map", map_e=rms_e, seed=2015)
    np.testing.assert_array_equal(run_loop(again, threshold_e, 60, tilt), residuals)

"""SPECULA's CCD with its noise drawn by a `detnoise.Readout`: `DetnoiseCCD`.

`DetnoiseCCD` is SPECULA's `CCD` (same inputs ``in_i``, outputs ``out_pixels`` and
``integrated_i``, same integration, binning and quantum efficiency) whose noise step is one read
of the readout model: photon noise, per-pixel read noise, EM-register excess noise, dark signal,
CIC, telegraph pixels, row/column noise, whatever the model has. SPECULA adds no noise of its
own. The pixels are e- referred to the input (an EMCCD's output divided by its mean gain, as
SPECULA's CCD leaves them), with no bias and no quantisation to adu.

In a SPECULA parameter file, list this module in ``main``'s ``add_modules`` and replace
``class: 'CCD'`` by ``class: 'DetnoiseCCD'`` (docs/ao-specula.md).
"""

import math
import sys

import numpy as np

import detnoise
from specula import cpuArray
from specula.data_objects.simul_params import SimulParams
from specula.processing_objects.ccd import CCD

__all__ = ["DetnoiseCCD"]

#: Models that read each frame through a random window of a per-pixel map (noise map, dark
#: frames, camera model): a fixed camera needs the map exactly the frame's size.
WINDOWED_MODELS = ("scmos-map", "scmos-rts", "scmos-correlated", "scmos-frames", "camera")


class DetnoiseCCD(CCD):
    """SPECULA's CCD whose noise is one read of a `detnoise.Readout` per frame.

    Parameters
    ----------
    simul_params : SimulParams
        Simulation parameters (the loop's time step).
    size : list of int [pixels]
        Detector size [nx, ny]; square (``Readout.read`` reads square frames).
    dt : float [s]
        Integration time, a multiple of the time step.
    bandw : float [nm]
        Optical bandwidth (SPECULA's CCD multiplies the intensity by it).
    readout : str or detnoise.Readout
        A model name of ``detnoise.MODEL_NAMES`` (``'scmos-map'``, ``'emccd-stochastic'``,
        ``'camera'`` ...) built with ``readout_params``, or a built ``detnoise.Readout``.
    readout_params : dict, optional
        The model's parameters (``detnoise.MODEL_PARAMS``: ``map_e`` [e- rms map or its file],
        ``em_gain`` [e-/e-], ``emccd_read_noise_e`` [e-], ``camera`` [folder] ...). With
        ``'camera'``, ``exposure_s`` defaults to ``dt``.
    seed : int [1], optional
        Seed of the readout built from a name (default 0); frame f of the run is frame f of a
        camera of that seed. Not with a built Readout (it has its own).
    binning : int [1], optional
        SPECULA's pixel binning (it averages the binned pixels).
    quantum_eff : float [1], optional
        Quantum efficiency times throughput, applied before the read.
    background_level : float [e-/pixel/frame], optional
        Background added to the expected image before the read (its shot noise drawn by the
        readout); not taken off.
    photon_noise : bool, optional
        True (default): shot noise is drawn by the readout. False: the expected image is rounded
        to whole photo-electrons and read without shot noise.
    start_time : float [s], optional
        Time to start integrating.
    """

    def __init__(
        self,
        simul_params: SimulParams,
        size: list,
        dt: float,
        bandw: float,
        readout,
        readout_params: dict = None,
        seed: int = None,
        binning: int = 1,
        quantum_eff: float = 1.0,
        background_level: float = 0.0,
        photon_noise: bool = True,
        start_time: float = 0,
        target_device_idx: int = None,
        precision: int = None,
    ):
        n = _frame_side(size, binning)
        if not (math.isfinite(background_level) and background_level >= 0):
            raise ValueError(
                f"DetnoiseCCD: background_level is {background_level}: expected e- per pixel "
                f"per frame, finite and >= 0"
            )
        # SPECULA's own noise flags stay off: the readout draws every noise, once.
        super().__init__(
            simul_params,
            size=size,
            dt=dt,
            bandw=bandw,
            binning=binning,
            quantum_eff=quantum_eff,
            start_time=start_time,
            target_device_idx=target_device_idx,
            precision=precision,
        )
        self._readout = _build_readout(readout, readout_params, seed, dt)
        _check_frame(self._readout, n, size, binning)
        self._read_photon_noise = bool(photon_noise)
        self._background_e = float(background_level)

    @property
    def readout(self):
        """The `detnoise.Readout` reading the frames (its ``frame`` is the next frame's index)."""
        return self._readout

    def setup(self):
        super().setup()
        shape = self.local_inputs["in_i"].i.shape
        if shape != self._integrated_i.i.shape:
            raise ValueError(
                f"DetnoiseCCD {self.name}: input in_i is {shape[1]}x{shape[0]} px but size is "
                f"{self._integrated_i.i.shape[1]}x{self._integrated_i.i.shape[0]}: set size to "
                f"the wavefront sensor's output"
            )

    def apply_noise(self):
        pixels = self._pixels.pixels
        # FFT convolutions (the SH's spot kernels) can leave values a hair below zero.
        expected_e = np.clip(cpuArray(pixels).astype(np.float64) + self._background_e, 0.0, None)
        if not self._read_photon_noise:
            expected_e = np.rint(expected_e)
        try:
            frame_e = self._readout.read(expected_e, photon_noise=self._read_photon_noise)
        except ValueError as e:
            raise ValueError(f"DetnoiseCCD {self.name}: reading the frame: {e}") from e
        pixels[:] = self.to_xp(frame_e, dtype=self.dtype)

    def get_resolved_seed(self):
        return self._readout.seed


def _frame_side(size, binning):
    """The side of the square frame read out, px; refuses a non-square or unbinnable size."""
    try:
        nx, ny = (int(v) for v in size)
    except (TypeError, ValueError):
        raise ValueError(f"DetnoiseCCD: size is {size!r}: expected [nx, ny] pixels") from None
    if not (isinstance(binning, int) and binning >= 1):
        raise ValueError(f"DetnoiseCCD: binning is {binning!r}: expected a whole number >= 1")
    if nx != ny or nx < 1:
        raise ValueError(
            f"DetnoiseCCD: size is {nx}x{ny} px: the readout reads square frames, give nx = ny >= 1"
        )
    if nx % binning:
        raise ValueError(f"DetnoiseCCD: size {nx} px is not a multiple of binning {binning}")
    return nx // binning


def _build_readout(readout, params, seed, dt):
    """The Readout of a model name and its parameters, or the Readout given."""
    if isinstance(readout, detnoise.Readout):
        if params or seed is not None:
            raise ValueError(
                "DetnoiseCCD: readout is a built detnoise.Readout: give its parameters and seed "
                "to Readout, not readout_params or seed"
            )
        return readout
    if not isinstance(readout, str):
        raise ValueError(
            f"DetnoiseCCD: readout is {readout!r}: expected a model name of "
            f"detnoise.MODEL_NAMES or a detnoise.Readout"
        )
    if params is None:
        params = {}
    if not isinstance(params, dict):
        raise ValueError(f"DetnoiseCCD: readout_params is {params!r}: expected a dict")
    params = dict(params)
    if readout == "camera" and "exposure_s" not in params and "frame_rate_hz" not in params:
        params["exposure_s"] = dt  # the camera integrates as long as this CCD
    try:
        return detnoise.Readout(readout, seed=0 if seed is None else seed, **params)
    except (TypeError, ValueError) as e:
        raise ValueError(f"DetnoiseCCD: readout {readout!r}: {e}") from e


def _check_frame(readout, n, size, binning):
    """Refuses a readout that cannot read the n x n frame, or whose map is larger than it.

    A model with a map reads a frame smaller than its map through a different random window
    every frame: a camera whose noisy pixels move, not the fixed camera of the map. Probe reads
    with an explicit seed leave the readout's frame counter alone.
    """
    frame = f"{n}x{n} px frame (size {list(size)}, binning {binning})"
    try:
        readout.read(np.zeros((n, n)), seed=0, photon_noise=False)
    except (ValueError, OSError) as e:  # OSError: a map file that cannot be read
        raise ValueError(
            f"DetnoiseCCD: readout {readout.model_name!r} cannot read the {frame}: {e}"
        ) from e
    if readout.model_name.split(":")[0] not in WINDOWED_MODELS:
        return
    try:
        readout.read(np.zeros((n + 1, n + 1)), seed=0, photon_noise=False)
    except (ValueError, OSError):
        return  # the map is exactly n x n (a map file's size is checked as it is read)
    raise ValueError(
        f"DetnoiseCCD: readout {readout.model_name!r}: its map (noise map, dark frames or camera) "
        f"is larger than the {frame}; it would be read through a different random window every "
        f"frame, not as one fixed camera: crop it to the wavefront sensor's window, "
        f"e.g. map_e[y0:y0 + {n}, x0:x0 + {n}]"
    )


# SPECULA's parameter files find a class `C` in `<module>.<c in snake_case>` of the modules in
# `add_modules`: `add_modules: ['detnoise.ao.specula']` and `class: 'DetnoiseCCD'` import
# `detnoise.ao.specula.detnoise_ccd`, this module under a second name (as `os.path`).
sys.modules[__name__ + ".detnoise_ccd"] = sys.modules[__name__]

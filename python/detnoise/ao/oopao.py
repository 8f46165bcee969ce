"""The measured camera as OOPAO's wavefront-sensor detector.

`DetnoiseDetector` subclasses OOPAO's ``Detector``: every OOPAO object that talks to a camera
(``ShackHartmann``'s ``wfs.cam``, ``tel * cam``) works with it unchanged, but the frame's noise
(photon noise, per-pixel read noise, EMCCD excess noise, a whole camera model) is drawn once by
a `detnoise.Readout` instead of OOPAO's own (a scalar read noise rounded to whole electrons, an
EMCCD without excess noise)::

    import detnoise
    from detnoise.ao.oopao import DetnoiseDetector, attach

    attach(wfs, DetnoiseDetector.from_map("rms_e.fits", seed=1))    # a fixed sCMOS camera
    attach(wfs, DetnoiseDetector(detnoise.Readout("emccd-stochastic", em_gain=300, seed=1)))

The frames are in e- referred to the input (an EMCCD's output divided by its mean gain).
OOPAO's switches keep their meaning: ``cam.photonNoise = False`` and ``cam.readoutNoise = False``
give the noise-free frame, which is how OOPAO takes its reference slopes
(``wfs.initialize_wfs()``); `reference_slopes` takes them through the camera's noise instead.
"""

import contextlib
import copy
import json
from pathlib import Path

import numpy as np
from OOPAO.Detector import Detector
from OOPAO.tools.tools import OopaoError, get_array_module, set_binning

import detnoise

__all__ = ["DetnoiseDetector", "attach", "reference_slopes"]

# OOPAO Detector settings whose effect this camera does not model, with their neutral values:
# the readout (or a camera model) is the one place the frame's noise comes from.
_UNSUPPORTED = {
    "darkCurrent": (0, "a camera model (DetnoiseDetector.from_camera) has its own dark current"),
    "FWC": (None, "saturation is not modelled"),
    "bits": (None, "the frames are e-, not quantised"),
    "backgroundNoise": (False, "add the background to the source's flux instead"),
    "backgroundMap": (None, "the frames are e-, a background is not subtracted"),
    "log_scale": (False, "the frames are linear e-"),
    "gain": (1, "the readout's own gain (em_gain) is divided out: frames are e-"),
}


def _to_numpy(array):
    backend = get_array_module(array)
    return array if backend is np else backend.asnumpy(array)


def _switch(name, value):
    """An OOPAO noise switch as a bool: True/False, 1/0 (OOPAO saves and restores them as 0-d
    arrays). A read noise in e- is refused: the readout sets the noise."""
    flag = np.asarray(value)
    if flag.shape != () or flag.item() not in (0, 1):
        raise OopaoError(
            f"DetnoiseDetector: {name}={value!r} is a switch here (True or False): the detnoise "
            "readout sets the noise; choose a readout model or noise map for another read noise"
        )
    return bool(flag.item())


def _map_array(map_e):
    """A noise map (array, or FITS/TIFF/EXR path of one frame) as a 2-D float array, e-."""
    if isinstance(map_e, (str, Path)):
        frames = detnoise.read_stack(str(map_e))
        if len(frames) != 1:
            raise ValueError(f"noise map {map_e}: {len(frames)} frames, expected one map")
        return np.asarray(next(frames), dtype=float)
    array = np.asarray(map_e, dtype=float)
    if array.ndim != 2:
        raise ValueError(f"noise map: shape {array.shape}, expected a 2-D map (rows, columns), e-")
    return array


class DetnoiseDetector(Detector):
    """OOPAO ``Detector`` whose frames are read through a `detnoise.Readout`.

    readout: any `detnoise.Readout` (its seed makes the frames reproducible). QE: quantum
    efficiency (photo-electrons per photon). binning: pixels summed before the read (as OOPAO's
    hardware binning). photonNoise, readoutNoise: switches (OOPAO sets both to 0 to take noise-
    free frames): both on, the readout draws shot and read noise; photon noise off, the expected
    frame rounded to whole photo-electrons is read without shot noise; read noise off, Poisson
    shot noise only; both off, the expected frame. They are switches only (True/False, 1/0):
    the readout sets the noise, so a read-noise value in e- is refused. map_shape: (rows,
    columns) the readout's map must match, checked against the frame at `attach` or the first
    frame. nRes, psf_sampling, integrationTime: as OOPAO's ``Detector``.
    """

    def __init__(
        self,
        readout,
        *,
        QE=1.0,
        binning=1,
        photonNoise=True,
        readoutNoise=True,
        nRes=None,
        psf_sampling=2.0,
        integrationTime=None,
        map_shape=None,
    ):
        if not isinstance(readout, detnoise.Readout):
            raise TypeError(f"readout: a detnoise.Readout, not {type(readout).__name__}")
        if not (np.isfinite(QE) and 0 < QE <= 1):
            raise ValueError(f"QE: {QE}, expected a quantum efficiency in (0, 1]")
        if int(binning) != binning or binning < 1:
            raise ValueError(f"binning: {binning}, expected a whole number >= 1")
        self.detnoise_readout = readout
        self.map_shape = None if map_shape is None else tuple(int(s) for s in map_shape)
        self._checked_shape = None
        # shot noise alone (read noise switched off) from detnoise too, on the same frame counter
        self._shot = detnoise.Readout("scmos-constant", sigma_e=0.0, seed=readout.seed)
        super().__init__(
            nRes=nRes,
            integrationTime=integrationTime,
            sensor="EMCCD" if readout.sensor == "emccd" else "CMOS",
            QE=QE,
            binning=int(binning),
            psf_sampling=psf_sampling,
            photonNoise=photonNoise,
            readoutNoise=readoutNoise,
        )
        if nRes is not None:
            self.check_frame((nRes // self.binning, nRes // self.binning))

    @property
    def photonNoise(self):
        """Switch: shot noise drawn (True) or not (False)."""
        return self._photon_noise

    @photonNoise.setter
    def photonNoise(self, value):
        self._photon_noise = _switch("photonNoise", value)

    @property
    def readoutNoise(self):
        """Switch: the readout's noise drawn (True) or not (False)."""
        return self._readout_noise

    @readoutNoise.setter
    def readoutNoise(self, value):
        self._readout_noise = _switch("readoutNoise", value)

    def __deepcopy__(self, memo):
        """A copy (OOPAO deep-copies its objects) that shares the readouts, which cannot be
        copied: the copy's frames continue the same frame counter."""
        new = self.__class__.__new__(self.__class__)
        memo[id(self)] = new
        for name, value in self.__dict__.items():
            shared = isinstance(value, detnoise.Readout)
            setattr(new, name, value if shared else copy.deepcopy(value, memo))
        return new

    @contextlib.contextmanager
    def noise_free(self):
        """Both switches off inside the block, restored after it, e.g. around OOPAO's
        ``InteractionMatrix``, which switches them off (noise='off') and leaves them off."""
        saved = self.photonNoise, self.readoutNoise
        self.photonNoise = self.readoutNoise = False
        try:
            yield self
        finally:
            self.photonNoise, self.readoutNoise = saved

    @classmethod
    def from_map(cls, map_e, *, window=None, seed=0, **detector):
        """A fixed sCMOS camera of a per-pixel read-noise map (e- rms; an array or a FITS/TIFF/EXR
        path), the frame's shape. window=(row, col, n): use the n x n px part of the map from
        pixel (row, col). Other keywords: as `DetnoiseDetector`."""
        array = _map_array(map_e)
        if window is not None:
            row, col, n = (int(v) for v in window)
            rows, cols = array.shape
            if row < 0 or col < 0 or n < 1 or row + n > rows or col + n > cols:
                raise ValueError(
                    f"window {tuple(window)} (row, col, n px) is not inside the {rows}x{cols} px "
                    "noise map"
                )
            array = array[row : row + n, col : col + n]
        if array.shape[0] != array.shape[1]:
            raise ValueError(
                f"noise map is {array.shape[0]}x{array.shape[1]} px: the frame is square, cut a "
                "square window=(row, col, n)"
            )
        readout = detnoise.Readout("scmos-map", map_e=np.ascontiguousarray(array), seed=seed)
        return cls(readout, map_shape=array.shape, **detector)

    @classmethod
    def from_camera(
        cls, path, *, exposure_s=None, em_gain=None, temperature_c=None, seed=0, **detector
    ):
        """A camera model folder (docs/camera.md) at an operating point: exposure (s; None:
        the campaign's shortest dark exposure), commanded EM gain (None: no multiplication),
        sensor temperature (degrees C). Its rows x columns must be the frame's. Other keywords:
        as `DetnoiseDetector`."""
        with open(Path(path) / "camera.json") as f:
            described = json.load(f)
        readout = detnoise.Readout.from_camera(
            path, exposure_s=exposure_s, em_gain=em_gain, temperature_c=temperature_c, seed=seed
        )
        return cls(readout, map_shape=(described["rows"], described["cols"]), **detector)

    def check_frame(self, shape):
        """Refuse a frame the readout cannot read as one fixed camera: not square, not the
        map's shape, or refused by the readout itself (ValueError naming both)."""
        shape = tuple(int(s) for s in shape)
        if shape == self._checked_shape:
            return
        frame = f"the detector's {'x'.join(map(str, shape))} px frame"
        if len(shape) != 2 or shape[0] != shape[1]:
            raise ValueError(
                f"detnoise.ao.oopao: {frame} is not square: detnoise.Readout reads (n, n) frames"
            )
        if self.map_shape is not None and self.map_shape != shape:
            rows, cols = self.map_shape
            raise ValueError(
                f"detnoise.ao.oopao: the camera's map is {rows}x{cols} px, {frame}: only a map of "
                "the frame's shape reads as one fixed camera (a larger one would be read through a "
                "random window every frame; from_map(window=...) cuts a fixed one)"
            )
        readout = self.detnoise_readout
        try:
            # frame 0 of an explicit seed: leaves the camera's frame counter alone
            readout.read(np.zeros(shape), seed=readout.seed, photon_noise=False)
        except ValueError as e:
            raise ValueError(
                f"detnoise.ao.oopao: readout {readout.model_name!r} cannot read {frame}: {e}"
            ) from e
        self._checked_shape = shape

    def _refuse_unsupported(self):
        for name, (neutral, why) in _UNSUPPORTED.items():
            value = getattr(self, name, neutral)
            if value is not neutral and value != neutral:
                raise OopaoError(f"DetnoiseDetector: {name}={value!r} is not supported ({why})")

    def integrate(self, frame):
        """Add a noise-free frame (photons per pixel) to the exposure; read out when complete."""
        frame = np.asarray(_to_numpy(frame), dtype=float)
        self.perfect_frame = frame.copy()
        self.flux_max_px = frame.max()
        self.signal = self.QE * self.flux_max_px
        self.buffer_frame.append(frame * self.QE)
        if self.integrationTime is None:
            self.readout()
        else:
            if self.frame is None:
                self.frame = self.perfect_frame * 0
            if self._integrated_time >= self.integrationTime:
                self.readout()

    def readout(self):
        """Read the exposure's expected photo-electrons through the readout into ``frame`` (e-)."""
        self._refuse_unsupported()
        expected = np.clip(np.sum(self.buffer_frame, axis=0), 0.0, None)
        if self.binning != 1:
            expected = set_binning(expected, self.binning)
        self.check_frame(expected.shape)
        #: the noise-free frame of the last read, expected photo-electrons per pixel
        self.expected_frame = expected
        self.frame = self._read(expected)
        self.buffer = list(self.buffer_frame)
        if self.resolution is None:
            self.resolution = self.frame.shape[0] * self.binning
        if self.fov_arcsec is not None:
            self.pixel_size_rad = self.fov_rad / self.resolution * self.binning
            self.pixel_size_arcsec = self.fov_arcsec / self.resolution * self.binning
        self.buffer_frame = []
        self._integrated_time = 0

    def _read(self, expected):
        photon, read = bool(self.photonNoise), bool(self.readoutNoise)
        if photon and read:
            return self.detnoise_readout.read(expected)
        if read:
            # without shot noise the readout reads whole photo-electrons
            return self.detnoise_readout.read(np.rint(expected), photon_noise=False)
        if photon:
            self._shot.frame = self.detnoise_readout.frame
            self.detnoise_readout.frame += 1
            return self._shot.read(expected)
        return expected.copy()

    def properties(self):
        prop = super().properties()
        readout = getattr(self, "detnoise_readout", None)
        if isinstance(readout, detnoise.Readout):
            prop["readout_noise"] = f"{'Readout (detnoise)':<25s}|{readout.model_name:^9s}"
            prop["read_noise_on"] = f"{'Readout noise':<25s}|{str(bool(self.readoutNoise)):^9s}"
            # OOPAO's dark current is not used: a camera model's is in the readout
            prop.pop("dark_current", None)
        return prop


def attach(wfs, camera):
    """Make `camera` (a `DetnoiseDetector`, or a `detnoise.Readout` to wrap with the defaults)
    the detector of OOPAO wavefront sensor `wfs` (``wfs.cam``), after checking that it reads
    the sensor's frame (square, the map's shape). Returns the camera."""
    if isinstance(camera, detnoise.Readout):
        camera = DetnoiseDetector(camera)
    if not isinstance(camera, DetnoiseDetector):
        kind = type(camera).__name__
        raise TypeError(f"camera: a DetnoiseDetector or a detnoise.Readout, not {kind}")
    if camera.binning != 1:
        raise ValueError(
            f"camera binning {camera.binning}: the wavefront sensor splits the unbinned frame "
            "into its sub-apertures; bin with the sensor's own binning_factor instead"
        )
    raw = getattr(wfs, "raw_data", None)
    if raw is not None:
        shape = np.shape(raw)[-2:]
        camera.check_frame((shape[0] // camera.binning, shape[1] // camera.binning))
    wfs.cam = camera
    return camera


def reference_slopes(wfs, frames):
    """Take the reference slopes of OOPAO Shack-Hartmann `wfs` through its camera with the noise
    on: the mean centroids (px) of `frames` frames of the source through the telescope alone, as
    ``wfs.initialize_wfs()`` propagates it (decouple the atmosphere first), at the source's
    current flux. Sets them as the reference of every source; returns them (``signal_2D``'s
    layout, px before ``slopes_units``). The noise-free reference is OOPAO's own:
    ``wfs.initialize_wfs()`` switches the camera's noise off, through this camera too."""
    if int(frames) != frames or frames < 1:
        raise ValueError(f"frames: {frames}, expected a whole number >= 1")
    if getattr(wfs, "is_geometric", False):
        raise ValueError("reference_slopes: a geometric Shack-Hartmann has no camera")
    sh_data = [wfs.sh_data["src_" + str(i)] for i in range(len(wfs.sh_data))]
    saved = [d.reference_signal_2D for d in sh_data]
    total = 0.0
    try:
        for d in sh_data:
            d.reference_signal_2D = 0
        for _ in range(int(frames)):
            wfs.src**wfs.telescope * wfs.em_field_transform
            wfs.relay(wfs.src)
            # signal_2D is (centroid - 0) / slopes_units, zero outside the valid sub-apertures
            total = total + np.asarray(wfs.signal_2D) * wfs.slopes_units
    except BaseException:
        for d, ref in zip(sh_data, saved):
            d.reference_signal_2D = ref
        raise
    reference = total / int(frames)
    if len(sh_data) == 1:
        sh_data[0].reference_signal_2D = reference
    else:
        for i, d in enumerate(sh_data):
            d.reference_signal_2D = reference[i]
    wfs.reference_signal_2D = np.squeeze(reference)
    return reference

"""The measured camera as an HCIPy detector (docs/ao-hcipy.md).

`DetnoiseDetector` is a `hcipy.Detector` that integrates like HCIPy's `NoisyDetector` (power
per unit time x dt x weight, summed over `subsampling` x `subsampling` sub-pixels) and reads
out through a `detnoise.Readout`: shot noise and the camera's noise are drawn by the readout
from its own seeded streams, so a detector of a given seed reads the same frames every run.
"""

import json
import numbers
from pathlib import Path

import hcipy
import numpy as np

import detnoise

__all__ = ["DetnoiseDetector"]

#: The map a report folder holds (docs/report.md): the measured read noise, e- rms per pixel.
REPORT_MAP = "rms_e.fits"


def _frame_px(grid):
    """Side n of the square (n, n) frame of `grid`; ValueError for any other grid."""
    if not isinstance(grid, hcipy.Grid):
        raise TypeError(f"detector_grid must be a hcipy Grid, not {type(grid).__name__}")
    if grid.ndim != 2 or not grid.is_separated:
        raise ValueError(
            "detector_grid must be a 2-D grid of rows and columns of pixels (a separated "
            "Cartesian grid, e.g. hcipy.make_pupil_grid): detnoise reads square (n, n) frames"
        )
    rows, cols = (int(s) for s in grid.shape)
    if rows != cols:
        raise ValueError(
            f"detector_grid is {rows}x{cols} px (rows x columns): detnoise reads square "
            "(n, n) frames; use a square detector grid"
        )
    return rows


def _subsampling(value):
    """`subsampling` as a whole number >= 1 of sub-pixels per pixel along each axis."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < 1:
        raise ValueError(
            f"subsampling must be a whole number >= 1 of sub-pixels per pixel, not {value!r}"
        )
    return int(value)


def _map_array(map_e):
    """A noise map (a path or an array) as a 2-D float array, and its name for messages."""
    if isinstance(map_e, (str, Path)):
        frames = detnoise.read_stack(map_e)
        if len(frames) != 1:
            raise ValueError(f"map_e {map_e}: holds {len(frames)} frames, not one map")
        return next(iter(frames)), str(map_e)
    arr = np.asarray(map_e, dtype=float)
    if arr.ndim != 2:
        raise ValueError(f"map_e: shape {arr.shape}, not a 2-D map")
    return arr, "map_e"


class DetnoiseDetector(hcipy.Detector):
    """A `hcipy.Detector` read out through a `detnoise.Readout`.

    Parameters
    ----------
    detector_grid : Grid
        The pixels (their centres): a square 2-D grid, n x n.
    readout : detnoise.Readout
        The camera; it draws the shot noise and its own noise, from its seed and frame counter.
    subsampling : int
        Sub-pixels per pixel along each axis; the input grid is the detector grid supersampled
        by it and the power of a pixel's sub-pixels is summed (as `hcipy.NoisyDetector`).
    quantum_efficiency : float
        Photo-electrons per unit of integrated power (the power in photons per unit time), in
        (0, 1]; default 1.
    unit : str
        "e": frames in e- referred to the input (an EMCCD's output divided by its mean gain);
        "adu": e- / gain_e_per_adu + offset_adu (the readout needs `gain_e_per_adu`).
    offset_adu : float or array, optional
        Offset added to "adu" frames, adu: a scalar or an (n, n) map.
    """

    def __init__(
        self,
        detector_grid,
        readout,
        subsampling=1,
        *,
        quantum_efficiency=1.0,
        unit="e",
        offset_adu=None,
    ):
        n = _frame_px(detector_grid)
        if not isinstance(readout, detnoise.Readout):
            raise TypeError(f"readout must be a detnoise.Readout, not {type(readout).__name__}")
        qe = float(quantum_efficiency)
        if not 0.0 < qe <= 1.0:
            raise ValueError(f"quantum_efficiency {quantum_efficiency!r}: must be in (0, 1]")
        hcipy.Detector.__init__(self, detector_grid, _subsampling(subsampling))
        self.readout = readout
        self.quantum_efficiency = qe
        self.unit = unit
        self.offset_adu = offset_adu
        self.frame_px = n
        # One dark frame read now (with its own seed: the frame counter is left alone) checks
        # the readout against this frame, the unit and the offset before any light is
        # integrated: a camera or map smaller than the frame, "adu" without a gain.
        self._read(np.zeros((n, n)), seed=0)
        self.accumulated_charge = 0

    # --- constructors -------------------------------------------------------------------

    @classmethod
    def from_noise_map(
        cls,
        detector_grid,
        map_e,
        *,
        window=None,
        gain_e_per_adu=None,
        seed=0,
        **options,
    ):
        """A fixed sCMOS camera of per-pixel read noise `map_e` (e- rms; a FITS/TIFF/EXR path,
        e.g. `rms_e.fits` of `detnoise darks` or a report, or a 2-D array): pixel [r, c] of the
        map reads pixel [r, c] of the frame (the field's `shaped` order: row = y, column = x).
        The map must be the frame's shape, or give `window` = (row, column), the top-left
        corner of the frame's n x n window in a larger map. `gain_e_per_adu` (e- per adu) for
        unit "adu"; `options` as the constructor's."""
        n = _frame_px(detector_grid)
        arr, name = _map_array(map_e)
        if window is None:
            if arr.shape != (n, n):
                raise ValueError(
                    f"{name}: the map is {arr.shape[0]}x{arr.shape[1]} px, the detector grid "
                    f"{n}x{n} px: give a map of the frame's shape, or `window` = (row, column) "
                    "of the frame's top-left corner in the map"
                )
        else:
            r0, c0 = (int(w) for w in window)
            if r0 < 0 or c0 < 0 or r0 + n > arr.shape[0] or c0 + n > arr.shape[1]:
                raise ValueError(
                    f"{name}: window {n}x{n} px at (row {r0}, column {c0}) is outside the "
                    f"{arr.shape[0]}x{arr.shape[1]} px map"
                )
        params = {} if gain_e_per_adu is None else {"gain_e_per_adu": gain_e_per_adu}
        # The file itself is read by the readout first: its BUNIT is checked (e-) and errors
        # name it; a window is then read from the array.
        readout = detnoise.Readout("scmos-map", map_e=map_e, seed=seed, **params)
        if window is not None:
            readout = detnoise.Readout(
                "scmos-map", map_e=arr[r0 : r0 + n, c0 : c0 + n].copy(), seed=seed, **params
            )
        return cls(detector_grid, readout, **options)

    @classmethod
    def from_report(cls, detector_grid, report_dir, **kwargs):
        """The camera a `detnoise report` folder measured: its `rms_e.fits` map, as
        `from_noise_map` (same keywords)."""
        path = Path(report_dir) / REPORT_MAP
        if not path.is_file():
            raise FileNotFoundError(
                f"{report_dir}: no {REPORT_MAP} in this folder (a report of an sCMOS with a "
                "conversion gain writes it)"
            )
        return cls.from_noise_map(detector_grid, path, **kwargs)

    @classmethod
    def from_camera(
        cls,
        detector_grid,
        camera_dir,
        *,
        exposure_s=None,
        em_gain=None,
        temperature_c=None,
        seed=0,
        **options,
    ):
        """A camera model folder (docs/camera.md) at an operating point, as
        `detnoise.Readout.from_camera` (exposure s, commanded EM gain e-/e-, temperature
        degrees C). The camera's rows x columns must be the detector grid's; frames in e-
        only (the model's converter is applied inside the readout)."""
        n = _frame_px(detector_grid)
        described = Path(camera_dir) / "camera.json"
        try:
            shape = json.loads(described.read_text(encoding="utf-8"))
            rows, cols = int(shape["rows"]), int(shape["cols"])
        except (OSError, ValueError, KeyError, TypeError) as e:
            raise ValueError(f"{described}: not a readable camera model ({e})") from e
        if (rows, cols) != (n, n):
            raise ValueError(
                f"{camera_dir}: the camera is {rows}x{cols} px, the detector grid {n}x{n} px: "
                "they must be the same"
            )
        if options.get("unit", "e") != "e":
            raise ValueError(
                "from_camera reads frames in e- only (unit=\"e\"); for adu build a "
                "detnoise.Readout with gain_e_per_adu"
            )
        readout = detnoise.Readout.from_camera(
            camera_dir,
            exposure_s=exposure_s,
            em_gain=em_gain,
            temperature_c=temperature_c,
            seed=seed,
        )
        return cls(detector_grid, readout, **options)

    # --- the hcipy.Detector interface ---------------------------------------------------

    def integrate(self, wavefront, dt, weight=1):
        """Integrate power (a Wavefront's, or a field of power per unit time on `input_grid`,
        in photons) for `dt` with `weight`: photo-electrons += power x dt x weight x QE,
        summed over each pixel's sub-pixels."""
        power = np.asarray(wavefront.power if hasattr(wavefront, "power") else wavefront)
        if power.shape != (self.input_grid.size,):
            raise ValueError(
                f"the power has shape {power.shape}: the detector integrates fields of its "
                f"input grid ({self.input_grid.size} points: the detector grid times "
                "subsampling^2)"
            )
        power = hcipy.Field(power.astype(float), self.input_grid)
        if self.subsampling > 1:
            power = hcipy.subsample_field(
                power, self.subsampling, new_grid=self.detector_grid, statistic="sum"
            )
        self.accumulated_charge = (
            self.accumulated_charge + power * (dt * weight * self.quantum_efficiency)
        )

    def read_out(self):
        """Read the integrated photo-electrons through the readout (shot noise and the
        camera's noise drawn there), reset, and return the frame as a Field on the detector
        grid, in `unit`. Without light integrated, a dark frame."""
        n = self.frame_px
        expected_e = np.broadcast_to(np.asarray(self.accumulated_charge, dtype=float), (n * n,))
        self.accumulated_charge = 0
        frame = self._read(expected_e.reshape(n, n))
        return hcipy.Field(frame.ravel(), self.detector_grid)

    def _read(self, image_e, seed=None):
        offset = {} if self.offset_adu is None else {"offset_adu": self.offset_adu}
        return self.readout.read(image_e, seed=seed, unit=self.unit, **offset)

"""detnoise: read-noise models of sCMOS and EMCCD cameras for Shack-Hartmann wavefront sensors.

numpy in and out, units in names (``_e`` electrons, ``_adu`` camera counts, ``_px`` pixels,
``_photons``):

- ``read_stack(paths)``: the frames of FITS/TIFF/OpenEXR stacks as 2-D arrays;
- ``dark_maps(paths, gain_e_per_adu=None, ...)``: offset, read-noise and flag maps;
- ``campaign(manifest=..., out=..., gain_e_per_adu=...)``: darks at several exposures, EM gains
  and temperatures decomposed per pixel into offset, CIC and dark current (a ``Campaign``);
- ``datasheet(emva=..., out=...)``: the EMVA 1288 datasheet of a camera (a ``Datasheet``);
- ``fit_pdf(rms_e)``, ``fit_emgain(paths, ...)``: calibration fits with standard errors;
- ``Readout(model, **params)``: a camera as a noise generator, ``cam.read(image_e)``;
- ``simulate(...)``, ``effective(...)``: Monte-Carlo records for ``pandas.DataFrame``;
- ``report(darks, out=...)``: the end-to-end report, as ``detnoise report`` writes it.

Bad settings raise ``ValueError`` (naming the keyword), unreadable files ``OSError``,
numerical failures ``RuntimeError``; Ctrl-C stops a long run with ``KeyboardInterrupt``.
Long runs take ``progress=``: a callable ``progress(stage, done, total, unit)``, or ``True``
for a ``tqdm`` bar (a line on standard error without tqdm).
"""

import functools
import sys

from . import _detnoise
from ._detnoise import (
    MODEL_NAMES,
    MODEL_PARAMS,
    MODELS_HELP,
    SETTINGS,
    Campaign,
    DarkMaps,
    Datasheet,
    DetnoiseWarning,
    EmGainFit,
    PdfFit,
    Readout,
    Report,
    StackIterator,
    __version__,
    fit_emgain,
    fit_pdf,
    read_stack,
)

__all__ = [
    "MODEL_NAMES",
    "MODEL_PARAMS",
    "MODELS_HELP",
    "SETTINGS",
    "Campaign",
    "DarkMaps",
    "Datasheet",
    "DetnoiseWarning",
    "EmGainFit",
    "PdfFit",
    "Readout",
    "Report",
    "StackIterator",
    "__version__",
    "campaign",
    "datasheet",
    "dark_maps",
    "effective",
    "fit_emgain",
    "fit_pdf",
    "read_stack",
    "report",
    "simulate",
]


class _TqdmProgress:
    """One tqdm bar per stage of a run."""

    def __init__(self, tqdm):
        self._tqdm = tqdm
        self._bar = None
        self._stage = None

    def __call__(self, stage, done, total, unit):
        if self._bar is None or stage != self._stage:
            self.close()
            self._bar = self._tqdm(total=total, desc=stage, unit=f" {unit}", unit_scale=True)
            self._stage = stage
        self._bar.total = total
        self._bar.update(done - self._bar.n)
        if done >= total:
            self.close()

    def close(self):
        if self._bar is not None:
            self._bar.close()
            self._bar = None


class _TextProgress:
    """Progress as one line per stage on standard error (without tqdm)."""

    def __init__(self):
        self._open = False

    def __call__(self, stage, done, total, unit):
        percent = 100.0 * done / total if total else 100.0
        end = "\n" if done >= total else ""
        sys.stderr.write(f"\r{stage}: {percent:5.1f} % of {total} {unit}{end}")
        sys.stderr.flush()
        self._open = not end

    def close(self):
        # A run stopped mid-stage (Ctrl-C) leaves its line at its last percentage: end it.
        if self._open:
            sys.stderr.write("\n")
            sys.stderr.flush()
            self._open = False


def _progress(progress):
    """The callback of ``progress=``: None, a callable, or True for a bar."""
    if progress is None or progress is False:
        return None
    if progress is True:
        try:
            from tqdm.auto import tqdm
        except ImportError:
            return _TextProgress()
        return _TqdmProgress(tqdm)
    if callable(progress):
        return progress
    raise TypeError(f"progress must be None, True or a callable, not {progress!r}")


def _with_progress(function):
    """``function`` taking ``progress=True`` for a bar, closed when the run ends."""

    @functools.wraps(function)
    def run(*args, progress=None, **kwargs):
        callback = _progress(progress)
        try:
            return function(*args, progress=callback, **kwargs)
        finally:
            close = getattr(callback, "close", None)
            if progress is True and close is not None:
                close()

    return run


dark_maps = _with_progress(_detnoise.dark_maps)
campaign = _with_progress(_detnoise.campaign)
datasheet = _detnoise.datasheet
simulate = _with_progress(_detnoise.simulate)
effective = _with_progress(_detnoise.effective)
report = _with_progress(_detnoise.report)

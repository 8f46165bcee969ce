"""Type stubs of detnoise: units are in the names (_e electrons, _adu camera counts, _px
pixels, _photons photons per sub-aperture before QE)."""

import os
import sys
from pathlib import Path
from typing import Any, Callable, Dict, Iterator, List, Literal, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

if sys.version_info >= (3, 11):
    from typing import TypedDict, Unpack
else:
    from typing_extensions import TypedDict, Unpack

__version__: str
#: Every model name `Readout`, `simulate` and `effective` accept, with its argument syntax.
MODEL_NAMES: List[str]
#: One line per model: syntax, what it simulates, and the parameters it reads.
MODELS_HELP: str
#: The keywords of the readout-model parameters (`ModelParams`).
MODEL_PARAMS: List[str]
#: Every readout and run setting: group, key, field, flag, unit, kind, range (lo, hi, lo_open,
#: hi_open) or choices, default and help; the ranges and defaults both front ends apply.
SETTINGS: List[Dict[str, Any]]

_Path = Union[str, "os.PathLike[str]"]
_Paths = Union[_Path, Sequence[_Path]]
_Array = npt.ArrayLike
#: progress(stage, done, total, unit): called at most every 0.1 s and at each stage's start
#: and end; True shows a tqdm bar (a line on standard error without tqdm).
_Progress = Union[None, bool, Callable[[str, int, int, str], Any]]
_Record = Dict[str, Any]

class DetnoiseWarning(UserWarning):
    """Something a run wants the user to know that did not stop it."""

class ModelParams(TypedDict, total=False):
    """Readout-model parameters; each model reads only those it needs (see MODELS_HELP).
    Ranges and defaults are the command line's (``SETTINGS``)."""

    # BEGIN settings: generated from detnoise::settings::READOUT by tests/python_stubs.rs
    #: EMCCD mean EM gain, output e- per input e-: 1 to 10,000 (cameras run at most at a few
    #: thousand; the exact register's table grows linearly with the gain); in [1, 10000] e-/e-;
    #: default: 500.
    em_gain: float
    #: Stages of the EM register, 1 to 2000 stages, and at least log2(gain) (a stage at most doubles
    #: the charge: p = gain^(1/stages) - 1 <= 1); whole number from 1 to 2000 stages; default: 520.
    stages: int
    #: EMCCD read noise before division by the gain, e- rms, at most 1e4 (no camera reads noisier;
    #: cameras: 10 to 100 e- at MHz rates); in [0, 10000] e-; default: 50.
    emccd_read_noise_e: float
    #: Read noise of `scmos-constant` without its own `:SIGMA`, e- rms, at most 1e4 (no camera reads
    #: noisier: its full well is ~1e6 e-); in [0, 10000] e-; default: 1.
    sigma_e: float
    #: `emccd-distribution` draws N(n g, n g^2) instead of Gamma(n, g) above this many input
    #: electrons, e- (the paper's switch, corrected); default: always the exact Gamma; whole number
    #: from 0 to 4294967295 input e-.
    gaussian_switch_e: Optional[int]
    #: EM register sampler: `exact` (tabulated single-electron output, fast) or `cascade` (per-stage
    #: binomials, the slow reference); default: exact.
    register: Literal["exact", "cascade"]
    #: Seed of the fixed sCMOS noise patterns, unitless (`scmos-fixed:K` uses pattern K of it);
    #: whole number from 0 to 18446744073709551615; default: 2015.
    pattern_seed: int
    #: `emccd-pp` threshold rule (a reconstruction of Basden et al. 2003): poisson-prior (boundaries
    #: n(n+1)/lambda in units of g, lambda the sub-aperture mean or `pp_lambda`), pixel-prior (the
    #: same with each pixel's own mean level in the centred noiseless spot, in photo-electrons:
    #: per-pixel thresholds, counts corrected to the posterior mean E[n | K] under that prior) or
    #: equal-density (fixed, ~0.203, 0.719, 1.896 g ...); pixel-prior is useful below 0.4
    #: photo-electrons per pixel, the others above it (model_range says so); default: poisson-prior.
    pp_rule: Literal["poisson-prior", "equal-density", "pixel-prior"]
    #: `emccd-pp` reference light level, photo-electrons per pixel, > 0 and at most 1e5 (the largest
    #: level the correction's thresholds can span; photon counting is for levels of a few e- at
    #: most); default: the sub-aperture mean (not with `pp_rule` pixel-prior, whose levels are the
    #: pixels' own); in (0, 100000] photo-electrons per pixel.
    pp_lambda: Optional[float]
    #: Per-pixel rms distribution of the sCMOS models: `paper` (Eq. 3 on [0, 10] e-) or the path of
    #: a `pdf_fit.json` written by `detnoise fit-pdf` (its best model unless `pdf_model`); default:
    #: paper.
    pdf: Union[str, "PdfFit", _Path]
    #: Name of the model to take from a `pdf_fit.json`: paper-scaled, paper-family, lognormal+tail
    #: or empirical; default: none.
    pdf_model: Optional[str]
    #: Measured read-noise map in e- (FITS/TIFF/EXR; e.g. `rms_e.fits` from `darks`) for the
    #: `scmos-map` model; non-finite pixels are excluded; default: none.
    map_e: Optional[Union[_Array, _Path]]
    #: Telegraph (RTS) pixels for `scmos-rts`: the rts.csv written by `darks` (with
    #: `gain_e_per_adu`, so that it has the levels in e-), of the camera of `map_e`; default: none.
    rts_table: Optional[_Path]
    #: Row-noise amplitude of `scmos-correlated`, e- rms: one draw per row of the window per frame
    #: (darks: temporal_noise.row_rms_e in summary.json), at most 1e4 (no camera's); in [0, 10000]
    #: e-; default: none.
    row_noise_e: Optional[float]
    #: Column-noise amplitude of `scmos-correlated`, e- rms: one draw per column of the window per
    #: frame (darks: temporal_noise.column_rms_e in summary.json), at most 1e4 (no camera's); in [0,
    #: 10000] e-; default: none.
    column_noise_e: Optional[float]
    #: Frame-common noise amplitude of `scmos-correlated`, e- rms: one draw per frame shared by
    #: every pixel (darks: temporal_noise.frame_rms_e in summary.json), at most 1e4; none: no frame
    #: noise; in [0, 10000] e-; default: none.
    frame_noise_e: Optional[float]
    #: Dark frames for `scmos-frames` (files, a directory or a glob; FITS, TIFF, OpenEXR): each
    #: pixel's mean over the stack is subtracted and the values converted with `gain_e_per_adu`;
    #: default: none.
    dark_frames: Optional[_Paths]
    #: Memory bound of the dark frames kept for `scmos-frames`, MiB: a larger stack is sampled
    #: uniformly (a fixed-seed reservoir, reproducible) down to what fits, as f32 e-; > 0 MiB;
    #: default: 512.
    dark_frames_max_mib: float
    #: Conversion gain of `dark_frames`, e- per adu, at most 1e4 (a 16-bit converter would then span
    #: 100 full wells; cameras run at 0.1 to a few tens); in (0, 10000] e- per adu; default: none.
    gain_e_per_adu: Optional[float]
    #: Path of a measured camera model (a folder with camera.json and its maps, docs/camera.md) for
    #: the `camera` model, read at the operating point of `exposure_s`, `em_gain`, `temperature_c`;
    #: default: none.
    camera: Optional[_Path]
    #: Exposure time of each frame of `camera`, s, > 0 and at most 86400; default: 1 /
    #: `frame_rate_hz`, else the campaign's shortest dark exposure (camera.json `campaign`) (the
    #: dark current's signal and shot noise scale with it); in (0, 86400] s.
    exposure_s: Optional[float]
    #: Sensor temperature of `camera`, degrees C, -273.15 to 200 (its dark current scaled by the
    #: model's doubling temperature); default: the temperature its dark current was measured at; in
    #: [-273.15, 200] degrees C.
    temperature_c: Optional[float]
    #: Frame rate the camera of `camera` runs at, Hz, > 0 and at most 1e6: the exposure is 1 / rate
    #: unless `exposure_s` is given; default: the rate of the campaign's shortest dark exposure
    #: (camera.json `campaign`); in (0, 1e6] Hz.
    frame_rate_hz: Optional[float]
    # END settings

class Readout:
    """A readout model of the registry as a noise generator, e.g.
    ``Readout("scmos-map", map_e=rms_e)`` or ``Readout("emccd-stochastic", em_gain=1000)``.

    Each sub-aperture of a read is one work item with its own seeded random streams, read in
    parallel without the GIL: results do not depend on the thread count. Sub-aperture i of
    the camera's frame f uses item f * 2**32 + i of the camera's `seed`.
    """

    def __init__(self, model: str, *, seed: int = 0, **params: Unpack[ModelParams]) -> None: ...
    @staticmethod
    def from_camera(
        path: _Path,
        *,
        exposure_s: Optional[float] = None,
        em_gain: Optional[float] = None,
        temperature_c: Optional[float] = None,
        seed: int = 0,
    ) -> "Readout":
        """The ``camera`` readout of a camera model folder (docs/camera.md) at an operating
        point: exposure (s; None: the campaign's shortest dark exposure, recorded in
        camera.json), commanded EM gain (None: no multiplication), sensor temperature
        (degrees C; None: the dark current's reference)."""
        ...
    def read(
        self,
        image_e: _Array,
        *,
        seed: Optional[int] = None,
        photon_noise: bool = True,
        unit: str = "e",
        offset_adu: Union[None, float, _Array] = None,
        mean_e: Optional[_Array] = None,
    ) -> npt.NDArray[np.float64]:
        """Read a frame (n, n) or a stack of sub-apertures (k, n, n).

        With ``photon_noise`` (default) the values are expected photo-electrons per pixel
        (>= 0) and shot noise is drawn; without, they are photo-electron counts (whole
        numbers >= 0). Returns a new float64 array of the same shape: e- referred to the
        input (an EMCCD's output divided by its mean gain), or with ``unit="adu"``
        value / gain_e_per_adu + offset_adu (not quantised). ``seed``: read as frame 0 of a
        camera of that seed (the frame counter is left alone); None: the camera's next frame.
        ``mean_e``: the controller's mean image, e- per pixel, (n, n) or the input's shape,
        for models with a per-pixel prior (default the input).
        """
    @property
    def model_name(self) -> str:
        """The model as given, e.g. "scmos-fixed:3"."""
    @property
    def sensor(self) -> str:
        """"scmos" or "emccd"."""
    @property
    def seed(self) -> int:
        """Seed of the frames read without an explicit seed."""
    @property
    def frame(self) -> int:
        """The next frame a read without a seed reads (settable)."""
    @frame.setter
    def frame(self, value: int) -> None: ...
    def noise_scale_e(self, subap_px: int) -> float:
        """Typical per-pixel read noise, e-, for subap_px x subap_px images."""

class StackIterator(Iterator[npt.NDArray[np.float64]]):
    """The frames of a stack, one 2-D float64 array (rows, columns) per frame."""

    def __next__(self) -> npt.NDArray[np.float64]: ...
    def __len__(self) -> int: ...
    @property
    def shape(self) -> Tuple[int, int]:
        """Frame shape (rows, columns)."""

def read_stack(paths: _Paths) -> StackIterator:
    """The frames of FITS/TIFF/OpenEXR files, directories or glob patterns, in stack order,
    as 2-D float64 arrays of the stored values (adu)."""

class DarkMaps:
    """The maps of a dark stack, as `detnoise darks` writes them."""

    @property
    def offset_adu(self) -> npt.NDArray[np.float64]:
        """Per-pixel offset (mean level), adu."""
    @property
    def rms_adu(self) -> npt.NDArray[np.float64]:
        """Per-pixel read noise (sample standard deviation), adu."""
    @property
    def rms_e(self) -> Optional[npt.NDArray[np.float64]]:
        """Per-pixel read noise, e- (with a gain), else None."""
    @property
    def flags(self) -> npt.NDArray[np.int32]:
        """Flag bits per pixel (hot, dead, RTS, ...; see summary["flags"])."""
    @property
    def excess_kurtosis(self) -> npt.NDArray[np.float64]:
        """Per-pixel excess kurtosis G2 (0 for Gaussian noise)."""
    @property
    def summary(self) -> Dict[str, Any]:
        """The content of summary.json (its `outputs` empty)."""
    def to_dict(self) -> Dict[str, Any]: ...

def dark_maps(
    paths: _Paths,
    *,
    gain_e_per_adu: Optional[float] = None,
    clip: int = 0,
    sigma_clip: Optional[float] = None,
    common_mode: bool = False,
    hot_sigma: float = 5.0,
    dead_fraction: float = 0.1,
    rts_sigma: float = 5.0,
    checksum: Optional[str] = "blake3",
    accept_illuminated: bool = False,
    camera: Optional[_Path] = None,
    exposure_s: Optional[float] = None,
    em_gain: Optional[float] = None,
    temperature_c: Optional[float] = None,
    progress: _Progress = None,
) -> DarkMaps:
    """Offset, read-noise (adu; e- with gain_e_per_adu, e- per adu) and flag maps of a dark
    stack, as `detnoise darks` computes them. clip: reject the N highest and lowest samples
    per pixel; sigma_clip: reject samples beyond K standard deviations; hot_sigma (robust
    sigmas), dead_fraction (of the median rms), rts_sigma (standard errors): flag thresholds.
    camera: a camera model folder whose dark current and CIC the frames hold at exposure_s
    (s, required with it), em_gain (e-/e-) and temperature_c (degrees C): the check for light
    takes that expected dark signal and its shot noise off first (`darks --camera`)."""

class Campaign:
    """A campaign measured and decomposed as `detnoise campaign` does, its outputs in `out`."""

    @property
    def out(self) -> Path:
        """The output directory written (conditions.csv, campaign.json, the maps, camera/)."""
    @property
    def conditions(self) -> List[Dict[str, Any]]:
        """One dict per stack, in input order, with the columns of conditions.csv (adu)."""
    @property
    def summary(self) -> Dict[str, Any]:
        """campaign.json."""
    @property
    def decomposition(self) -> Dict[str, Any]:
        """decomposition.json: the fit's figures, hot pixels, fit quality, notes."""
    @property
    def maps(self) -> Dict[str, npt.NDArray[np.float64]]:
        """The decomposition's 2-D maps by file name without .fits: offset_adu, offset_se_adu,
        dark_current_e_per_s, dark_current_se_e_per_s, fit_reduced_chi2, hot_class (0 normal,
        1 warm, 2 hot, 3 not fitted) and, with CIC fitted, cic_e_per_frame, cic_se_e_per_frame."""
    @property
    def camera(self) -> Optional[Path]:
        """The camera model folder written (None when no camera could be described)."""

def campaign(
    *,
    manifest: Optional[_Path] = None,
    emva: Optional[_Path] = None,
    files: Optional[_Paths] = None,
    out: _Path,
    gain_e_per_adu: float,
    exposure_key: str = "EXPTIME",
    em_gain_key: Optional[str] = None,
    temperature_key: Optional[str] = None,
    kind_key: Optional[str] = None,
    kind: Optional[Literal["dark", "flat"]] = None,
    light_key: Optional[str] = None,
    force: bool = False,
    checksum: Optional[str] = "blake3",
    em_fit: bool = True,
    temperature_term: Union[Literal["off", "fit"], float, None] = None,
    clip: int = 0,
    sigma_clip: Optional[float] = None,
    common_mode: bool = False,
    warm_sigma: float = 5.0,
    hot_sigma: float = 25.0,
    warm_e_per_s: Optional[float] = None,
    hot_e_per_s: Optional[float] = None,
    bad_fit_p_value: float = 1e-3,
    progress: _Progress = None,
) -> Campaign:
    """Measure and decompose a campaign as `detnoise campaign`: the stacks from exactly one of
    manifest (CSV), emva (EMVA 1288 descriptor) or files (FITS, conditions from the *_key
    header keywords); gain_e_per_adu (e- per adu); temperature_term "off" (default), "fit" or
    a doubling temperature (deg C); clip (samples), sigma_clip (standard deviations, at most
    1000) and common_mode as `dark_maps`; warm/hot classes at warm_sigma/hot_sigma robust
    sigmas (at most 1000) or warm_e_per_s/hot_e_per_s (e-/s, at most 1e6); bad_fit_p_value in
    (0, 1). Writes `out` (replaced only if detnoise wrote it; force: write into a folder of
    other files)."""

class Datasheet:
    """The EMVA 1288 datasheet of a camera as `detnoise datasheet` writes it into `out`."""

    @property
    def out(self) -> Path:
        """The output directory written (datasheet.json/.csv/.html/.xml, figures, FITS maps)."""
    @property
    def sheet(self) -> Dict[str, Any]:
        """datasheet.json: sections of rows (label, unit, value, se, status) and figures."""
    @property
    def maps(self) -> Dict[str, npt.NDArray[np.float64]]:
        """The per-pixel maps by file name without .fits: gain_dn_per_e, gain_se_dn_per_e,
        dark_current_e_per_s, dark_current_se_e_per_s, rms_e, rms_se_e."""

def datasheet(
    *,
    emva: Optional[_Path] = None,
    manifest: Optional[_Path] = None,
    out: _Path,
    force: bool = False,
    defect_sigma: float = 6.0,
    operating_point: str = "8,airy:2,50",
) -> Datasheet:
    """The EMVA 1288 (release 4.0) datasheet of the dataset named by exactly one of emva (the
    reference implementation's descriptor file) and manifest (campaign CSV), as `detnoise
    datasheet`: defect pixels beyond defect_sigma robust standard deviations (in (0, 1000]);
    the effective read noise of the dark noise map at operating_point (SUBAP,SPOT,SIGNAL, as
    the report's). Writes `out` (replaced only if detnoise wrote it; force: write into a folder
    of other files)."""

class PdfFit:
    """A fit of the per-pixel read-noise pdf; pass it as ``pdf=`` to simulate with it."""

    @property
    def best_model(self) -> str: ...
    @property
    def models(self) -> List[str]: ...
    @property
    def n_values(self) -> int: ...
    @property
    def upper_cut_e(self) -> float: ...
    def params(self, model: Optional[str] = None) -> Dict[str, float]:
        """Parameters of `model` (default the best); names carry their unit."""
    def param_se(self, model: Optional[str] = None) -> Dict[str, Optional[float]]:
        """Standard errors of the parameters (None where undefined)."""
    def to_dict(self) -> Dict[str, Any]:
        """The content of pdf_fit.json."""
    def summary_text(self) -> str: ...

def fit_pdf(
    rms_e: _Array,
    *,
    flags: Optional[_Array] = None,
    models: Optional[Sequence[str]] = None,
    upper_cut_e: Optional[float] = None,
) -> PdfFit:
    """Fit models of the per-pixel read-noise pdf (paper-scaled, paper-family,
    lognormal+tail, empirical) to a read-noise map in e- rms, flagged pixels left out."""

class EmGainFit:
    """An EM-gain fit of EMCCD frames, with standard errors."""

    em_gain: float
    em_gain_se: float
    em_gain_units: str
    bias_adu: float
    bias_adu_se: float
    read_noise_adu: float
    read_noise_adu_se: float
    lambda_e: float
    lambda_e_se: float
    def to_dict(self) -> Dict[str, Any]:
        """The content of emgain.json."""
    def summary_text(self) -> str: ...

def fit_emgain(
    paths: _Paths,
    *,
    gain_e_per_adu: Optional[float] = None,
    gain_map: Optional[_Path] = None,
    offset: Optional[_Path] = None,
    read_noise: Optional[_Path] = None,
    stages: Optional[int] = None,
    serial_cic: bool | None = None,
    max_value_adu: Optional[float] = None,
    bin_width_adu: Optional[float] = None,
    reference_stack: Optional[_Paths] = None,
    reference_offset: Optional[_Path] = None,
) -> EmGainFit:
    """Fit bias, read noise, EM gain and light level to EMCCD frames, as `detnoise emgain`."""

def simulate(
    models: Union[str, Sequence[str], None] = None,
    *,
    subap_px: Union[int, Sequence[int], None] = None,
    spot: Union[str, Sequence[str], None] = None,
    signal_photons: Union[float, Sequence[float], None] = None,
    qe: float = 1.0,
    iters: int = 10_000,
    seed: int = 1,
    sampling: str = "integrated",
    bg_grid: str = "auto",
    position_half_range_px: float = 0.5,
    max_empty_frac: float = 0.01,
    centroider: Union[str, Sequence[str], None] = None,
    mask_above: Optional[float] = None,
    progress: _Progress = None,
    **params: Unpack[ModelParams],
) -> List[_Record]:
    """The sub-aperture Monte-Carlo (`detnoise simulate`): one record per configuration, model
    and centroider with R (r_px) and its SE (r_se_px), px. Defaults: the command line's
    models, 16 px, airy:2, 50 photons, `cog` (`centroider`: NAME[:PARAM] texts; `mask_above`,
    times the median sigma, sets masked-cog's parameter)."""

def effective(
    model: str = "scmos-random",
    *,
    subap_px: Union[int, Sequence[int], None] = None,
    spot: Union[str, Sequence[str], None] = None,
    signal_photons: Union[float, Sequence[float], None] = None,
    qe: float = 1.0,
    iters: int = 10_000,
    seed: int = 1,
    sampling: str = "integrated",
    bg_grid: str = "auto",
    position_half_range_px: float = 0.5,
    max_empty_frac: float = 0.01,
    target_se_e: float = 0.05,
    target_rel: float = 0.025,
    max_iters: Optional[int] = None,
    centroider: Union[str, Sequence[str], None] = None,
    mask_above: Optional[float] = None,
    progress: _Progress = None,
    **params: Unpack[ModelParams],
) -> List[_Record]:
    """Effective Gaussian read noise (`detnoise effective`): one record per configuration and
    centroider with sigma_eff_e, sigma_eff_se_e (e-: the uniform camera with the same R under
    the same centroider, its parameter re-optimised; None without a value),
    sigma_cog_equiv_e, sigma_cog_equiv_se_e (e-: the uniform camera with the same R under plain
    cog; equal to sigma_eff_e for cog) and a status word. Defaults: the paper's Fig. 12 grid and
    `cog`."""

class Report:
    """A report's results; its files are in `out_dir`."""

    @property
    def summary(self) -> Dict[str, Any]:
        """The content of summary.json."""
    @property
    def effective(self) -> List[_Record]: ...
    @property
    def comparison(self) -> List[_Record]: ...
    @property
    def pdf_fit(self) -> Optional[PdfFit]: ...
    @property
    def out_dir(self) -> Path: ...
    @property
    def files(self) -> List[Path]: ...
    def to_dict(self) -> Dict[str, Any]: ...

def report(
    darks: _Paths,
    *,
    out: _Path,
    flats: Optional[Sequence[_Path]] = None,
    detector: str = "scmos",
    force: bool = False,
    quick: bool = False,
    subap_px: Union[int, Sequence[int], None] = None,
    spot: Union[str, Sequence[str], None] = None,
    signal_photons: Union[float, Sequence[float], None] = None,
    operating_point: Optional[str] = None,
    iters: int = 10_000,
    target_se_e: float = 0.05,
    target_rel: float = 0.025,
    max_iters: Optional[int] = None,
    seed: int = 1,
    sampling: str = "integrated",
    qe: float = 1.0,
    qe_emccd: float = 1.0,
    accept_illuminated: bool = False,
    centroider: Union[str, Sequence[str], None] = None,
    mask_above: Optional[float] = None,
    centroider_full_grid: bool = False,
    subap_grid: Optional[str] = None,
    subap_mask: Optional[_Path] = None,
    progress: _Progress = None,
    **params: Unpack[ModelParams],
) -> Report:
    """The end-to-end report (`detnoise report`), written into `out`. `centroider`: the
    centroider section's methods (default every registered one); `subap_grid`:
    SIZE[,PITCH[,X0,Y0]] px adds the per-sub-aperture map (`subap_mask`: its valid cells)."""

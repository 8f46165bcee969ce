//! The entries: readout-model settings (`ModelParams`, Python's `**params`) and the run
//! settings of a Monte-Carlo sweep (`SimConfig` and its grid).

use super::Kind::{self, Choice, Paths, Real, Text, TextList, Whole};
use super::Setting;
use crate::detector::pp::PpRule;
use crate::detector::register::{MAX_EM_GAIN, MAX_STAGES};
use crate::montecarlo::SimConfig;
use std::ops::Bound::{Excluded, Included, Unbounded};

const NON_NEGATIVE: Kind = Real(Included(0.0), Unbounded);
const POSITIVE: Kind = Real(Excluded(0.0), Unbounded);
const ANY_SEED: Kind = Whole(0, u64::MAX);

/// Largest read-noise amplitude of any setting (and of an RTS table's widths), e- rms: read
/// noise above 1e4 e- rms is no camera's (a full well is ~1e6 e-, so its signal-to-noise would
/// stay below 100 at saturation), and a bound keeps the Monte-Carlo's centroid sums far inside
/// their range (at 1e20 e- they overflowed, and R came out empty).
pub const MAX_NOISE_E: f64 = 1e4;
/// A read-noise amplitude, e- rms: 0 to [`MAX_NOISE_E`].
const NOISE_E: Kind = Real(Included(0.0), Included(MAX_NOISE_E));

/// Largest `emccd-pp` reference light level, photo-electrons per pixel: the bound of the
/// correction's `pp_lambda_max`, the brightest level its thresholds span.
pub const MAX_PP_LAMBDA: f64 = 1e5;

/// Longest exposure of an operating point, s (a day: no dark frame is longer).
pub const MAX_EXPOSURE_S: f64 = 86_400.0;

/// Largest conversion gain, e- per adu: a 16-bit converter at 1e4 e-/adu spans 6.5e8 e-, a
/// hundred times the full well of any pixel or EM register (~1e6 e-); cameras run at 0.1 to
/// a few tens of e-/adu.
pub const MAX_GAIN_E_PER_ADU: f64 = 1e4;

/// EMCCD mean EM gain, e-/e-.
pub const EM_GAIN: Setting = Setting::new(
    "em_gain",
    "--em-gain",
    Real(Included(1.0), Included(MAX_EM_GAIN)),
    "EMCCD mean EM gain, output e- per input e-: 1 to 10,000 (cameras run at most at a few \
     thousand; the exact register's table grows linearly with the gain)",
)
.unit("e-/e-")
.default("500");

/// Stages of the EM register.
pub const STAGES: Setting = Setting::new(
    "stages",
    "--stages",
    Whole(1, MAX_STAGES as u64),
    "Stages of the EM register, 1 to 2000 stages, and at least log2(gain) (a stage at most \
     doubles the charge: p = gain^(1/stages) - 1 <= 1)",
)
.unit("stages")
.default("520");

/// EMCCD read noise before division by the gain, e- rms.
pub const EMCCD_READ_NOISE_E: Setting = Setting::new(
    "emccd_read_noise_e",
    "--emccd-read-noise",
    NOISE_E,
    "EMCCD read noise before division by the gain, e- rms, at most 1e4 (no camera reads \
     noisier; cameras: 10 to 100 e- at MHz rates)",
)
.unit("e-")
.default("50");

/// Input electrons above which `emccd-distribution` draws a Gaussian.
pub const GAUSSIAN_SWITCH_E: Setting = Setting::new(
    "gaussian_switch_e",
    "--gaussian-switch",
    Whole(0, u32::MAX as u64),
    "`emccd-distribution` draws N(n g, n g^2) instead of Gamma(n, g) above this many input \
     electrons, e- (the paper's switch, corrected); default: always the exact Gamma",
)
.unit("input e-");

/// EM register sampler.
pub const REGISTER: Setting = Setting::new(
    "cascade_register",
    "--register",
    Choice(&["exact", "cascade"]),
    "EM register sampler: `exact` (tabulated single-electron output, fast) or `cascade` \
     (per-stage binomials, the slow reference)",
)
.key("register")
.default("exact");

/// Read noise of a bare `scmos-constant`, e- rms.
pub const SIGMA_E: Setting = Setting::new(
    "sigma_e",
    "--sigma",
    NOISE_E,
    "Read noise of `scmos-constant` without its own `:SIGMA`, e- rms, at most 1e4 (no camera \
     reads noisier: its full well is ~1e6 e-)",
)
.unit("e-")
.default("1");

/// Per-pixel rms distribution of the sCMOS models.
pub const PDF: Setting = Setting::new(
    "pdf",
    "--pdf",
    Text,
    "Per-pixel rms distribution of the sCMOS models: `paper` (Eq. 3 on [0, 10] e-) or the path \
     of a `pdf_fit.json` written by `detnoise fit-pdf` (its best model unless --pdf-model)",
)
.default("paper");

/// The model taken from a `pdf_fit.json`.
pub const PDF_MODEL: Setting = Setting::new(
    "pdf_model",
    "--pdf-model",
    Text,
    "Name of the model to take from a `pdf_fit.json`: paper-scaled, paper-family, \
     lognormal+tail or empirical",
);

/// Seed of the fixed sCMOS noise patterns.
pub const PATTERN_SEED: Setting = Setting::new(
    "pattern_seed",
    "--pattern-seed",
    ANY_SEED,
    "Seed of the fixed sCMOS noise patterns, unitless (`scmos-fixed:K` uses pattern K of it)",
)
.default("2015");

/// Measured read-noise map (e-) of `scmos-map`.
pub const MAP: Setting = Setting::new(
    "map",
    "--map",
    Kind::Path,
    "Measured read-noise map in e- (FITS/TIFF/EXR; e.g. `rms_e.fits` from `darks`) for the \
     `scmos-map` model; non-finite pixels are excluded",
)
.key("map_e")
.needed_as("a measured noise map (FILE, e-)");

/// Threshold rule of `emccd-pp`.
pub const PP_RULE: Setting = Setting::new(
    "pp_rule",
    "--pp-rule",
    Choice(&PpRule::NAMES),
    "`emccd-pp` threshold rule (a reconstruction of Basden et al. 2003): poisson-prior \
     (boundaries n(n+1)/lambda in units of g, lambda the sub-aperture mean or --pp-lambda), \
     pixel-prior (the same with each pixel's own mean level in the centred noiseless spot, in \
     photo-electrons: per-pixel thresholds, counts corrected to the posterior mean E[n | K] \
     under that prior) or equal-density (fixed, ~0.203, 0.719, 1.896 g ...); pixel-prior is \
     useful below 0.4 photo-electrons per pixel, the others above it (model_range says so)",
)
.default("poisson-prior");

/// Reference light level of `emccd-pp`, photo-electrons per pixel.
pub const PP_LAMBDA: Setting = Setting::new(
    "pp_lambda",
    "--pp-lambda",
    Real(Excluded(0.0), Included(MAX_PP_LAMBDA)),
    "`emccd-pp` reference light level, photo-electrons per pixel, > 0 and at most 1e5 (the \
     largest level the correction's thresholds can span; photon counting is for levels of a few \
     e- at most); default: the sub-aperture mean (not with --pp-rule pixel-prior, whose levels \
     are the pixels' own)",
)
.unit("photo-electrons per pixel");

/// Telegraph pixels of `scmos-rts`.
pub const RTS_TABLE: Setting = Setting::new(
    "rts_table",
    "--rts-table",
    Kind::Path,
    "Telegraph (RTS) pixels for `scmos-rts`: the rts.csv written by `darks` (with \
     --gain-e-per-adu, so that it has the levels in e-), of the camera of --map",
)
.needed_as("the telegraph pixels (rts.csv from darks)");

/// Row-noise amplitude of `scmos-correlated`, e- rms.
pub const ROW_NOISE_E: Setting = Setting::new(
    "row_noise_e",
    "--row-noise-e",
    NOISE_E,
    "Row-noise amplitude of `scmos-correlated`, e- rms: one draw per row of the window per \
     frame (darks: temporal_noise.row_rms_e in summary.json), at most 1e4 (no camera's)",
)
.unit("e-")
.needed_as("the row-noise amplitude (e- rms; 0 for none)");

/// Column-noise amplitude of `scmos-correlated`, e- rms.
pub const COLUMN_NOISE_E: Setting = Setting::new(
    "column_noise_e",
    "--column-noise-e",
    NOISE_E,
    "Column-noise amplitude of `scmos-correlated`, e- rms: one draw per column of the window \
     per frame (darks: temporal_noise.column_rms_e in summary.json), at most 1e4 (no camera's)",
)
.unit("e-")
.needed_as("the column-noise amplitude (e- rms; 0 for none)");

/// Frame-common noise amplitude of `scmos-correlated`, e- rms.
pub const FRAME_NOISE_E: Setting = Setting::new(
    "frame_noise_e",
    "--frame-noise-e",
    NOISE_E,
    "Frame-common noise amplitude of `scmos-correlated`, e- rms: one draw per frame shared by \
     every pixel (darks: temporal_noise.frame_rms_e in summary.json), at most 1e4; none: no \
     frame noise",
)
.unit("e-");

/// Dark frames of `scmos-frames`.
pub const DARK_FRAMES: Setting = Setting::new(
    "dark_frames",
    "--dark-frames",
    Paths,
    "Dark frames for `scmos-frames` (files, a directory or a glob; FITS, TIFF, OpenEXR): each \
     pixel's mean over the stack is subtracted and the values converted with --gain-e-per-adu",
)
.needed_as("the camera's dark frames (and `gain_e_per_adu`)");

/// Memory bound of the dark frames kept, MiB.
pub const DARK_FRAMES_MAX_MIB: Setting = Setting::new(
    "dark_frames_max_mib",
    "--dark-frames-max-mib",
    POSITIVE,
    "Memory bound of the dark frames kept for `scmos-frames`, MiB: a larger stack is sampled \
     uniformly (a fixed-seed reservoir, reproducible) down to what fits, as f32 e-",
)
.unit("MiB")
.default("512");

/// Conversion gain, e- per adu.
pub const GAIN_E_PER_ADU: Setting = Setting::new(
    "gain_e_per_adu",
    "--gain-e-per-adu",
    Real(Excluded(0.0), Included(MAX_GAIN_E_PER_ADU)),
    "Conversion gain of --dark-frames, e- per adu, at most 1e4 (a 16-bit converter would then \
     span 100 full wells; cameras run at 0.1 to a few tens)",
)
.unit("e- per adu");

/// The measured camera model of the `camera` readout.
pub const CAMERA: Setting = Setting::new(
    "camera",
    "--camera",
    Kind::Path,
    "Path of a measured camera model (a folder with camera.json and its maps, docs/camera.md) for the \
     `camera` model, read at the operating point of --exposure-s, --em-gain, --temperature-c",
)
.needed_as("a camera model folder (FILE)");

/// Exposure time of the camera model's operating point, s.
pub const EXPOSURE_S: Setting = Setting::new(
    "exposure_s",
    "--exposure-s",
    Real(Excluded(0.0), Included(MAX_EXPOSURE_S)),
    "Exposure time of each frame of --camera, s, > 0 and at most 86400; default: \
     1 / --frame-rate-hz, else the campaign's shortest dark exposure (camera.json `campaign`) \
     (the dark current's signal and shot noise scale with it)",
)
.unit("s");

/// Sensor temperature of the camera model's operating point, degrees C.
pub const TEMPERATURE_C: Setting = Setting::new(
    "temperature_c",
    "--temperature-c",
    Real(Included(-273.15), Included(200.0)),
    "Sensor temperature of --camera, degrees C, -273.15 to 200 (its dark current scaled by the \
     model's doubling temperature); default: the temperature its dark current was measured at",
)
.unit("degrees C");

/// Frame rate of the camera model's operating point, Hz.
pub const FRAME_RATE_HZ: Setting = Setting::new(
    "frame_rate_hz",
    "--frame-rate-hz",
    Real(Excluded(0.0), Included(1e6)),
    "Frame rate the camera of --camera runs at, Hz, > 0 and at most 1e6: the exposure is \
     1 / rate unless --exposure-s is given; default: the rate of the campaign's shortest dark \
     exposure (camera.json `campaign`)",
)
.unit("Hz");

/// The readout-model settings (`ModelParams`; Python's `**params`), in the order of `--help`.
pub const READOUT: &[&Setting] = &[
    &EM_GAIN,
    &STAGES,
    &EMCCD_READ_NOISE_E,
    &SIGMA_E,
    &GAUSSIAN_SWITCH_E,
    &REGISTER,
    &PATTERN_SEED,
    &PP_RULE,
    &PP_LAMBDA,
    &PDF,
    &PDF_MODEL,
    &MAP,
    &RTS_TABLE,
    &ROW_NOISE_E,
    &COLUMN_NOISE_E,
    &FRAME_NOISE_E,
    &DARK_FRAMES,
    &DARK_FRAMES_MAX_MIB,
    &GAIN_E_PER_ADU,
    &CAMERA,
    &EXPOSURE_S,
    &TEMPERATURE_C,
    &FRAME_RATE_HZ,
];

/// Sub-aperture sizes, px per side.
pub const SUBAP_PX: Setting = Setting::new(
    "subap_px",
    "--subap",
    Text,
    "Sub-aperture sizes, pixels per side (2 to 128), comma-separated (e.g. 4,8,16)",
)
.unit("px")
.default("16");

/// Spot shapes.
pub const SPOT: Setting = Setting::new(
    "spot",
    "--spot",
    TextList,
    "Spot shapes: airy:D (first-dark-ring diameter D px; airy:1,2,4 gives three spots) or \
     gauss:SX,SY (standard deviations in px); sizes >= 0.1 px. Repeat the option for several \
     Gaussians",
)
.unit("px")
.default("airy:2");

/// Pixel sampling of the spot.
pub const SAMPLING: Setting = Setting::new(
    "sampling",
    "--sampling",
    Choice(&["integrated", "point"]),
    "Pixel sampling of the spot: integrated over each pixel's area, or point values at pixel \
     centres",
)
.default("integrated");

/// Signal levels, photons per sub-aperture before QE.
pub const SIGNAL_PHOTONS: Setting = Setting::new(
    "signal_photons",
    "--signal",
    Text,
    "Signal levels, photons per sub-aperture before QE, comma-separated; signal x QE at most \
     1e9 photo-electrons (counts are 32-bit per pixel)",
)
.unit("photons")
.default("50");

/// Quantum efficiency.
pub const QE: Setting = Setting::new(
    "qe",
    "--qe",
    Real(Excluded(0.0), Included(1.0)),
    "Quantum efficiency (photo-electrons per photon, 0-1], applied to every model",
)
.default("1");

/// Monte-Carlo iterations per configuration.
pub const ITERS: Setting = Setting::new(
    "iters",
    "--iters",
    Whole(2, SimConfig::MAX_ITERS),
    "Monte-Carlo iterations (frames) per configuration, 2 to 1e9",
)
.unit("frames")
.default("10000");

/// Seed of every random stream.
pub const SEED: Setting = Setting::new(
    "seed",
    "--seed",
    ANY_SEED,
    "Seed of every random stream (a whole number, unitless); the same seed gives the same \
     results on any thread count",
)
.default("1");

/// Background levels subtracted before centroiding, e-.
pub const BG_GRID: Setting = Setting::new(
    "bg_grid",
    "--bg-grid",
    Text,
    "Background levels subtracted before centroiding, e-: `auto` (0-1 e- in 0.05 steps, \
     coarser above, 5 % steps up to the brightest expected pixel) or start:stop:step (at most \
     100,000 levels)",
)
.unit("e-")
.default("auto");

/// Half-width of the random spot offset, px.
pub const POSITION_HALF_RANGE_PX: Setting = Setting::new(
    "position_half_range_px",
    "--position-range",
    NON_NEGATIVE,
    "Half-width of the random spot offset, px: offsets are uniform in [-h, h] in x and y; at \
     most a quarter of the sub-aperture side (the spot stays mostly inside it)",
)
.unit("px")
.default("0.5");

/// Largest fraction of empty frames for an eligible background level.
pub const MAX_EMPTY_FRAC: Setting = Setting::new(
    "max_empty_frac",
    "--max-empty-frac",
    Real(Included(0.0), Included(1.0)),
    "Largest fraction of empty frames (nothing above the level) for a level to be eligible",
)
.default("0.01");

/// The run settings of a Monte-Carlo sweep (`simulate`, `effective`, `subaps`), in the order of
/// `--help`.
pub const RUN: &[&Setting] = &[
    &SUBAP_PX,
    &SPOT,
    &SAMPLING,
    &SIGNAL_PHOTONS,
    &QE,
    &ITERS,
    &SEED,
    &BG_GRID,
    &POSITION_HALF_RANGE_PX,
    &MAX_EMPTY_FRAC,
];

/// Centroiders of a run.
pub const CENTROIDER: Setting = Setting::new(
    "centroider",
    "--centroider",
    Text,
    "Centroiders, comma-separated `NAME[:PARAM]` (crate::centroid::CENTROIDERS); a PARAM fixes      the method's parameter instead of sweeping it",
)
.default("cog");

/// masked-cog's threshold, times the camera's median sigma.
pub const MASK_ABOVE: Setting = Setting::new(
    "mask_above",
    "--mask-above",
    POSITIVE,
    "Mask pixels whose read noise exceeds this many times the camera's median (sets the      parameter of masked-cog in --centroider; times the median sigma)",
);

/// The centroider settings (`simulate`, `effective`, `report`, `subaps`).
pub const CENTROID: &[&Setting] = &[&CENTROIDER, &MASK_ABOVE];

/// Target standard error of each effective read noise, e-.
pub const TARGET_SE_E: Setting = Setting::new(
    "target_se_e",
    "--target-se-e",
    Real(Included(0.0), Included(MAX_NOISE_E)),
    "Target standard error of each effective read noise, e- (0 = off), at most 1e4 (the largest \
     read noise of any setting: every value meets a larger target). A value is `ok` when its \
     SE is at most this or at most --target-rel times the value; until then iterations are \
     added (same random numbers, continued), up to --max-iters",
)
.unit("e-")
.default("0.05");

/// Relative precision target, a fraction of the value.
pub const TARGET_REL: Setting = Setting::new(
    "target_rel",
    "--target-rel",
    Real(Included(0.0), Included(1.0)),
    "Relative target, a unitless fraction of the value in [0, 1]: a value is also `ok` when its \
     SE is at most this fraction of it (0 = off; 0.02 = 2 %)",
)
.unit("(fraction of the value)")
.default("0.025");

/// Iteration cap per configuration of the effective read noise.
pub const MAX_ITERS: Setting = Setting::new(
    "max_iters",
    "--max-iters",
    Whole(2, SimConfig::MAX_ITERS),
    "Iteration cap per configuration, frames, at least --iters (where each starts; default: \
     80000, or --iters if larger): a value still short of its target there is `imprecise`. 0 \
     targets, or --max-iters = --iters, give a fixed count",
)
.unit("frames");

/// The precision settings of the effective read noise (`effective`, `report`, `subaps`).
pub const PRECISION: &[&Setting] = &[&TARGET_SE_E, &TARGET_REL, &MAX_ITERS];

/// The kind of camera a report describes.
pub const DETECTOR: Setting = Setting::new(
    "detector",
    "--detector",
    Choice(&["scmos", "emccd"]),
    "The camera type: scmos (effective read noise from the per-pixel noise) or emccd (EM gain \
     fit with the exact register, then the comparison with the fitted gain and read noise, and \
     the simple model's effective QE factor over the grid)",
)
.default("scmos");

/// Quantum efficiency of the EMCCD of a report.
pub const QE_EMCCD: Setting = Setting::new(
    "qe_emccd",
    "--qe-emccd",
    Real(Excluded(0.0), Included(1.0)),
    "Quantum efficiency of the EMCCD (the one compared with in an sCMOS report, this camera in \
     an EMCCD report), photo-electrons per photon, (0, 1]",
)
.default("1");

/// The configuration of a report's headline numbers.
pub const OPERATING_POINT: Setting = Setting::new(
    "operating_point",
    "--operating-point",
    Text,
    "The configuration of the headline numbers and of the comparison chart: sub-aperture size \
     (px per side), spot (airy:D or gauss:SX,SY, px) and signal (photons), e.g. 12,airy:4,100; \
     default: 8,airy:2,50",
);

/// The lenslet grid over the detector, px.
pub const SUBAP_GRID: Setting = Setting::new(
    "subap_grid",
    "--subap-grid",
    Text,
    "Lenslet grid over the detector: SIZE[,PITCH[,X0,Y0]] in px (square sub-apertures of SIZE \
     px, PITCH px apart, the first at column X0, row Y0)",
)
.unit("px");

/// The valid sub-apertures of the lenslet grid.
pub const SUBAP_MASK: Setting = Setting::new(
    "subap_mask",
    "--subap-mask",
    Kind::Path,
    "Mask of the valid sub-apertures (FITS/TIFF/EXR): one pixel per cell of the grid, non-zero \
     = valid",
);

/// A report's own settings (`report`, Python's `report()`); the lenslet grid is also
/// `subaps`'.
pub const REPORT: &[&Setting] = &[
    &DETECTOR,
    &QE_EMCCD,
    &OPERATING_POINT,
    &SUBAP_GRID,
    &SUBAP_MASK,
];

/// Every group, named as `--help` headings and Python's `SETTINGS` name them.
pub const GROUPS: &[(&str, &[&Setting])] = &[
    ("readout", READOUT),
    ("run", RUN),
    ("centroid", CENTROID),
    ("precision", PRECISION),
    ("report", REPORT),
];

/// A command whose option for a registry setting takes a default of its own.
#[derive(Debug, Clone, Copy)]
pub struct CommandDefault {
    /// The command (`effective`, `report`, ...).
    pub command: &'static str,
    /// The setting.
    pub setting: &'static Setting,
    /// The command's default as typed (None: none).
    pub default: Option<&'static str>,
    /// Why the command differs.
    pub why: &'static str,
}

/// Every command's own default for a registry setting; elsewhere the registry's holds.
pub const COMMAND_DEFAULTS: &[CommandDefault] = &[
    CommandDefault {
        command: "datasheet",
        setting: &OPERATING_POINT,
        default: Some("8,airy:2,50"),
        why: "the report's operating point, for the effective read noise of the dark noise map",
    },
    CommandDefault {
        command: "effective",
        setting: &SUBAP_PX,
        default: Some("4,6,8,10,12,14,16"),
        why: "the sub-aperture sizes of the paper's Fig. 12",
    },
    CommandDefault {
        command: "effective",
        setting: &SPOT,
        default: Some("airy:1,2,4,6,8,10"),
        why: "the spot diameters of the paper's Fig. 12",
    },
    CommandDefault {
        command: "effective",
        setting: &SIGNAL_PHOTONS,
        default: Some("20,50,100,200,500,1000"),
        why: "the six signal levels of the paper's Fig. 12",
    },
    CommandDefault {
        command: "report",
        setting: &SUBAP_PX,
        default: Some("4,6,8,10,12,16"),
        why: "the report's grid (crate::report::DEFAULT_SUBAPS_PX)",
    },
    CommandDefault {
        command: "report",
        setting: &SPOT,
        default: Some("airy:1,2,4,6,8,10"),
        why: "the report's grid (crate::report::DEFAULT_AIRY_DIAMETERS_PX)",
    },
    CommandDefault {
        command: "report",
        setting: &SIGNAL_PHOTONS,
        default: Some("20,50,100,200,500,1000"),
        why: "the report's grid (crate::report::DEFAULT_SIGNALS_PHOTONS)",
    },
    CommandDefault {
        command: "subaps",
        setting: &SUBAP_PX,
        default: Some("grid"),
        why: "the sub-aperture size is the SIZE of --subap-grid",
    },
    CommandDefault {
        command: "paper",
        setting: &SAMPLING,
        default: Some("point"),
        why: "the paper's figures are drawn with point sampling (SPEC section 3)",
    },
    CommandDefault {
        command: "ptc",
        setting: &EM_GAIN,
        default: Some("1"),
        why: "the EM gain the flats were taken at: 1 for a camera without EM gain",
    },
    CommandDefault {
        command: "emgain",
        setting: &STAGES,
        default: None,
        why: "the register's stages are a model choice of the fit: none means the Gamma model",
    },
    CommandDefault {
        command: "synth",
        setting: &DETECTOR,
        default: None,
        why: "a synthetic camera's type is always stated",
    },
    CommandDefault {
        command: "synth",
        setting: &EM_GAIN,
        default: None,
        why: "300 (the bundled synthetic EMCCD stacks') for --detector emccd, none (no \
              multiplication) with --camera: the run chooses, its help says so",
    },
    CommandDefault {
        command: "darks",
        setting: &EM_GAIN,
        default: None,
        why: "the EM gain of --camera's dark frames: none means no multiplication",
    },
    CommandDefault {
        command: "synth",
        setting: &ROW_NOISE_E,
        default: Some("0"),
        why: "a synthetic camera has no row noise unless asked",
    },
    CommandDefault {
        command: "synth",
        setting: &COLUMN_NOISE_E,
        default: Some("0"),
        why: "a synthetic camera has no column noise unless asked",
    },
];

/// The default of `setting` in `command`: the command's own, else the registry's.
pub fn default_in(command: &str, setting: &Setting) -> Option<&'static str> {
    COMMAND_DEFAULTS
        .iter()
        .find(|d| d.command == command && d.setting.field == setting.field)
        .map_or(setting.default, |d| d.default)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn light_level_and_precision_target_are_bounded_with_a_reason() {
        // Issue 31: both took any finite number (1e300 photo-electrons, 1e300 e- of SE).
        for (s, max) in [(&PP_LAMBDA, MAX_PP_LAMBDA), (&TARGET_SE_E, MAX_NOISE_E)] {
            assert!(s.parse(&max.to_string()).is_ok(), "{}", s.field);
            let err = s.parse(&(2.0 * max).to_string()).unwrap_err();
            assert!(err.contains("]"), "{}: {err}", s.field);
            assert!(s.parse("1e300").is_err(), "{}", s.field);
            assert!(s.help.contains("at most 1e"), "{}: {}", s.field, s.help);
        }
        assert!(PP_LAMBDA.parse("0").is_err() && TARGET_SE_E.parse("0").is_ok());
    }
}

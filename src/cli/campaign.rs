//! `detnoise campaign`: a characterisation campaign (dark and flat stacks at several exposure
//! times, EM gains and temperatures) read from a manifest, an EMVA 1288 descriptor or FITS
//! header keywords, each stack streamed once into its noise figures.

use std::ops::Bound::{Excluded, Included};
use std::path::PathBuf;

use super::args::real;
use super::darks::SampleArgs;
use super::progress::Terminal;
use crate::campaign::fit::{
    FitThresholds, HotRule, TemperatureTerm, DEFAULT_BAD_FIT_P_VALUE, MAX_CLASS_E_PER_S,
    MAX_CLASS_SIGMAS,
};
use crate::campaign::{
    run as run_campaign, CampaignInput, CampaignRun, KeywordOptions, MeasureOptions, StackKind,
};
use crate::error::Result;
use crate::io::Checksum;

/// The kind of every stack given as files (when no keyword says it).
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum KindArg {
    /// No light reaches the sensor.
    Dark,
    /// Uniform illumination.
    Flat,
}

/// Options of `detnoise campaign`.
#[derive(clap::Args, Debug)]
#[command(group(clap::ArgGroup::new("input").required(true).args(["manifest", "emva_descriptor", "files"])))]
pub struct CampaignArgs {
    /// CSV manifest, one row per stack, header
    /// `file,kind,exposure_s,em_gain,temperature_c,light_level` (kind dark or flat; exposure in
    /// s, EM gain in e-/e-, temperature in deg C; em_gain, temperature_c and light_level may be
    /// empty; files relative to the manifest's folder).
    #[arg(long, value_name = "FILE")]
    pub manifest: Option<PathBuf>,
    /// EMVA 1288 descriptor file, as the EMVA reference implementation reads it (`d TEXP_NS`
    /// darks, `b TEXP_NS PHOTONS` flats, `i PATH` images; exposure in ns).
    #[arg(long, value_name = "FILE")]
    pub emva_descriptor: Option<PathBuf>,
    /// FITS stacks, one file each, their conditions read from header keywords.
    #[arg(value_name = "FILES")]
    pub files: Vec<PathBuf>,
    /// Header keyword of the exposure time (s), with FILES.
    #[arg(long, default_value = "EXPTIME", value_name = "KEY")]
    pub exposure_key: String,
    /// Header keyword of the commanded EM gain (e-/e-), with FILES. Default: none (no EM
    /// register).
    #[arg(long, requires = "files", value_name = "KEY")]
    pub em_gain_key: Option<String>,
    /// Header keyword of the sensor temperature (deg C), with FILES. Default: none.
    #[arg(long, requires = "files", value_name = "KEY")]
    pub temperature_key: Option<String>,
    /// Header keyword that says dark or flat (e.g. IMAGETYP: `Dark Frame`, `Flat Field`),
    /// with FILES. Default: none (then --kind).
    #[arg(long, requires = "files", value_name = "KEY")]
    pub kind_key: Option<String>,
    /// What every stack of FILES is (checked against --kind-key when both are given).
    #[arg(long, value_enum, requires = "files")]
    pub kind: Option<KindArg>,
    /// Header keyword of a flat's light level (any unit), with FILES. Default: none.
    #[arg(long, requires = "files", value_name = "KEY")]
    pub light_key: Option<String>,
    /// Conversion gain (e- per adu): noise figures in e- and the EM fit's gain in e-/e-.
    #[arg(long, value_parser = real(Excluded(0.0), Included(crate::settings::MAX_GAIN_E_PER_ADU), "e- per adu"))]
    pub gain_e_per_adu: f64,
    /// Output directory: conditions.csv and campaign.json, written only when the run
    /// succeeds; an existing directory is replaced only if detnoise wrote it.
    #[arg(long)]
    pub out: PathBuf,
    /// Write into an existing --out that holds other files (they are never replaced or deleted).
    #[arg(long)]
    pub force: bool,
    /// Checksum of every input file recorded in campaign.json, computed from the frames read:
    /// blake3 (as `b3sum` prints it) or sha256 (as `sha256sum` prints it).
    #[arg(long, value_enum, default_value = "blake3")]
    pub checksum: Checksum,
    /// Record no checksums of the inputs.
    #[arg(long)]
    pub no_checksums: bool,
    /// Skip the EM-gain histogram fit of EMCCD darks (G and CIC per stack). Default: fitted.
    #[arg(long)]
    pub no_em_fit: bool,
    /// Temperature law of the dark current, D(T) = D_ref 2^((T - T_ref)/T_d) (EMVA 1288):
    /// `off` (one dark current for all darks), `fit` (T_d fitted, one for the sensor, with
    /// its SE; needs darks at two temperatures or more), or T_d itself in deg C (> 0). T_ref
    /// is the median temperature of the darks.
    #[arg(long, default_value = "off", value_parser = parse_temperature_term)]
    pub temperature_term: TemperatureTerm,
    /// Clipping and common mode of every stack, as `darks`.
    #[command(flatten)]
    pub samples: SampleArgs,
    /// Warm pixels: dark current above the median + K robust sigmas of the dark-current map,
    /// K in robust sigmas, > 0 and at most 1000 (beyond, no pixel of a million is classed by
    /// chance), below --hot-sigma.
    #[arg(long, default_value_t = 5.0, value_parser = real(Excluded(0.0), Included(MAX_CLASS_SIGMAS), "robust sigmas"))]
    pub warm_sigma: f64,
    /// Hot pixels: dark current above the median + K robust sigmas of the dark-current map,
    /// K in robust sigmas, > 0 and at most 1000, above --warm-sigma.
    #[arg(long, default_value_t = 25.0, value_parser = real(Excluded(0.0), Included(MAX_CLASS_SIGMAS), "robust sigmas"))]
    pub hot_sigma: f64,
    /// Warm pixels by absolute dark current instead: above this many e- per s, > 0 and at most
    /// 1e6 (a full well of ~1e6 e- filled within a second), with --hot-e-per-s.
    #[arg(long, requires = "hot_e_per_s", conflicts_with_all = ["warm_sigma", "hot_sigma"], value_parser = real(Excluded(0.0), Included(MAX_CLASS_E_PER_S), "e- per s"))]
    pub warm_e_per_s: Option<f64>,
    /// Hot pixels by absolute dark current instead: above this many e- per s, > 0 and at most
    /// 1e6, above --warm-e-per-s.
    #[arg(long, requires = "warm_e_per_s", value_parser = real(Excluded(0.0), Included(MAX_CLASS_E_PER_S), "e- per s"))]
    pub hot_e_per_s: Option<f64>,
    /// A pixel's decomposition fit is flagged bad (fit_quality.fits) when its chi2 has a
    /// p-value below this, unitless, in (0, 1).
    #[arg(long, default_value_t = DEFAULT_BAD_FIT_P_VALUE, value_parser = real(Excluded(0.0), Excluded(1.0), ""))]
    pub bad_fit_p_value: f64,
}

/// `off`, `fit` or a doubling temperature (deg C, > 0).
pub fn parse_temperature_term(text: &str) -> std::result::Result<TemperatureTerm, String> {
    match text {
        "off" => Ok(TemperatureTerm::Off),
        "fit" => Ok(TemperatureTerm::Fit { reference_c: None }),
        _ => match text.parse::<f64>() {
            Ok(t) if t > 0.0 && t.is_finite() => Ok(TemperatureTerm::Given {
                doubling_c: t,
                reference_c: None,
            }),
            _ => Err(format!(
                "`{text}`: off, fit, or a doubling temperature in deg C (> 0)"
            )),
        },
    }
}

impl CampaignArgs {
    /// The run these options ask for.
    pub fn job(&self) -> CampaignRun {
        let input = match (&self.manifest, &self.emva_descriptor) {
            (Some(m), _) => CampaignInput::Manifest(m.clone()),
            (None, Some(d)) => CampaignInput::Emva(d.clone()),
            (None, None) => CampaignInput::Keywords {
                files: self.files.clone(),
                options: KeywordOptions {
                    exposure_key: self.exposure_key.clone(),
                    em_gain_key: self.em_gain_key.clone(),
                    temperature_key: self.temperature_key.clone(),
                    kind_key: self.kind_key.clone(),
                    kind: self.kind.map(|k| match k {
                        KindArg::Dark => StackKind::Dark,
                        KindArg::Flat => StackKind::Flat,
                    }),
                    light_key: self.light_key.clone(),
                },
            },
        };
        CampaignRun {
            input,
            out: self.out.clone(),
            force: self.force,
            measure: MeasureOptions {
                gain_e_per_adu: self.gain_e_per_adu,
                checksum: (!self.no_checksums).then_some(self.checksum),
                em_fit: !self.no_em_fit,
                clip: self.samples.clip(),
                common_mode: self.samples.common_mode,
            },
            temperature: self.temperature_term,
            thresholds: FitThresholds {
                hot: match (self.warm_e_per_s, self.hot_e_per_s) {
                    (Some(warm_e_per_s), Some(hot_e_per_s)) => HotRule::Absolute {
                        warm_e_per_s,
                        hot_e_per_s,
                    },
                    _ => HotRule::Robust {
                        warm_sigmas: self.warm_sigma,
                        hot_sigmas: self.hot_sigma,
                    },
                },
                bad_fit_p_value: self.bad_fit_p_value,
            },
        }
    }
}

/// Run `detnoise campaign`.
pub fn run(args: &CampaignArgs) -> Result<()> {
    let r = run_campaign(&args.job(), &Terminal::default())?;
    let (bytes, secs) = (r.stored_bytes as f64, r.read_seconds);
    eprintln!(
        "read {} of samples in {secs:.3} s ({}/s)",
        super::darks::decimal_size(bytes),
        super::darks::decimal_size(bytes / secs.max(1e-9))
    );
    for m in &r.stacks {
        let s = &m.stats;
        let c = &s.condition;
        let em = match &m.em_fit {
            Some(Ok(f)) => format!(
                ", EM fit G {:.1} +/- {:.1} e-/e-, {:.4} e-/pixel",
                f.em_gain, f.em_gain_se, f.lambda_e
            ),
            _ => String::new(),
        };
        eprintln!(
            "{}: {:?} t {} s{}{}: {} frames, total rms {:.4} adu{em}",
            s.file.display(),
            c.kind,
            c.exposure_s,
            c.em_gain
                .map(|g| format!(" EM gain {g}"))
                .unwrap_or_default(),
            c.temperature_c
                .map(|t| format!(" {t} C"))
                .unwrap_or_default(),
            s.frames,
            s.temporal.total_rms_adu.unwrap_or(f64::NAN),
        );
    }
    eprintln!("wrote {}", r.out.display());
    Ok(())
}

//! `detnoise effective`: the effective Gaussian read noise over a grid of configurations.

use super::args::{real, CentroiderArgs, DetectorArgs, PrecisionArgs, SweepArgs};
use super::progress::Terminal;
use crate::detector::ModelSpec;
use crate::effective::{
    effective_table_with, write_tables, EffectiveRecord, QePrecision, QE_TABLE_NAMES, TABLE_NAMES,
};
use crate::output::{DirPlan, OutputDir};
use crate::settings::{self, default_in};
use crate::Result;
use std::fmt::Write as _;
use std::ops::Bound::{Included, Unbounded};
use std::path::PathBuf;

/// Options of `detnoise effective`.
#[derive(clap::Args, Debug)]
#[command(mut_arg("subap", |a| a.default_value(default_in("effective", &settings::SUBAP_PX))))]
#[command(mut_arg("spot", |a| a.default_value(default_in("effective", &settings::SPOT))))]
#[command(mut_arg("signal", |a| a.default_value(default_in("effective", &settings::SIGNAL_PHOTONS))))]
#[command(mut_arg("iters", |a| a.help(
    "Starting Monte-Carlo iterations (frames) per configuration, 2 to 1e9: more are added, up to \
     --max-iters, until the precision target is met"
)))]
pub struct EffectiveArgs {
    /// The detector whose effective read noise is wanted: scmos-random (the rms pdf),
    /// scmos-map (needs --map), or any other model (every model is listed with --help).
    #[arg(long, default_value = "scmos-random")]
    pub model: String,
    /// The Monte-Carlo sweep: sub-aperture sizes (px), spots, signals (photons), iterations, seed.
    #[command(flatten)]
    pub sweep: SweepArgs,
    /// Precision target of each value and the iteration cap.
    #[command(flatten)]
    pub precision: PrecisionArgs,
    /// Instead of the effective read noise, solve for the QE factor q of the paper's simple
    /// model (emccd-simple:q: Poisson of q x the flux, read noise --emccd-read-noise /
    /// --em-gain) whose R equals the --model's (EMCCD models only; the paper's q is 0.5).
    /// Writes effective_qe.csv, effective_qe.json and one chart per spot
    /// (effective_qe_airy-2.png and .svg for airy:2) instead of the effective-noise files.
    #[arg(long, long_help = simple_qe_long_help())]
    pub simple_qe: bool,
    /// Target standard error of each QE factor with --simple-qe, unitless (0 = off); a factor
    /// is also `ok` when its SE is at most --target-rel times it, and --max-iters caps it.
    #[arg(long, default_value_t = QePrecision::DEFAULT_TARGET_SE, value_parser = real(Included(0.0), Unbounded, "(QE factor)"))]
    pub qe_target_se: f64,
    /// Readout-model parameters: EM gain (e-/e-), read noise (e- rms), sCMOS pdf and map.
    #[command(flatten)]
    pub detector: DetectorArgs,
    /// The centroiders the detector is read through: sigma_eff is then the uniform camera that,
    /// read through the same centroider (its parameter re-optimised), matches this camera's R
    /// (the number for a simulator running that centroider); sigma_cog_equiv_e is the uniform
    /// camera that matches it under plain cog. Heatmaps of a centroider other than cog carry its name, e.g.
    /// effective_noise_S50_masked-cog.png.
    #[command(flatten)]
    pub centroiders: CentroiderArgs,
    /// Output directory: effective_noise.csv, effective_noise.json and one heatmap per signal
    /// (e.g. effective_noise_S50.png and .svg for 50 photons). Written only when the run succeeds; an existing
    /// directory is replaced only if detnoise wrote it.
    #[arg(long)]
    pub out: PathBuf,
    /// Write into an existing --out that holds other files (they are never replaced or deleted).
    #[arg(long)]
    pub force: bool,
}

/// Files `effective` writes into its directory (glob patterns): the effective-noise files, or
/// with `--simple-qe` the QE-factor files.
pub const OUTPUT_NAMES: [&str; 8] = [
    TABLE_NAMES[0],
    TABLE_NAMES[1],
    "effective_noise_S*.png",
    "effective_noise_S*.svg",
    QE_TABLE_NAMES[0],
    QE_TABLE_NAMES[1],
    "effective_qe_*.png",
    "effective_qe_*.svg",
];

impl EffectiveArgs {
    /// Check every option (model, detector, sweep lists) before any file is read.
    pub fn validate(&self) -> Result<()> {
        let spec = ModelSpec::parse(&self.model)?;
        if self.simple_qe && !spec.is_emccd() {
            return Err(crate::Error::invalid(
                "--simple-qe",
                format!(
                    "the QE factor of the simple EMCCD model is solved for EMCCD models; {} is \
                     an sCMOS model",
                    spec.name()
                ),
            ));
        }
        self.detector.validate(std::slice::from_ref(&spec))?;
        self.centroiders.specs()?;
        self.sweep.validate()?;
        let precision = self.precision.precision(self.sweep.iters());
        precision.validate(self.sweep.iters())?;
        QePrecision::with(&precision, self.qe_target_se).validate(self.sweep.iters())
    }
}

/// Write the table (CSV, JSON) and the heatmaps into `dir`; returns the heatmaps' paths.
pub fn write_outputs(records: &[EffectiveRecord], dir: &OutputDir) -> Result<Vec<PathBuf>> {
    write_tables(records, &dir.path(""))?;
    crate::charts::heatmaps::effective_heatmaps(records, dir)
}

/// Entry point of `detnoise effective`.
pub fn run_cli(args: &EffectiveArgs) -> Result<()> {
    args.validate()?;
    let dir = OutputDir::prepare(
        &args.out,
        DirPlan {
            command: "effective",
            force: args.force,
            inputs: &args.detector.input_files(),
            names: &OUTPUT_NAMES,
        },
    )?;
    let specs = [ModelSpec::parse(&args.model)?];
    let params = args.detector.params()?;
    let configs = args.sweep.configs()?;
    let precision = args.precision.precision(args.sweep.iters());
    if args.simple_qe {
        let precision = QePrecision::with(&precision, args.qe_target_se);
        qe::run(&configs, &specs, &params, &precision, &dir)?;
        let path = dir.commit()?;
        eprintln!("wrote {}", path.display());
        return Ok(());
    }
    let centroiders = args.centroiders.specs()?;
    let records = effective_table_with(
        &configs,
        &specs,
        &centroiders,
        &params,
        &precision,
        &Terminal::default(),
    )?;
    write_outputs(&records, &dir)?;
    print!("{}", terminal_table(&records));
    let path = dir.commit()?;
    eprintln!("wrote {}", path.display());
    Ok(())
}

mod qe;
mod table;
pub use table::{qe_terminal_table, terminal_table};

/// The long help of `--simple-qe`: what it solves, its files, and every status.
fn simple_qe_long_help() -> String {
    let mut h = String::from(
        "Instead of the effective read noise, solve for the QE factor q of the paper's simple \
         EMCCD model (emccd-simple:q: Poisson of q x the flux plus read noise --emccd-read-noise \
         / --em-gain, e-) whose centroid error R equals the --model's, per configuration, with \
         its standard error from paired differences on common random numbers (the paper's q is \
         0.5). EMCCD models only. Writes effective_qe.csv and effective_qe.json (qe_factor, \
         qe_factor_se, paper_z = (q - 0.5) / SE, status) and one chart of q against signal per \
         spot (effective_qe_airy-2.png and .svg for airy:2) instead of the effective-noise \
         files.\n\nStatuses of the QE factor (the `status` column):",
    );
    for s in crate::effective::QeStatus::ALL {
        let _ = write!(h, "\n  {:<18} {}", s.label(), s.meaning());
    }
    h
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::effective::{Effective, Precision, Status};
    use crate::montecarlo::SimConfig;

    #[test]
    fn terminal_table_shows_status_words_and_fits_100_columns() {
        let cfg = SimConfig::paper(16);
        let e = |sigma: f64, se: f64, target: Option<f64>, status| Effective {
            sigma_eff_e: sigma,
            sigma_eff_se_e: se,
            sigma_cog_equiv_e: sigma,
            sigma_cog_equiv_se_e: se,
            target_se_e: target,
            iters: 80_000,
            r_px: 0.5,
            r_se_px: 0.01,
            b_opt_e: 2.0,
            param_name: None,
            param_opt: None,
            sigma_grid_e: vec![],
            r_const_px: vec![],
            status,
            parts: Default::default(),
        };
        let records: Vec<EffectiveRecord> = [
            e(1.234, 0.021, Some(0.05), Status::Ok),
            e(18.57, 6.58, Some(0.37), Status::Imprecise),
            e(0.0, 0.01, Some(0.05), Status::LowerBound),
            e(f64::NAN, f64::NAN, None, Status::Unreachable),
            e(f64::NAN, f64::INFINITY, None, Status::NoEligibleLevel),
        ]
        .iter()
        .map(|e| EffectiveRecord::new("scmos-random".into(), &cfg, e))
        .collect();
        let text = terminal_table(&records);
        assert!(
            !text.to_lowercase().contains("nan") && !text.contains("inf"),
            "{text}"
        );
        assert!(text.lines().all(|l| l.chars().count() <= 100), "{text}");
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines.len(), 2 + records.len());
        assert!(lines[2].contains("1.234") && lines[2].ends_with(" ok"));
        assert!(lines[3].contains("18.570") && lines[3].contains("6.580"));
        assert!(lines[3].ends_with(" imprecise") && lines[3].contains("80000"));
        for (line, s) in lines[2..].iter().zip(Status::ALL) {
            assert!(line.ends_with(&format!(" {}", s.label())), "{line}");
        }
        assert!(
            lines[5].contains("        -        -        -  unreachable"),
            "{text}"
        );
    }

    #[test]
    fn the_cog_equivalent_column_appears_only_beside_another_centroider() {
        let cfg = SimConfig::paper(8);
        let e = Effective {
            sigma_eff_e: 1.397,
            sigma_eff_se_e: 0.02,
            sigma_cog_equiv_e: 0.2196,
            sigma_cog_equiv_se_e: 0.046,
            target_se_e: Some(0.05),
            iters: 10_000,
            r_px: 0.095,
            r_se_px: 0.0005,
            b_opt_e: 0.45,
            param_name: None,
            param_opt: None,
            sigma_grid_e: vec![],
            r_const_px: vec![],
            status: Status::Ok,
            parts: Default::default(),
        };
        let mut record = EffectiveRecord::new("scmos-map".into(), &cfg, &e);
        let cog_only = terminal_table(std::slice::from_ref(&record));
        assert!(!cog_only.contains("cog_equiv"), "{cog_only}");
        record.centroider = "wcog".into();
        let text = terminal_table(&[record]);
        let lines: Vec<&str> = text.lines().collect();
        assert!(lines[1].contains(" cog_equiv  status"), "{text}");
        assert!(
            lines[2].contains("1.397") && lines[2].contains(" 0.220  ok"),
            "{text}"
        );
        assert!(text.lines().all(|l| l.chars().count() <= 100), "{text}");
    }

    #[test]
    fn help_states_the_precision_rule_and_every_status() {
        let mut cmd = super::super::command();
        let sub = cmd.find_subcommand_mut("effective").expect("subcommand");
        let help = sub.render_long_help().to_string();
        for s in Status::ALL {
            assert!(help.contains(s.label()), "--help lacks {}", s.label());
        }
        for flag in [
            "--target-se-e",
            "--target-rel",
            "--max-iters",
            "Starting Monte-Carlo",
        ] {
            assert!(help.contains(flag), "--help lacks {flag}");
        }
        assert!(help.contains("--max-empty-frac") && !help.contains("`max_empty_frac`"));
    }

    #[test]
    fn the_default_cap_rises_to_the_starting_iterations_and_a_given_one_is_checked() {
        use clap::Parser;
        #[derive(clap::Parser)]
        struct Cli {
            #[command(flatten)]
            p: PrecisionArgs,
        }
        let parse = |args: &[&str]| Cli::try_parse_from([&["x"], args].concat()).unwrap().p;
        let default = parse(&[]);
        assert_eq!(default.precision(10_000), Precision::default());
        assert_eq!(default.precision(200_000).max_iters, 200_000);
        let given = parse(&["--max-iters", "5000", "--target-rel", "0"]);
        assert_eq!(given.precision(10_000).target_rel, 0.0);
        let err = given.precision(10_000).validate(10_000).unwrap_err();
        assert!(err.to_string().contains("`max_iters`"), "{err}");
    }
}

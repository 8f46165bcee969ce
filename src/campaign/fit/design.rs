//! The design of a decomposition: the dark conditions with the EM gain each is fitted at, the
//! parameters, and every check of the input and the options, made before any fit.

use rayon::prelude::*;

use super::options::{ConversionGain, DecomposeOptions, EmGainFit};
use super::wls::Normal;
use crate::campaign::{ConditionStats, StackKind};
use crate::detector::register::{excess_noise_factor_sq, EmRegister};
use crate::error::{Error, Result};
use crate::stats::median;

/// The field named by a refused design (the campaign's set of conditions).
pub(super) const CAMPAIGN: &str = "campaign";

/// One dark condition as the fit uses it.
pub(super) struct Cond<'a> {
    /// Its moments.
    pub stats: &'a ConditionStats,
    /// Exposure time (s).
    pub t: f64,
    /// EM gain used (e-/e-; 1 without a register).
    pub g: f64,
    /// Its SE (e-/e-).
    pub g_se: f64,
    /// Temperature (deg C).
    pub temp: Option<f64>,
    /// Excess noise factor squared of the register at `g` (1 without a register): the
    /// variance of the output per unit of mean signal, in units of the gain.
    pub enf2: f64,
}

/// The dark conditions and the parameters of every pixel's fit.
pub(super) struct Design<'a> {
    /// The dark conditions, in input order.
    pub conds: Vec<Cond<'a>>,
    /// Image rows.
    pub rows: usize,
    /// Image columns.
    pub cols: usize,
    /// rows x cols.
    pub npix: usize,
    /// An EM register.
    pub register: bool,
    /// CIC fitted.
    pub cic: bool,
    /// Notes for the summary.
    pub notes: Vec<String>,
    /// Each condition's median over pixels of the mean (adu) and of the variance (adu^2).
    pub typical: Vec<[f64; 2]>,
    /// Each condition's least signal above the offset (adu) the weights assume: the median
    /// over pixels of the first fit's signal (0 until `pixels::set_signal_floor` runs).
    pub signal_floor_adu: Vec<f64>,
}

fn distinct(values: impl Iterator<Item = f64>) -> Vec<f64> {
    let mut v: Vec<f64> = values.collect();
    v.sort_by(f64::total_cmp);
    v.dedup_by(|a, b| (*a - *b).abs() <= 1e-9 * b.abs().max(1e-300));
    v
}

fn list(values: &[f64]) -> String {
    values
        .iter()
        .map(|v| format!("{v}"))
        .collect::<Vec<_>>()
        .join(", ")
}

impl<'a> Design<'a> {
    /// Check `stats` and `opts` and set up the fit; refuses a design that cannot separate the
    /// requested terms, naming what is missing.
    pub fn new(stats: &'a [ConditionStats], opts: &DecomposeOptions) -> Result<Self> {
        check_options(opts)?;
        let darks: Vec<&ConditionStats> = stats
            .iter()
            .filter(|s| s.condition.kind == StackKind::Dark)
            .collect();
        let first = *darks.first().ok_or_else(|| {
            Error::invalid(
                CAMPAIGN,
                "no dark stacks: the decomposition fits darks at two or more exposure times",
            )
        })?;
        let (rows, cols) = (first.rows, first.cols);
        let npix = rows * cols;
        let register = first.condition.em_gain.is_some();
        for s in &darks {
            check_stack(s, first, npix, register)?;
        }
        if let ConversionGain::Map(m) = &opts.conversion_gain {
            if m.len() != npix {
                return Err(Error::invalid(
                    "conversion_gain",
                    format!(
                        "the gain map has {} pixels, the stacks {rows}x{cols} = {npix}",
                        m.len()
                    ),
                ));
            }
        }
        let mut notes = Vec::new();
        if !register && !opts.em_gains.is_empty() {
            return Err(Error::invalid(
                "em_gains",
                "fitted EM gains given, but the darks have no EM gain (no register)",
            ));
        }
        let conds = darks
            .iter()
            .map(|s| {
                let (g, g_se) = gain_used(s, &opts.em_gains)?;
                if register {
                    EmRegister::check(g, opts.register_stages, "em_gain")?;
                }
                Ok(Cond {
                    stats: s,
                    t: s.condition.exposure_s,
                    g,
                    g_se,
                    temp: s.condition.temperature_c,
                    enf2: if register {
                        excess_noise_factor_sq(g, opts.register_stages)
                    } else {
                        1.0
                    },
                })
            })
            .collect::<Result<Vec<_>>>()?;
        if register && opts.em_gains.is_empty() {
            notes.push(
                "EM gains: the commanded values are used as exact (no fitted gains given); C and \
                 D scale as 1/G"
                    .into(),
            );
        }
        let cic = register && opts.fit_cic;
        if !register {
            notes.push(
                "no EM register: CIC cannot be told from the offset (nothing multiplies it but \
                 1), so it is part of F and there is no CIC map"
                    .into(),
            );
        } else if !opts.fit_cic {
            notes.push("CIC not fitted (fit_cic off): it is part of the offset F".into());
        }
        let typical = conds
            .par_iter()
            .map(|c| [median(&c.stats.mean_adu), median(&c.stats.var_adu2)])
            .collect();
        let mut design = Design {
            signal_floor_adu: vec![0.0; conds.len()],
            typical,
            conds,
            rows,
            cols,
            npix,
            register,
            cic,
            notes,
        };
        design.check_separable()?;
        if design.dof() == 0 {
            // Solvable, but nothing is left to judge the fit: say so rather than refuse.
            design.notes.push(format!(
                "{} dark conditions for {} parameters per pixel: every pixel is fitted exactly, \
                 so there is no fit quality (reduced chi2 NaN) and no bad-fit flag",
                design.conds.len(),
                design.npar()
            ));
        }
        Ok(design)
    }

    /// Parameters per pixel: F, (C,) D.
    pub fn npar(&self) -> usize {
        if self.cic {
            3
        } else {
            2
        }
    }

    /// Degrees of freedom of each pixel's fit.
    pub fn dof(&self) -> usize {
        self.conds.len() - self.npar()
    }

    /// Index of D among the parameters.
    pub fn d_index(&self) -> usize {
        self.npar() - 1
    }

    /// The design row of condition `i` for a pixel of inverse conversion gain `k` (adu/e-),
    /// with the temperature factor `f` of that condition: the derivatives of the mean (adu)
    /// by F, (C,) D.
    #[inline]
    pub fn row(&self, i: usize, k: f64, f: f64) -> [f64; 3] {
        let c = &self.conds[i];
        self.row_at(c.g, c.t, k, f)
    }

    /// The design row at EM gain `g`, exposure `t` (s), inverse conversion gain `k` and
    /// temperature factor `f`.
    #[inline]
    pub fn row_at(&self, g: f64, t: f64, k: f64, f: f64) -> [f64; 3] {
        let gk = g * k;
        if self.cic {
            [1.0, gk, gk * t * f]
        } else {
            [1.0, gk * t * f, 0.0]
        }
    }

    /// Refuse a design that cannot separate the parameters, naming what is missing.
    fn check_separable(&self) -> Result<()> {
        let times = distinct(self.conds.iter().map(|c| c.t));
        if times.len() < 2 {
            return Err(Error::invalid(
                CAMPAIGN,
                format!(
                    "dark current needs darks at two or more exposure times; all {} dark stacks \
                     are at {} s",
                    self.conds.len(),
                    list(&times)
                ),
            ));
        }
        if self.cic {
            let gains = distinct(self.conds.iter().map(|c| c.g));
            if gains.len() < 2 {
                return Err(Error::invalid(
                    CAMPAIGN,
                    format!(
                        "CIC needs darks at two or more EM gains (all are at G = {}); add a gain \
                         or turn `fit_cic` off (CIC is then part of the offset)",
                        list(&gains)
                    ),
                ));
            }
        }
        let mut n = Normal::<3>::new(self.npar());
        for i in 0..self.conds.len() {
            n.add(&self.row(i, 1.0, 1.0), 0.0, 1.0);
        }
        if n.solve().is_none() {
            let conds: Vec<String> = self
                .conds
                .iter()
                .map(|c| format!("(G {}, t {} s)", c.g, c.t))
                .collect();
            return Err(Error::invalid(
                CAMPAIGN,
                format!(
                    "the conditions {} do not separate offset, CIC and dark current: CIC needs two \
                     gains and dark current two exposure times at one gain",
                    conds.join(", ")
                ),
            ));
        }
        Ok(())
    }
}

/// The EM gain a condition is fitted at: the fitted one for its commanded gain if given, the
/// commanded one otherwise (1 without a register).
fn gain_used(s: &ConditionStats, fits: &[EmGainFit]) -> Result<(f64, f64)> {
    let Some(g) = s.condition.em_gain else {
        return Ok((1.0, 0.0));
    };
    if fits.is_empty() {
        return Ok((g, 0.0));
    }
    let found: Vec<&EmGainFit> = fits
        .iter()
        .filter(|f| (f.commanded - g).abs() <= 1e-9 * g)
        .collect();
    match found.as_slice() {
        [f] => Ok((f.gain, f.se)),
        [] => Err(Error::invalid(
            "em_gains",
            format!(
                "no fitted EM gain for commanded gain {g} of {} (fitted gains are given for {}); \
                 give one for every commanded gain or none",
                s.file.display(),
                list(&fits.iter().map(|f| f.commanded).collect::<Vec<_>>())
            ),
        )),
        _ => Err(Error::invalid(
            "em_gains",
            format!("commanded gain {g} is given {} times", found.len()),
        )),
    }
}

fn check_options(opts: &DecomposeOptions) -> Result<()> {
    match &opts.conversion_gain {
        ConversionGain::Global {
            e_per_adu,
            se_e_per_adu,
        } => {
            if !(e_per_adu.is_finite() && *e_per_adu > 0.0) {
                return Err(Error::invalid(
                    "conversion_gain",
                    format!("{e_per_adu} e-/adu must be finite and > 0"),
                ));
            }
            if !(se_e_per_adu.is_finite() && *se_e_per_adu >= 0.0) {
                return Err(Error::invalid(
                    "conversion_gain",
                    format!("standard error {se_e_per_adu} e-/adu must be finite and >= 0"),
                ));
            }
        }
        ConversionGain::Map(m) => {
            if let Some(i) = m.iter().position(|k| !(k.is_finite() && *k > 0.0)) {
                return Err(Error::invalid(
                    "conversion_gain",
                    format!(
                        "the gain map has {} e-/adu at pixel {i}: every gain must be finite and > 0",
                        m[i]
                    ),
                ));
            }
        }
    }
    for f in &opts.em_gains {
        let gains_ok = [f.commanded, f.gain]
            .iter()
            .all(|g| g.is_finite() && *g >= 1.0);
        if !(gains_ok && f.se.is_finite() && f.se >= 0.0) {
            return Err(Error::invalid(
                "em_gains",
                format!(
                    "commanded {} fitted {} SE {}: gains must be finite and >= 1 e-/e-, the SE \
                     finite and >= 0",
                    f.commanded, f.gain, f.se
                ),
            ));
        }
    }
    super::FitThresholds {
        hot: opts.hot,
        bad_fit_p_value: opts.bad_fit_p_value,
    }
    .check()
}

fn check_stack(
    s: &ConditionStats,
    first: &ConditionStats,
    npix: usize,
    register: bool,
) -> Result<()> {
    if (s.rows, s.cols) != (first.rows, first.cols) {
        return Err(Error::input(
            &s.file,
            format!(
                "frames are {}x{} but those of {} are {}x{}: a campaign has one shape",
                s.rows,
                s.cols,
                first.file.display(),
                first.rows,
                first.cols
            ),
        ));
    }
    if s.mean_adu.len() != npix || s.var_adu2.len() != npix {
        return Err(Error::input(
            &s.file,
            format!(
                "{} means and {} variances for {}x{} pixels",
                s.mean_adu.len(),
                s.var_adu2.len(),
                s.rows,
                s.cols
            ),
        ));
    }
    if s.frames < 2 {
        return Err(Error::input(
            &s.file,
            format!(
                "{} frame(s): a temporal variance needs two or more",
                s.frames
            ),
        ));
    }
    let c = &s.condition;
    if !(c.exposure_s.is_finite() && c.exposure_s >= 0.0) {
        return Err(Error::input(
            &s.file,
            format!("exposure time {} s must be finite and >= 0", c.exposure_s),
        ));
    }
    match (c.em_gain, register) {
        (Some(g), true) if !(g.is_finite() && g >= 1.0) => Err(Error::input(
            &s.file,
            format!("EM gain {g} must be finite and >= 1 e-/e-"),
        )),
        (None, true) | (Some(_), false) => Err(Error::input(
            &s.file,
            format!(
                "{} an EM gain but {} {}: the darks of a campaign are all EMCCD or all without \
                 a register",
                if c.em_gain.is_some() { "has" } else { "has no" },
                first.file.display(),
                if register { "has one" } else { "has none" }
            ),
        )),
        _ => Ok(()),
    }
}

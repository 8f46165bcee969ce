//! What the wavefront sensor can do about its camera's noise: the measured map and the fitted
//! pdf read through each centroider (at the operating point, and over the grid's sub-aperture
//! sizes for the map). Methods are compared by R itself: each one's R relative to `cog`'s on
//! the same frames, with the paired SE of that one experiment. Each method's effective read
//! noise is the uniform camera with the same R under the same method (the number for a
//! simulator running it), its cog-equivalent beside it; and the paper's sCMOS-against-EMCCD
//! comparison is redone with plain `cog` and with each side's best centroider.

use serde::Serialize;

use super::grid::Grid;
use super::point::OperatingPoint;
use crate::centroid::CentroiderSpec;
use crate::detector::Readout;
use crate::detector::{ModelParams, ModelSpec};
use crate::effective::{effective_table_with, EffectiveRecord, Precision, Status};
use crate::montecarlo::{sweep_with, Arm, Experiment, SimConfig, SimRecord, SimResult, Term};
use crate::plot::{LineChart, Series};
use crate::progress::{Observer, Silent};
use crate::spot::Spot;
use crate::Result;
use std::path::Path;

/// Files the section writes.
pub const CENTROIDER_FILES: [&str; 6] = [
    "centroiders.csv",
    "centroiders.json",
    "centroiders.png",
    "centroiders_vs_emccd.csv",
    "centroiders_vs_emccd.json",
    "centroiders_vs_emccd.png",
];

/// One model read through one centroider in one configuration.
#[derive(Debug, Clone, Serialize)]
pub struct CentroiderRow {
    /// The camera model (`scmos-map`: the measured map; `scmos-random`: the fitted pdf).
    pub model: String,
    /// Sub-aperture size (px per side).
    pub subap_px: usize,
    /// Spot.
    pub spot: String,
    /// Signal (photons per sub-aperture).
    pub signal_photons: f64,
    /// Centroider.
    pub centroider: String,
    /// Name (with unit) of its parameter; None for `cog` and `ivw-cog`.
    pub centroider_param: Option<&'static str>,
    /// Its parameter at the optimum.
    pub centroider_param_opt: Option<f64>,
    /// The camera's R under this centroider (px) and its SE.
    pub r_px: f64,
    /// Standard error of R (px).
    pub r_se_px: f64,
    /// R_crlb / R: the Cramer-Rao floor over R (1 = efficient); None when not computed.
    pub crlb_efficiency: Option<f64>,
    /// R lies more than 3 SE under the floor: the centroid is biased.
    pub below_crlb: Option<bool>,
    /// The uniform camera with the same R under this same centroider (its parameter
    /// re-optimised) (e-): the read noise for a simulator running it; None without a value.
    pub sigma_eff_e: Option<f64>,
    /// Its standard error (e-).
    pub sigma_eff_se_e: Option<f64>,
    /// The uniform camera with the same R under plain `cog` (e-); None without a value.
    pub sigma_cog_equiv_e: Option<f64>,
    /// Its standard error (e-).
    pub sigma_cog_equiv_se_e: Option<f64>,
    /// How sigma_eff was settled.
    pub status: Status,
    /// R under this centroider relative to R under `cog`, R / R(cog) - 1, on the same frames
    /// (one run of the configuration with every centroider; negative = lower R than `cog`);
    /// None for `cog`.
    pub r_vs_cog: Option<f64>,
    /// Its standard error, paired: from the block means of that one run, which carry the
    /// correlation of the two methods' errors on shared frames.
    pub r_vs_cog_se: Option<f64>,
    /// `lower` or `higher` (than `cog`'s R, by more than 2 SE), `tie`, or `reference` (`cog`).
    pub vs_cog: String,
}

/// The best centroider of each side at one signal, the two compared.
#[derive(Debug, Clone, Serialize)]
pub struct VersusRow {
    /// Signal (photons per sub-aperture).
    pub signal_photons: f64,
    /// The sCMOS camera's (measured map) best centroider, its parameter and R (px) with SE.
    pub scmos_centroider: String,
    /// Parameter of the sCMOS side's best centroider at its optimum.
    pub scmos_param_opt: Option<f64>,
    /// R of the sCMOS side (px).
    pub scmos_r_px: f64,
    /// Its standard error (px).
    pub scmos_r_se_px: f64,
    /// R of the sCMOS side with plain `cog` (px).
    pub scmos_cog_r_px: f64,
    /// The EMCCD's best centroider.
    pub emccd_centroider: String,
    /// Parameter of the EMCCD side's best centroider at its optimum.
    pub emccd_param_opt: Option<f64>,
    /// R of the EMCCD side (px).
    pub emccd_r_px: f64,
    /// Its standard error (px).
    pub emccd_r_se_px: f64,
    /// R of the EMCCD with plain `cog` (px).
    pub emccd_cog_r_px: f64,
    /// sCMOS R over EMCCD R with both at their best, and its SE.
    pub ratio: f64,
    /// Standard error of the ratio (the two sides are separate runs, at their own QE: the
    /// relative SEs add in quadrature).
    pub ratio_se: f64,
    /// `scmos` or `emccd` (the lower R, by more than 2 SE of the ratio), or `tie`.
    pub better: String,
    /// sCMOS R over EMCCD R with both through plain `cog` (the paper's comparison).
    pub ratio_cog: f64,
    /// Standard error of the `cog` ratio (quadrature, as for `ratio`).
    pub ratio_cog_se: f64,
    /// `scmos`, `emccd` or `tie` with plain `cog`, as for `better`.
    pub better_cog: String,
}

/// The section's numbers, as summary.json's `centroiders` records them.
#[derive(Debug, Clone, Serialize)]
pub struct Centroiders {
    /// The camera's median per-pixel read noise (e-): what a perfect method would reach.
    pub median_rms_e: f64,
    /// The best centroider (lowest R) of the measured map at the operating point.
    pub best_for_map: Option<String>,
    /// Rows: the map and the fitted pdf at the operating point, then the map at the grid's
    /// other sub-aperture sizes.
    pub rows: Vec<CentroiderRow>,
    /// The sCMOS-against-EMCCD comparison with each side's best centroider.
    pub versus_emccd: Vec<VersusRow>,
}

/// What the section is computed from.
pub(crate) struct Inputs<'a> {
    /// The report's grid.
    pub grid: &'a Grid,
    /// The operating point.
    pub op: &'a OperatingPoint,
    /// Model parameters with the fitted pdf and the measured map.
    pub params: &'a ModelParams,
    /// Centroiders to compare (`cog` is added first when missing: it is the reference).
    pub centroiders: &'a [CentroiderSpec],
    /// QE of this camera and of the compared EMCCD.
    pub qe: (f64, f64),
    /// Median per-pixel read noise (e-).
    pub median_rms_e: f64,
    /// Precision of each sigma_eff.
    pub precision: &'a Precision,
    /// The report's effective table (fitted pdf and measured map through `cog`): the section
    /// takes `cog`'s values from it rather than solving them again.
    pub solved: &'a [EffectiveRecord],
    /// Run the map through every centroider over the whole grid (every spot and signal), not
    /// only over its sub-aperture sizes at the operating point's spot and signal.
    pub full_grid: bool,
}

/// Compute the section and write its files into `dir`.
pub(crate) fn centroider_section(
    i: &Inputs,
    dir: &Path,
    observer: &dyn Observer,
) -> Result<Centroiders> {
    let mut specs = vec![CentroiderSpec::default()];
    specs.extend(
        i.centroiders
            .iter()
            .filter(|c| **c != CentroiderSpec::default()),
    );
    let op = i.op;
    let at = |n: usize| i.grid.config(n, op.spot, op.signal_photons, i.qe.0);
    let mut records = group(ModelSpec::ScmosMap, &[at(op.subap_px)], &specs, i, observer)?;
    records.extend(group(
        ModelSpec::ScmosRandom,
        &[at(op.subap_px)],
        &specs,
        i,
        observer,
    )?);
    let others: Vec<_> = if i.full_grid {
        let here = at(op.subap_px);
        i.grid
            .configs(i.qe.0)
            .into_iter()
            .filter(|c| key(c) != key(&here))
            .collect()
    } else {
        i.grid
            .subaps_px
            .iter()
            .filter(|&&n| n != op.subap_px)
            .map(|&n| at(n))
            .collect()
    };
    records.extend(group(ModelSpec::ScmosMap, &others, &specs, i, observer)?);
    let rows = with_comparisons(&records, &specs, i.params)?;
    // The operating point's spot and signal (the first row is the map there).
    let records_op = rows[0].clone();
    let best_for_map = rows
        .iter()
        .filter(|r| {
            r.model == "scmos-map"
                && r.subap_px == op.subap_px
                && same_spot_signal(r, &records_op)
                && r.status != Status::NoEligibleLevel
        })
        .min_by(|a, b| a.r_px.total_cmp(&b.r_px))
        .map(|r| r.centroider.clone());
    let versus_emccd = versus(i, &specs)?;
    let section = Centroiders {
        median_rms_e: i.median_rms_e,
        best_for_map,
        rows,
        versus_emccd,
    };
    write_files(&section, dir)?;
    Ok(section)
}

/// What identifies a configuration of the section: sub-aperture, spot and signal.
fn key(c: &SimConfig) -> (usize, Spot, f64) {
    (c.subap_px, c.spot, c.signal_photons)
}

/// `model` at `configs` read through each of `specs` (`cog` first), records in centroider then
/// configuration order. `cog`'s values are the report's effective table's where it has them
/// (the same solves: same configuration, seed and precision), so they are not solved twice.
fn group(
    model: ModelSpec,
    configs: &[SimConfig],
    specs: &[CentroiderSpec],
    i: &Inputs,
    observer: &dyn Observer,
) -> Result<Vec<EffectiveRecord>> {
    let name = model.name();
    let models = [model];
    let known = |c: &SimConfig| {
        i.solved
            .iter()
            .find(|r| r.model.starts_with(name) && key(&r.config) == key(c))
    };
    let missing: Vec<SimConfig> = configs
        .iter()
        .filter(|c| known(c).is_none())
        .cloned()
        .collect();
    let solve = |configs: &[SimConfig], specs: &[CentroiderSpec]| {
        if configs.is_empty() || specs.is_empty() {
            return Ok(Vec::new());
        }
        effective_table_with(configs, &models, specs, i.params, i.precision, observer)
    };
    let mut cog_solved = solve(&missing, &specs[..1])?.into_iter();
    let mut out = Vec::with_capacity(configs.len() * specs.len());
    for c in configs {
        let record = match known(c) {
            Some(r) => EffectiveRecord {
                model: name.to_string(),
                ..r.clone()
            },
            None => cog_solved
                .next()
                .expect("one solve per missing configuration"),
        };
        out.push(record);
    }
    out.extend(solve(configs, &specs[1..])?);
    Ok(out)
}

/// Each centroider's R relative to `cog`'s, for one model on the same frames.
struct SharedFrames {
    /// R / R(cog) - 1 and its paired SE, per centroider in the order of `specs` (`cog`'s 0).
    vs_cog: Vec<(f64, f64)>,
}

/// Run `model` in `cfg` once through every one of `specs` (`cog` first): each arm centroids
/// the same frames, so R / R(cog) - 1 has a paired SE (linearised: the SE of
/// R - ratio x R(cog) over R(cog), from the block means of this one experiment).
fn shared_frames(
    cfg: &SimConfig,
    model: &dyn Readout,
    specs: &[CentroiderSpec],
) -> Result<SharedFrames> {
    let arms: Vec<Arm> = specs
        .iter()
        .map(|&centroider| Arm {
            model: 0,
            centroider,
        })
        .collect();
    let mut exp = Experiment::with_arms(cfg, &[model], &arms)?.with_blocks();
    exp.extend_to(cfg.iters, &Silent, 1)?;
    let results = exp.results()?;
    let cog = &results[0];
    let vs_cog = results
        .iter()
        .enumerate()
        .map(|(k, r)| {
            let ratio = r.r_px / cog.r_px;
            let terms = [
                Term {
                    model: k,
                    level: r.best,
                    coef: 1.0 / cog.r_px,
                },
                Term {
                    model: 0,
                    level: cog.best,
                    coef: -ratio / cog.r_px,
                },
            ];
            let se = if k == 0 { 0.0 } else { exp.paired_se(&terms) };
            (ratio - 1.0, se)
        })
        .collect();
    Ok(SharedFrames { vs_cog })
}

/// Rows of `records` (each model and configuration through every one of `specs`), each with
/// its R compared with `cog`'s on shared frames (one run per model and configuration).
fn with_comparisons(
    records: &[EffectiveRecord],
    specs: &[CentroiderSpec],
    params: &ModelParams,
) -> Result<Vec<CentroiderRow>> {
    let reference = CentroiderSpec::default().label();
    let mut runs: Vec<(String, (usize, Spot, f64), SharedFrames)> = Vec::new();
    let mut rows = Vec::with_capacity(records.len());
    for r in records {
        let model = r.model.split(':').next().unwrap_or(&r.model).to_string();
        let here = key(&r.config);
        if !runs.iter().any(|(m, k, _)| *m == model && *k == here) {
            let readout = ModelSpec::parse(&model)?.build(params, r.config.subap_px)?;
            let shared = shared_frames(&r.config, readout.as_ref(), specs)?;
            runs.push((model.clone(), here, shared));
        }
        let shared = &runs
            .iter()
            .find(|(m, k, _)| *m == model && *k == here)
            .expect("run above")
            .2;
        let k = specs
            .iter()
            .position(|c| c.label() == r.centroider)
            .expect("a record per centroider");
        let (ratio, se) = shared.vs_cog[k];
        let vs_cog = if r.centroider == reference {
            "reference"
        } else if ratio.abs() <= 2.0 * se || !ratio.is_finite() {
            "tie"
        } else if ratio < 0.0 {
            "lower"
        } else {
            "higher"
        };
        let e = &r.effective;
        let valued = !matches!(e.status, Status::Unreachable | Status::NoEligibleLevel);
        let finite = |v: f64| (valued && v.is_finite()).then_some(v);
        let compared = r.centroider != reference;
        rows.push(CentroiderRow {
            model,
            subap_px: r.config.subap_px,
            spot: r.config.spot.label(),
            signal_photons: r.config.signal_photons,
            centroider: r.centroider.clone(),
            centroider_param: e.param_name,
            centroider_param_opt: e.param_opt,
            r_px: e.r_px,
            r_se_px: e.r_se_px,
            crlb_efficiency: r.r_crlb_px.map(|f| f / e.r_px).filter(|v| v.is_finite()),
            below_crlb: r
                .r_crlb_px
                .map(|f| crate::crlb::below_floor(e.r_px, e.r_se_px, f)),
            sigma_eff_e: finite(e.sigma_eff_e),
            sigma_eff_se_e: finite(e.sigma_eff_se_e),
            sigma_cog_equiv_e: finite(e.sigma_cog_equiv_e),
            sigma_cog_equiv_se_e: finite(e.sigma_cog_equiv_se_e),
            status: e.status,
            r_vs_cog: compared.then_some(ratio),
            r_vs_cog_se: compared.then_some(se),
            vs_cog: vs_cog.into(),
        });
    }
    Ok(rows)
}

/// True when `r` is at `other`'s spot and signal.
fn same_spot_signal(r: &CentroiderRow, other: &CentroiderRow) -> bool {
    r.spot == other.spot && r.signal_photons == other.signal_photons
}

/// The measured map and the EMCCD of the comparison, each read through every centroider over
/// the grid's signals at the operating point's sub-aperture and spot; each side at its best.
fn versus(i: &Inputs, specs: &[CentroiderSpec]) -> Result<Vec<VersusRow>> {
    let op = i.op;
    let side = |model: ModelSpec, qe: f64| -> Result<Vec<SimRecord>> {
        let configs: Vec<_> = i
            .grid
            .signals_with(op)
            .into_iter()
            .map(|s| i.grid.config(op.subap_px, op.spot, s, qe))
            .collect();
        sweep_with(&configs, &[model], specs, i.params, &Silent)
    };
    let scmos = side(ModelSpec::ScmosMap, i.qe.0)?;
    let emccd = side(ModelSpec::EmccdStochastic, i.qe.1)?;
    let per = specs.len();
    Ok(scmos
        .chunks(per)
        .zip(emccd.chunks(per))
        .map(|(s, e)| {
            let best = |rs: &[SimRecord]| {
                rs.iter()
                    .min_by(|a, b| a.result.r_px.total_cmp(&b.result.r_px))
                    .expect("one record per centroider")
                    .result
                    .clone()
            };
            let (bs, be) = (best(s), best(e));
            let (ratio, ratio_se, better) = compare(&bs, &be);
            let (ratio_cog, ratio_cog_se, better_cog) = compare(&s[0].result, &e[0].result);
            VersusRow {
                signal_photons: s[0].config.signal_photons,
                scmos_centroider: bs.centroider.clone(),
                scmos_param_opt: bs.param_opt,
                scmos_r_px: bs.r_px,
                scmos_r_se_px: bs.r_se_px,
                scmos_cog_r_px: s[0].result.r_px,
                emccd_centroider: be.centroider.clone(),
                emccd_param_opt: be.param_opt,
                emccd_r_px: be.r_px,
                emccd_r_se_px: be.r_se_px,
                emccd_cog_r_px: e[0].result.r_px,
                ratio,
                ratio_se,
                better: better.into(),
                ratio_cog,
                ratio_cog_se,
                better_cog: better_cog.into(),
            }
        })
        .collect())
}

/// The sCMOS side's R over the EMCCD side's, its SE, and the better side (`tie` within 2 SE).
/// The two sides are separate runs (each at its own QE), so their relative SEs add in
/// quadrature.
fn compare(scmos: &SimResult, emccd: &SimResult) -> (f64, f64, &'static str) {
    let ratio = scmos.r_px / emccd.r_px;
    let se = ratio * (scmos.r_se_px / scmos.r_px).hypot(emccd.r_se_px / emccd.r_px);
    let better = if (ratio - 1.0).abs() <= 2.0 * se {
        "tie"
    } else if ratio < 1.0 {
        "scmos"
    } else {
        "emccd"
    };
    (ratio, se, better)
}

/// The tables (CSV, JSON) and the two charts.
fn write_files(c: &Centroiders, dir: &Path) -> Result<()> {
    use crate::output::write_csv_json;
    write_csv_json(&c.rows, dir, ["centroiders.csv", "centroiders.json"])?;
    write_csv_json(
        &c.versus_emccd,
        dir,
        ["centroiders_vs_emccd.csv", "centroiders_vs_emccd.json"],
    )?;
    sigma_chart(c).save(dir.join("centroiders.png"))?;
    versus_chart(c).save(dir.join("centroiders_vs_emccd.png"))
}

/// sigma_eff of the measured map against sub-aperture size, one line per centroider.
fn sigma_chart(c: &Centroiders) -> LineChart {
    let mut chart = LineChart::new(
        "Effective read noise of the measured map per centroider",
        "sub-aperture size (px per side)",
        "sigma_eff (e-): the uniform camera with the same R under the same centroider",
    );
    let mut names: Vec<&str> = Vec::new();
    // The first row is the map at the operating point (none in an empty section).
    let op = c.rows.first();
    let on_axis =
        |r: &&CentroiderRow| r.model == "scmos-map" && op.is_some_and(|op| same_spot_signal(r, op));
    for r in c.rows.iter().filter(on_axis) {
        if !names.contains(&r.centroider.as_str()) {
            names.push(&r.centroider);
        }
    }
    chart.series = names
        .iter()
        .map(|name| {
            let mut pts: Vec<(f64, f64, f64)> = c
                .rows
                .iter()
                .filter(on_axis)
                .filter(|r| r.centroider == *name && r.status == Status::Ok)
                .filter_map(|r| Some((r.subap_px as f64, r.sigma_eff_e?, r.sigma_eff_se_e?)))
                .collect();
            pts.sort_by(|a, b| a.0.total_cmp(&b.0));
            Series::with_errors(name.to_string(), pts)
        })
        .collect();
    let sizes = c.rows.iter().map(|r| r.subap_px as f64);
    let (lo, hi) = sizes.fold((f64::INFINITY, 0.0f64), |(lo, hi), x| {
        (lo.min(x), hi.max(x))
    });
    chart.series.push(Series::new(
        format!("camera median {:.2} e-", c.median_rms_e),
        [(lo, c.median_rms_e), (hi, c.median_rms_e)],
    ));
    // Seven lines leave no corner free: the data take the lower part of the axis and the
    // legend (a third of the plot's height) the upper part.
    let top = chart
        .series
        .iter()
        .flat_map(|s| &s.points)
        .map(|p| p.y + p.y_se.unwrap_or(0.0))
        .filter(|y| y.is_finite())
        .fold(0.0f64, f64::max);
    if top > 0.0 {
        chart.y_range = Some((0.0, top / DATA_HEIGHT_FRACTION));
    }
    chart
}

/// The part of the σ_eff chart's height that the data take, the rest left to the legend.
const DATA_HEIGHT_FRACTION: f64 = 0.6;

/// R against signal: each side with plain cog and at its best centroider.
fn versus_chart(c: &Centroiders) -> LineChart {
    let mut chart = LineChart::new(
        "sCMOS (measured map) against EMCCD, each with its best centroider",
        "signal (photons per sub-aperture)",
        "R, mean radial error (px)",
    );
    chart.log_x = true;
    chart.log_y = true;
    let v = &c.versus_emccd;
    chart.series = vec![
        Series::with_errors(
            "sCMOS, best centroider",
            v.iter()
                .map(|r| (r.signal_photons, r.scmos_r_px, r.scmos_r_se_px)),
        ),
        Series::with_errors(
            "EMCCD, best centroider",
            v.iter()
                .map(|r| (r.signal_photons, r.emccd_r_px, r.emccd_r_se_px)),
        ),
        Series::new(
            "sCMOS, cog",
            v.iter().map(|r| (r.signal_photons, r.scmos_cog_r_px)),
        ),
        Series::new(
            "EMCCD, cog",
            v.iter().map(|r| (r.signal_photons, r.emccd_cog_r_px)),
        ),
    ];
    chart
}

/// The page's section: the table at the operating point (map and fitted pdf), the best method,
/// the gap recovered, the chart over sub-aperture sizes and the comparison with an EMCCD.
pub(crate) fn section_html(h: &mut String, c: &Centroiders, at: &super::point::ChosenPoint) {
    use super::html::{figure, num, pm};
    use std::fmt::Write as _;
    let _ = write!(
        h,
        "<h2>What the wavefront sensor can do about it: centroiders</h2><p>A controller knows \
         its camera's noise map: it can threshold each pixel by its own noise (tcog), mask the \
         noisiest pixels (masked-cog), weight by inverse variance (ivw-cog), weight by the \
         spot's shape (wcog), keep the brightest pixels (brightest-n), apply the noise-weighted \
         matched filter of the mean spot (matched-filter) or correlate with it (correlation). \
         Methods are compared \
         by R itself: each is run at its best parameter on the same frames as plain cog, and \
         “R vs cog” is R / R(cog) − 1 with the paired SE of that one run (lower by more than \
         2 SE, higher, or a tie). σ<sub>eff</sub> is the uniform camera that has the same R \
         under the <em>same</em> method (its parameter re-optimised): the read noise to give a \
         simulator that runs that method. The cog-equivalent is the uniform camera with the \
         same R under plain cog (it compares a method with the paper's cog in units of noise; \
         0 when the method does better than a noiseless camera read with cog). \
         R<sub>crlb</sub> / R is the share of R that the Cramer-Rao floor of this camera sets (1: no unbiased centroid does better; \
         a method more than 3 SE under the floor is marked biased). The camera's \
         median read noise is {} e⁻. At {}×{} px, {}, {} photons:</p>",
        num(c.median_rms_e, 2),
        at.subap_px,
        at.subap_px,
        crate::output::html_escape(&at.spot),
        at.signal_photons
    );
    h.push_str(
        "<table><tr><th>camera</th><th>centroider</th><th>best parameter</th><th>R (px)</th>\
         <th>R vs cog</th><th>R<sub>crlb</sub> / R</th><th>σ<sub>eff</sub>, same method (e⁻)</th><th>status</th>\
         <th>cog-equivalent (e⁻)</th></tr>",
    );
    let op = c.rows.first();
    for r in c
        .rows
        .iter()
        .filter(|r| r.subap_px == at.subap_px && op.is_some_and(|op| same_spot_signal(r, op)))
    {
        let param = match (r.centroider_param, r.centroider_param_opt) {
            (Some(n), Some(v)) => format!("{n} = {}", num(v, 2)),
            _ => "–".into(),
        };
        let vs_cog = match r.vs_cog.as_str() {
            "reference" => "–".to_string(),
            word => format!(
                "{} % <span class=\"status\">{word}</span>",
                pm(
                    r.r_vs_cog.map(|g| 100.0 * g),
                    r.r_vs_cog_se.map(|g| 100.0 * g),
                    1
                )
            ),
        };
        // The Cramer-Rao floor's share of R; under the floor by 3 SE the method is biased.
        let floor = match (r.crlb_efficiency, r.below_crlb) {
            (Some(e), Some(true)) => {
                format!(
                    "{} <span class=\"status\">below floor: biased</span>",
                    num(e, 2)
                )
            }
            (Some(e), _) => num(e, 2),
            _ => "–".into(),
        };
        let camera = if r.model == "scmos-map" {
            "measured map"
        } else {
            "fitted pdf"
        };
        let _ = write!(
            h,
            "<tr><td>{camera}</td><td>{}</td><td>{param}</td><td>{}</td><td>{vs_cog}</td><td>{floor}</td>\
             <td>{}</td><td><span class=\"status\">{}</span></td><td>{}</td></tr>",
            r.centroider,
            pm(Some(r.r_px), Some(r.r_se_px), 4),
            pm(r.sigma_eff_e, r.sigma_eff_se_e, 2),
            r.status.label(),
            pm(r.sigma_cog_equiv_e, r.sigma_cog_equiv_se_e, 2)
        );
    }
    h.push_str("</table>");
    match &c.best_for_map {
        Some(best) => {
            let _ = write!(
                h,
                "<p><b>Best centroider for this camera</b> (measured map, lowest R): \
                 <b>{best}</b>.</p>"
            );
        }
        None => h.push_str("<p>No centroider has an eligible background level at this point.</p>"),
    }
    figure(
        h,
        "centroiders.png",
        "Effective read noise of the measured map per centroider against sub-aperture size",
        "σ<sub>eff</sub> of the measured map per centroider, each referred to the same \
         centroider (± 1 SE; only ok values), at the operating point's spot and signal, against \
         sub-aperture size; the flat line is the camera's median.",
    );
    h.push_str(
        "<p><b>sCMOS against EMCCD</b>: the paper's comparison (both through plain cog, as in \
         the comparison above) and the same redone with each side's best centroider; ratio = \
         R<sub>sCMOS</sub> / R<sub>EMCCD</sub>, better by more than 2 SE, else a tie. Which \
         camera wins can depend on the centroider: the two columns answer two questions (with \
         the paper's cog; with each camera's best method).</p>",
    );
    versus_story(h, &c.versus_emccd);
    h.push_str(
        "<table><tr><th>photons</th><th>ratio, cog</th><th>better, cog</th>\
         <th>sCMOS best</th><th>R sCMOS (px)</th><th>EMCCD best</th><th>R EMCCD (px)</th>\
         <th>ratio, best</th><th>better, best</th></tr>",
    );
    for v in &c.versus_emccd {
        let _ = write!(
            h,
            "<tr><td>{}</td><td>{}</td><td><span class=\"status\">{}</span></td><td>{}</td>\
             <td>{}</td><td>{}</td><td>{}</td><td>{}</td>\
             <td><span class=\"status\">{}</span></td></tr>",
            v.signal_photons,
            pm(Some(v.ratio_cog), Some(v.ratio_cog_se), 3),
            v.better_cog,
            v.scmos_centroider,
            pm(Some(v.scmos_r_px), Some(v.scmos_r_se_px), 4),
            v.emccd_centroider,
            pm(Some(v.emccd_r_px), Some(v.emccd_r_se_px), 4),
            pm(Some(v.ratio), Some(v.ratio_se), 3),
            v.better
        );
    }
    h.push_str("</table>");
    figure(
        h,
        "centroiders_vs_emccd.png",
        "R against signal of the sCMOS camera and an EMCCD, each with plain cog and its best centroider",
        "R against signal (± 1 SE) of this camera's measured map and of the compared EMCCD, each \
         with its best centroider at every signal, and with plain cog.",
    );
    h.push_str(
        "<p class=\"note\">Files: centroiders.csv/.json (every camera, centroider and \
         sub-aperture size: R, R vs cog with its paired SE, σ<sub>eff</sub> (same method) and \
         the cog-equivalent with SE and status, best parameter), centroiders_vs_emccd.csv/.json \
         (both ratios), centroiders.png, \
         centroiders_vs_emccd.png.</p>",
    );
}

/// One sentence per question of the comparison: at which signals each camera wins with plain
/// `cog`, and at which with each side's best centroider.
fn versus_story(h: &mut String, rows: &[VersusRow]) {
    use std::fmt::Write as _;
    if rows.is_empty() {
        return;
    }
    let signals = |word: &str, pick: fn(&VersusRow) -> &str| -> String {
        let s: Vec<String> = rows
            .iter()
            .filter(|r| pick(r) == word)
            .map(|r| r.signal_photons.to_string())
            .collect();
        if s.is_empty() {
            "none".into()
        } else {
            s.join(", ")
        }
    };
    for (question, pick) in [
        (
            "With plain cog",
            (|r: &VersusRow| r.better_cog.as_str()) as fn(&VersusRow) -> &str,
        ),
        ("With each side's best centroider", |r: &VersusRow| {
            r.better.as_str()
        }),
    ] {
        let _ = write!(
            h,
            "<p>{question}: sCMOS better at {} photons, EMCCD better at {}, tied at {}.</p>",
            signals("scmos", pick),
            signals("emccd", pick),
            signals("tie", pick)
        );
    }
}

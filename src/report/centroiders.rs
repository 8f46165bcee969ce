//! What the wavefront sensor can do about its camera's noise: the effective read noise of the
//! measured map and of the fitted pdf read through each centroider (at the operating point, and
//! over the grid's sub-aperture sizes for the map), how much of the gap to the median each
//! recovers, and the paper's sCMOS-against-EMCCD comparison redone with each side's best
//! centroider.

use serde::Serialize;

use super::grid::Grid;
use super::point::OperatingPoint;
use crate::centroid::CentroiderSpec;
use crate::detector::{ModelParams, ModelSpec};
use crate::effective::{effective_table_with, EffectiveRecord, Precision, Status};
use crate::montecarlo::{sweep_with, SimConfig, SimRecord};
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
    /// The uniform camera (plain `cog`) with the same R (e-); None without a value.
    pub sigma_eff_e: Option<f64>,
    /// Its standard error (e-).
    pub sigma_eff_se_e: Option<f64>,
    /// How sigma_eff was settled.
    pub status: Status,
    /// Fraction of the gap between `cog`'s sigma_eff and the camera's median read noise that
    /// this centroider recovers (1 = down to the median; negative = worse than `cog`).
    pub gap_recovered: Option<f64>,
    /// Its standard error (quadrature of the two sigma_eff SEs over the gap).
    pub gap_recovered_se: Option<f64>,
    /// `ok`; `not_resolved` (the gap itself is under 2 SE, or a value is missing); or
    /// `reference` (`cog`).
    pub gap_status: String,
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
    /// Standard error of the ratio.
    pub ratio_se: f64,
    /// `scmos` or `emccd` (the lower R, by more than 2 SE of the ratio), or `tie`.
    pub better: String,
}

/// The section's numbers, as summary.json's `centroiders` records them.
#[derive(Debug, Clone, Serialize)]
pub struct Centroiders {
    /// The camera's median per-pixel read noise (e-): what a perfect method would reach.
    pub median_rms_e: f64,
    /// The best centroider (lowest sigma_eff among `ok` values) of the measured map at the
    /// operating point.
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
    let rows = with_gaps(&records, i.median_rms_e);
    // The operating point's spot and signal (the first row is the map there).
    let records_op = rows[0].clone();
    let best_for_map = rows
        .iter()
        .filter(|r| {
            r.model == "scmos-map"
                && r.subap_px == op.subap_px
                && same_spot_signal(r, &records_op)
                && r.status == Status::Ok
        })
        .min_by(|a, b| {
            a.sigma_eff_e
                .unwrap_or(f64::INFINITY)
                .total_cmp(&b.sigma_eff_e.unwrap_or(f64::INFINITY))
        })
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

/// Rows with the gap each centroider recovers against `cog` of the same model and size.
fn with_gaps(records: &[EffectiveRecord], median: f64) -> Vec<CentroiderRow> {
    let value = |r: &EffectiveRecord| {
        let e = &r.effective;
        (e.status == Status::Ok || e.status == Status::Imprecise)
            .then_some((e.sigma_eff_e, e.sigma_eff_se_e))
    };
    let reference = CentroiderSpec::default().label();
    records
        .iter()
        .map(|r| {
            let e = &r.effective;
            let cog = records.iter().find(|c| {
                c.centroider == reference && c.model == r.model && key(&c.config) == key(&r.config)
            });
            let (gap, gap_se, gap_status) =
                match (r.centroider == reference, cog.and_then(value), value(r)) {
                    (true, _, _) => (None, None, "reference"),
                    (_, Some((sc, sc_se)), Some((s, s_se))) if sc - median > 2.0 * sc_se => {
                        let g = sc - median;
                        (Some((sc - s) / g), Some(sc_se.hypot(s_se) / g), "ok")
                    }
                    _ => (None, None, "not_resolved"),
                };
            let valued = !matches!(e.status, Status::Unreachable | Status::NoEligibleLevel);
            let finite = |v: f64| (valued && v.is_finite()).then_some(v);
            CentroiderRow {
                model: r.model.split(':').next().unwrap_or(&r.model).to_string(),
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
                status: e.status,
                gap_recovered: gap,
                gap_recovered_se: gap_se,
                gap_status: gap_status.into(),
            }
        })
        .collect()
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
            let ratio = bs.r_px / be.r_px;
            let ratio_se = ratio * (bs.r_se_px / bs.r_px).hypot(be.r_se_px / be.r_px);
            let better = if (ratio - 1.0).abs() <= 2.0 * ratio_se {
                "tie"
            } else if ratio < 1.0 {
                "scmos"
            } else {
                "emccd"
            };
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
            }
        })
        .collect())
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
        "sigma_eff (e-): the uniform camera with the same R under plain cog",
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
         spot's shape (wcog), or keep the brightest pixels (brightest-n). Each is run at its \
         best parameter on the same frames; σ<sub>eff</sub> is the uniform camera that, \
         centroided plainly (cog), has the same error, so it is comparable across methods. R<sub>crlb</sub> / R is the share of R \
         that the Cramer-Rao floor of this camera sets (1: no unbiased centroid does better; \
         a method more than 3 SE under the floor is marked biased). The \
         camera's median read noise is {} e⁻: a method reaching it would make this camera \
         behave like a uniform one of its median. Gap recovered = (σ<sub>eff</sub>(cog) − \
         σ<sub>eff</sub>) / (σ<sub>eff</sub>(cog) − median). At {}×{} px, {}, {} photons:</p>",
        num(c.median_rms_e, 2),
        at.subap_px,
        at.subap_px,
        crate::output::html_escape(&at.spot),
        at.signal_photons
    );
    h.push_str(
        "<table><tr><th>camera</th><th>centroider</th><th>best parameter</th><th>R (px)</th>\
         <th>R<sub>crlb</sub> / R</th><th>σ<sub>eff</sub> (e⁻)</th><th>status</th><th>gap recovered</th></tr>",
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
        let gap = match r.gap_status.as_str() {
            "ok" => format!(
                "{} %",
                pm(
                    r.gap_recovered.map(|g| 100.0 * g),
                    r.gap_recovered_se.map(|g| 100.0 * g),
                    0
                )
            ),
            other => format!("<span class=\"status\">{other}</span>"),
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
            "<tr><td>{camera}</td><td>{}</td><td>{param}</td><td>{}</td><td>{floor}</td>\
             <td>{}</td><td><span class=\"status\">{}</span></td><td>{gap}</td></tr>",
            r.centroider,
            pm(Some(r.r_px), Some(r.r_se_px), 4),
            pm(r.sigma_eff_e, r.sigma_eff_se_e, 2),
            r.status.label()
        );
    }
    h.push_str("</table>");
    match &c.best_for_map {
        Some(best) => {
            let _ = write!(
                h,
                "<p><b>Best centroider for this camera</b> (measured map, lowest σ<sub>eff</sub> \
                 among <span class=\"status\">ok</span> values): <b>{best}</b>.</p>"
            );
        }
        None => h.push_str("<p>No centroider's σ<sub>eff</sub> is <span class=\"status\">ok</span> at this point.</p>"),
    }
    figure(
        h,
        "centroiders.png",
        "Effective read noise of the measured map per centroider against sub-aperture size",
        "σ<sub>eff</sub> of the measured map per centroider (± 1 SE; only ok values) at the \
         operating point's spot and signal, against sub-aperture size; the flat line is the \
         camera's median.",
    );
    h.push_str(
        "<p><b>sCMOS against EMCCD, each with its best centroider</b> (the paper's comparison \
         redone; ratio = R<sub>sCMOS</sub> / R<sub>EMCCD</sub>, better by more than 2 SE, else a \
         tie):</p><table><tr><th>photons</th><th>sCMOS best</th><th>R sCMOS (px)</th>\
         <th>EMCCD best</th><th>R EMCCD (px)</th><th>ratio</th><th>better</th></tr>",
    );
    for v in &c.versus_emccd {
        let _ = write!(
            h,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td>\
             <td><span class=\"status\">{}</span></td></tr>",
            v.signal_photons,
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
         sub-aperture size: R, σ<sub>eff</sub> with SE and status, best parameter, gap \
         recovered), centroiders_vs_emccd.csv/.json, centroiders.png, \
         centroiders_vs_emccd.png.</p>",
    );
}

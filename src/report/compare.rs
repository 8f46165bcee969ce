//! The comparison of a report: R against signal at the operating sub-aperture and spot, for
//! this camera's models beside the one-number sCMOS models and an EMCCD; its table, its chart
//! and what the chart's caption says of the error bars.

use super::grid::Grid;
use super::point::OperatingPoint;
use super::result::Compared;
use crate::charts::heatmaps::round_up_2_digits;
use crate::detector::{ModelParams, ModelSpec};
use crate::montecarlo::{sweep, SimConfig, SimRecord};
use crate::output::{render, write_atomic, OutputDir, TableFormat};
use crate::plot::{LineChart, Series};
use crate::progress::Silent;
use crate::{Error, Result};

/// A model and its legend label in the comparison chart.
pub(crate) type Label = (ModelSpec, String);

/// Legend labels of the comparison chart of an sCMOS report; the compared EMCCD's gain (e-/e-)
/// and read noise (e-) are those of `params`, the ones it is simulated with.
pub(crate) fn scmos_labels(params: &ModelParams) -> Vec<Label> {
    vec![
        (ModelSpec::ScmosRandom, "this camera (fitted pdf)".into()),
        (ModelSpec::ScmosMap, "this camera (measured map)".into()),
        (ModelSpec::ScmosMedian, "one number: median".into()),
        (ModelSpec::ScmosMean, "one number: mean".into()),
        (
            ModelSpec::EmccdStochastic,
            format!(
                "EMCCD (g = {}, {} e- read noise)",
                params.em_gain, params.emccd_read_noise_e
            ),
        ),
    ]
}

/// Legend labels of the comparison chart of an EMCCD report; the sCMOS models use the rms
/// pdf of `params` (the paper's unless one was given), named by its label.
pub(crate) fn emccd_labels(params: &ModelParams) -> Vec<Label> {
    vec![
        (
            ModelSpec::EmccdStochastic,
            "this EMCCD (fitted gain and read noise)".into(),
        ),
        (
            ModelSpec::ScmosRandom,
            format!("sCMOS, pdf {}", params.pdf.label()),
        ),
        (ModelSpec::ScmosMedian, "sCMOS, one number: median".into()),
        (ModelSpec::ScmosMean, "sCMOS, one number: mean".into()),
    ]
}

/// Names of the files [`write_comparison`] writes.
pub(crate) const COMPARISON_FILES: [&str; 3] =
    ["r_vs_signal.csv", "r_vs_signal.png", "r_vs_signal.svg"];

/// Write the comparison's table (`r_vs_signal.csv`) and chart (PNG and SVG) into `dir`;
/// returns what the chart's caption says of its error bars ([`error_bar_note`]).
pub(crate) fn write_comparison(
    comparison: &[Compared],
    dir: &OutputDir,
    labels: &[Label],
) -> Result<String> {
    let records: Vec<&SimRecord> = comparison.iter().map(|c| &c.record).collect();
    let [csv, png, svg] = COMPARISON_FILES;
    write_atomic(
        &dir.path(csv),
        render(&records, TableFormat::Csv)?.as_bytes(),
    )?;
    let chart = comparison_chart(comparison, labels)?;
    chart.save(dir.path(png))?;
    chart.save(dir.path(svg))?;
    Ok(error_bar_note(chart.error_bar_extent()?, &records))
}

/// R against signal at one sub-aperture and spot, one line per model (in order of first
/// appearance) with error bars of one standard error; `labels` names the models in the legend
/// (others show their model name).
pub(crate) fn comparison_chart(
    comparison: &[Compared],
    labels: &[(ModelSpec, String)],
) -> Result<LineChart> {
    let first = &comparison
        .first()
        .ok_or_else(|| Error::Numeric("no comparison records to draw".into()))?
        .record;
    let mut chart = LineChart::new(
        format!(
            "R against signal, {}x{} px, {}",
            first.config.subap_px,
            first.config.subap_px,
            first.config.spot.label()
        ),
        "signal (photons per sub-aperture)",
        "R, mean radial error (px)",
    );
    chart.log_x = true;
    chart.log_y = true;
    let mut models: Vec<&Compared> = Vec::new();
    for c in comparison {
        if !models.iter().any(|m| m.spec == c.spec) {
            models.push(c);
        }
    }
    chart.series = models
        .iter()
        .map(|m| {
            let label = labels
                .iter()
                .find(|(spec, _)| *spec == m.spec)
                .map_or(m.record.result.model.as_str(), |(_, l)| l.as_str());
            Series::with_errors(
                label,
                comparison.iter().filter(|c| c.spec == m.spec).map(|c| {
                    let (cfg, r) = (&c.record.config, &c.record.result);
                    (cfg.signal_photons, r.r_px, r.r_se_px)
                }),
            )
        })
        .collect();
    Ok(chart)
}

/// What a caption says of a chart's error bars (one standard error): that they are drawn, or
/// that they hide behind the markers, with the largest standard error (px) and the largest
/// relative one. `extent` is [`LineChart::error_bar_extent`]; `records` the points drawn.
pub(crate) fn error_bar_note(extent: Option<(f64, f64)>, records: &[&SimRecord]) -> String {
    match extent {
        None => String::new(),
        Some((arm_px, _)) if arm_px > LineChart::MARKER_HALF_PX => {
            "Error bars are one standard error.".into()
        }
        Some((_, largest_se)) => {
            let rel = records
                .iter()
                .map(|r| r.result.r_se_px / r.result.r_px)
                .filter(|v| v.is_finite())
                .fold(0.0, f64::max);
            format!(
                "Error bars (one standard error) are smaller than the markers: standard errors \
                 are at most {} px, {:.1} % of R.",
                round_up_2_digits(largest_se).1,
                100.0 * rel
            )
        }
    }
}

/// Models run together at one quantum efficiency (photo-electrons per photon).
pub(crate) struct Group<'a> {
    /// The models, in the order of their records.
    pub specs: &'a [ModelSpec],
    /// Quantum efficiency of these models.
    pub qe: f64,
}

/// The sCMOS report's comparison: this camera (fitted pdf, measured map), the one-number
/// models at `qe`, and an EMCCD at `qe_emccd`.
pub(crate) fn scmos_groups(qe: f64, qe_emccd: f64) -> [Group<'static>; 2] {
    [
        Group {
            specs: &[
                ModelSpec::ScmosRandom,
                ModelSpec::ScmosMap,
                ModelSpec::ScmosMedian,
                ModelSpec::ScmosMean,
            ],
            qe,
        },
        Group {
            specs: &[ModelSpec::EmccdStochastic],
            qe: qe_emccd,
        },
    ]
}

/// The EMCCD report's comparison: sCMOS models with the paper's pdf at `qe`, and this EMCCD
/// (fitted gain and read noise) at `qe_emccd`.
pub(crate) fn emccd_groups(qe: f64, qe_emccd: f64) -> [Group<'static>; 2] {
    [
        Group {
            specs: &[
                ModelSpec::ScmosRandom,
                ModelSpec::ScmosMedian,
                ModelSpec::ScmosMean,
            ],
            qe,
        },
        Group {
            specs: &[ModelSpec::EmccdStochastic],
            qe: qe_emccd,
        },
    ]
}

/// R against signal for `groups` at the operating point's sub-aperture and spot, over the grid's
/// signals and the operating point's: signal major, then group, then model (the order of
/// `r_vs_signal.csv`).
pub(crate) fn compare_models(
    grid: &Grid,
    op: &OperatingPoint,
    params: &ModelParams,
    groups: &[Group],
) -> Result<Vec<Compared>> {
    let mut out = Vec::new();
    for signal_photons in grid.signals_with(op) {
        for group in groups {
            let cfg = grid.config(op.subap_px, op.spot, signal_photons, group.qe);
            out.extend(run_models(&cfg, group.specs, params)?);
        }
    }
    Ok(out)
}

/// Every model of `specs` on the configuration `cfg`, with common random numbers.
fn run_models(cfg: &SimConfig, specs: &[ModelSpec], params: &ModelParams) -> Result<Vec<Compared>> {
    // One configuration: `sweep` returns one record per model, in the order of `specs`.
    let records = sweep(std::slice::from_ref(cfg), specs, params, &Silent)?;
    Ok(specs
        .iter()
        .zip(records)
        .map(|(spec, record)| Compared {
            spec: spec.clone(),
            record,
        })
        .collect())
}

/// Which model gives the smaller R at each signal: `mine` against `other`, each with the name
/// the page shows. A difference under two standard errors of the ratio is no difference.
pub(crate) fn verdicts(
    comparison: &[Compared],
    (mine, mine_name): (&ModelSpec, &str),
    (other, other_name): (&ModelSpec, &str),
) -> Vec<(f64, String)> {
    let mut signals: Vec<f64> = comparison
        .iter()
        .map(|c| c.record.config.signal_photons)
        .collect();
    signals.dedup();
    signals
        .into_iter()
        .filter_map(|s| {
            let get = |m: &ModelSpec| {
                comparison
                    .iter()
                    .find(|c| &c.spec == m && c.record.config.signal_photons == s)
                    .map(|c| &c.record.result)
            };
            let (c, e) = (get(mine)?, get(other)?);
            let ratio = c.r_px / e.r_px;
            // The compared models are in different groups, each its own run (`run_models`, at
            // the group's QE): two separate experiments, so the relative SEs add in quadrature.
            let se = ratio * ((c.r_se_px / c.r_px).powi(2) + (e.r_se_px / e.r_px).powi(2)).sqrt();
            let verdict = if (ratio - 1.0).abs() < 2.0 * se {
                "no significant difference".to_string()
            } else if ratio < 1.0 {
                format!("{mine_name} wins (R {:.1} % lower)", 100.0 * (1.0 - ratio))
            } else {
                format!(
                    "{other_name} wins (R {:.1} % lower)",
                    100.0 * (1.0 - 1.0 / ratio)
                )
            };
            Some((s, verdict))
        })
        .collect()
}

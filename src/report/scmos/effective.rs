//! The effective-noise part of an sCMOS report: the fitted pdf and the measured map over the
//! grid (and at the operating point, beside the grid when it is not one of its
//! configurations), the headline numbers, the table's files and the heatmaps.

use crate::charts::heatmaps::{effective_heatmaps, NoiseScale};
use crate::detector::{ModelParams, ModelSpec};
use crate::effective::{effective_table, Effective, EffectiveRecord, Precision, TABLE_NAMES};
use crate::montecarlo::SimConfig;
use crate::output::{write_csv_json, OutputDir};
use crate::progress::Observer;
use crate::report::grid::Grid;
use crate::report::point::{ChosenPoint, OperatingPoint};
use crate::report::result::Headline;
use crate::Result;
use std::path::PathBuf;

/// The models of the effective-noise table, with their labels in it.
const EFFECTIVE_MODELS: [(ModelSpec, &str); 2] = [
    (ModelSpec::ScmosRandom, "scmos-random (fitted pdf)"),
    (ModelSpec::ScmosMap, "scmos-map (measured map)"),
];

/// The heatmaps of the fitted pdf, one per signal (see [`effective_heatmaps`]).
const HEATMAP_FILES: [&str; 2] = ["effective_noise_S*.png", "effective_noise_S*.svg"];

/// The files this part may write: the table and the heatmaps.
pub(super) fn outputs() -> impl Iterator<Item = &'static str> {
    TABLE_NAMES.into_iter().chain(HEATMAP_FILES)
}

/// Both models solved over the grid and at the operating point.
pub(super) struct Solved {
    /// The fitted pdf's records: the grid's, then the operating point's when not in it.
    fitted: Vec<EffectiveRecord>,
    /// The measured map's, likewise.
    measured: Vec<EffectiveRecord>,
    /// How many of the records are the grid's.
    grid_len: usize,
    /// The headline numbers (both models at the operating point).
    pub headline: Headline,
    /// The solutions at the operating point: fitted pdf, measured map.
    pub at_point: (Effective, Effective),
}

/// The table as written: the grid's records (fitted pdf, then measured map), the heatmaps
/// written (PNG and SVG) and their colour scale.
pub(super) struct Table {
    pub effective: Vec<EffectiveRecord>,
    pub heatmaps: Vec<PathBuf>,
    pub scale: NoiseScale,
}

/// Solve both models on the grid's configurations at quantum efficiency `qe`, and at the
/// operating point `op` (given by the user when `given`): one stage of progress.
pub(super) fn solve(
    grid: &Grid,
    (op, given): (&OperatingPoint, bool),
    qe: f64,
    params: &ModelParams,
    precision: &Precision,
    observer: &dyn Observer,
) -> Result<Solved> {
    let in_grid = grid.contains(op);
    let grid_len = grid.configs(qe).len();
    // The headline is solved with the table (one stage of progress): beside the grid, last,
    // when it is not one of the grid's configurations.
    let configs = with_point(grid, op, qe, in_grid);
    let [fitted, measured] = effective_tables(&configs, params, precision, observer)?;
    let at_point = (at_point(&fitted, op), at_point(&measured, op));
    let headline = headline(ChosenPoint::new(op, given, in_grid), &at_point);
    Ok(Solved {
        fitted,
        measured,
        grid_len,
        headline,
        at_point,
    })
}

impl Solved {
    /// Keep the grid's records, draw the fitted pdf's heatmaps and write the table into
    /// `dir`; returns the table and the names written.
    pub(super) fn write(mut self, dir: &OutputDir) -> Result<(Table, Vec<String>)> {
        self.fitted.truncate(self.grid_len);
        self.measured.truncate(self.grid_len);
        let heatmaps = effective_heatmaps(&self.fitted, dir)?;
        let mut names: Vec<String> = heatmaps.iter().map(|p| file_name(p)).collect();
        let scale = NoiseScale::from_ok(&self.fitted);
        let effective: Vec<EffectiveRecord> =
            self.fitted.into_iter().chain(self.measured).collect();
        write_csv_json(&effective, &dir.path(""), TABLE_NAMES)?;
        names.extend(TABLE_NAMES.map(String::from));
        let table = Table {
            effective,
            heatmaps,
            scale,
        };
        Ok((table, names))
    }
}

fn file_name(path: &std::path::Path) -> String {
    path.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default()
}

/// The effective read noise of each model of [`EFFECTIVE_MODELS`] on every configuration, as
/// one stage of progress (both models' iterations), labelled as the page names them.
fn effective_tables(
    configs: &[SimConfig],
    params: &ModelParams,
    precision: &Precision,
    observer: &dyn Observer,
) -> Result<[Vec<EffectiveRecord>; 2]> {
    let specs = EFFECTIVE_MODELS.map(|(spec, _)| spec);
    // Records come model by model, each over every configuration.
    let mut records = effective_table(configs, &specs, params, precision, observer)?.into_iter();
    Ok(EFFECTIVE_MODELS.map(|(_, label)| {
        records
            .by_ref()
            .take(configs.len())
            .map(|r| EffectiveRecord {
                model: label.into(),
                ..r
            })
            .collect()
    }))
}

/// The grid's configurations at quantum efficiency `qe`, and the operating point's after them
/// when it is not `in_grid`.
fn with_point(grid: &Grid, op: &OperatingPoint, qe: f64, in_grid: bool) -> Vec<SimConfig> {
    let mut configs = grid.configs(qe);
    if !in_grid {
        configs.push(grid.config(op.subap_px, op.spot, op.signal_photons, qe));
    }
    configs
}

/// The headline numbers: both models' solutions (fitted pdf, measured map) at the point `at`.
fn headline(at: ChosenPoint, (f, m): &(Effective, Effective)) -> Headline {
    Headline {
        at,
        sigma_eff_fitted_pdf_e: f.sigma_eff_e,
        sigma_eff_fitted_pdf_se_e: f.sigma_eff_se_e,
        sigma_eff_fitted_pdf_status: f.status,
        sigma_eff_map_e: m.sigma_eff_e,
        sigma_eff_map_se_e: m.sigma_eff_se_e,
        sigma_eff_map_status: m.status,
    }
}

/// The solution at the operating point `op` among `records` (solved with the table).
fn at_point(records: &[EffectiveRecord], op: &OperatingPoint) -> Effective {
    records
        .iter()
        .find(|r| {
            let c = &r.config;
            c.subap_px == op.subap_px && c.spot == op.spot && c.signal_photons == op.signal_photons
        })
        .expect("the operating point is solved with the table")
        .effective
        .clone()
}

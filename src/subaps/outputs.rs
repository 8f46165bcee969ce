//! The per-sub-aperture map's files: the CSV table, the FITS images (values, SE, status), the
//! chart and the summary JSON, all from a job's header and its records in index order.

use super::chart::subaps_chart;
use super::part::{Binding, PartHeader, PartRecord};
use crate::effective::{EffectiveParts, Status};
use crate::io::fits::{key, write_image, ImageData, KeyValue, Keyword};
use crate::output::{render, write_atomic, write_json, TableFormat};
use crate::Result;
use serde::Serialize;
use std::path::{Path, PathBuf};

/// Files the map is written as (in an output directory): table, images, chart, summary.
pub const OUTPUT_NAMES: [&str; 11] = [
    "subaps.csv",
    "subaps_sigma_eff_e.fits",
    "subaps_sigma_eff_se_e.fits",
    "subaps_status.fits",
    "subaps_sigma_eff.png",
    "subaps_sigma_eff.svg",
    "subaps_summary.json",
    super::crlb::FLOOR_NAME,
    super::static_maps::STATIC_MAP_NAMES[0],
    super::static_maps::STATIC_MAP_NAMES[1],
    super::static_maps::STATIC_MAP_NAMES[2],
];

/// The status image's code of a cell without a sub-aperture (masked, or not fitting the map).
pub const NO_SUBAP_CODE: i32 = -1;

/// The status image's code of `s`: its place in [`Status::ALL`] (0 = ok).
pub fn status_code(s: Status) -> i32 {
    Status::ALL
        .iter()
        .position(|x| *x == s)
        .expect("a listed status") as i32
}

/// One row of `subaps.csv`: the sub-aperture, its effective read noise (empty without a
/// value), the window's R and the map in its window.
#[derive(Debug, Clone, Serialize)]
pub struct SubapRow {
    /// Index among the sub-apertures (row-major over the grid).
    pub index: usize,
    /// Grid row (0 = the map's first rows).
    pub grid_row: usize,
    /// Grid column.
    pub grid_col: usize,
    /// Column of the window's first pixel (px).
    pub x0_px: usize,
    /// Row of the window's first pixel (px).
    pub y0_px: usize,
    /// Effective read noise (e-); empty for `unreachable` and `no_eligible_level`.
    pub sigma_eff_e: Option<f64>,
    /// Its standard error (e-).
    pub sigma_eff_se_e: Option<f64>,
    /// The standard error it had to reach (e-).
    pub target_se_e: Option<f64>,
    /// How the value was settled (only `ok` is a result).
    pub status: Status,
    /// The window's R (px).
    pub r_px: Option<f64>,
    /// Its standard error (px).
    pub r_se_px: Option<f64>,
    /// Iterations of the final runs (frames).
    pub iters: u64,
    /// Median of the map's finite pixels in the window (e-).
    pub window_median_e: Option<f64>,
    /// sqrt(mean sigma^2) of them (e-).
    pub window_rms_e: Option<f64>,
    /// Non-finite map pixels in the window (read with the map's rms).
    pub window_nonfinite_px: usize,
    /// The uniform camera with the same R under plain `cog` (e-; the value itself for `cog`).
    pub sigma_cog_equiv_e: Option<f64>,
    /// Its standard error (e-).
    pub sigma_cog_equiv_se_e: Option<f64>,
    /// Static part: the window's mean centroid error along x (px).
    pub static_x_px: Option<f64>,
    /// Static part along y (px).
    pub static_y_px: Option<f64>,
    /// Length of the static offset (px).
    pub static_px: Option<f64>,
    /// Its standard error (px).
    pub static_se_px: Option<f64>,
    /// True when the static offset is at least 3 times its SE.
    pub static_resolved: bool,
    /// Random part: the rms of the error about its mean (px).
    pub random_rms_px: Option<f64>,
    /// Constant read noise whose rms error equals the random rms (e-).
    pub sigma_random_e: Option<f64>,
    /// Its standard error (e-; from the window's and the ladder's own SEs: conservative).
    pub sigma_random_se_e: Option<f64>,
}

fn finite(v: f64) -> Option<f64> {
    v.is_finite().then_some(v)
}

impl SubapRow {
    /// The row of `r` in a job on grid `b`.
    pub fn new(r: &PartRecord, b: &Binding) -> SubapRow {
        SubapRow {
            index: r.index,
            grid_row: r.grid_row,
            grid_col: r.grid_col,
            x0_px: b.grid.x0_px + r.grid_col * b.grid.pitch_px,
            y0_px: b.grid.y0_px + r.grid_row * b.grid.pitch_px,
            sigma_eff_e: finite(r.sigma_eff_e),
            sigma_eff_se_e: finite(r.sigma_eff_se_e),
            target_se_e: r.target_se_e,
            status: r.status,
            r_px: finite(r.r_px),
            r_se_px: finite(r.r_se_px),
            iters: r.iters,
            window_median_e: finite(r.window.median_e),
            window_rms_e: finite(r.window.rms_e),
            window_nonfinite_px: r.window.nonfinite_px,
            sigma_cog_equiv_e: finite(r.sigma_cog_equiv_e),
            sigma_cog_equiv_se_e: finite(r.sigma_cog_equiv_se_e),
            static_x_px: finite(r.parts.static_x_px),
            static_y_px: finite(r.parts.static_y_px),
            static_px: finite(r.parts.static_px),
            static_se_px: finite(r.parts.static_se_px),
            static_resolved: r.parts.static_resolved,
            random_rms_px: finite(r.parts.random_rms_px),
            sigma_random_e: finite(r.parts.sigma_random_e),
            sigma_random_se_e: finite(r.parts.sigma_random_se_e),
        }
    }
}

/// sigma_eff over the sub-apertures whose value is `ok` (e-).
#[derive(Debug, Clone, Serialize)]
pub struct Spread {
    /// Sub-apertures with an `ok` value.
    pub ok: usize,
    /// Median (e-).
    pub median_e: f64,
    /// Smallest (e-).
    pub min_e: f64,
    /// Largest (e-).
    pub max_e: f64,
    /// 10th percentile (e-).
    pub p10_e: f64,
    /// 90th percentile (e-).
    pub p90_e: f64,
    /// The spread: 90th minus 10th percentile (e-).
    pub spread_p90_p10_e: f64,
}

impl Spread {
    /// The spread of the `ok` values of `records`; None when there is none.
    pub fn of(records: &[PartRecord]) -> Option<Spread> {
        let mut v: Vec<f64> = records
            .iter()
            .filter(|r| r.status == Status::Ok && r.sigma_eff_e.is_finite())
            .map(|r| r.sigma_eff_e)
            .collect();
        if v.is_empty() {
            return None;
        }
        v.sort_by(f64::total_cmp);
        let p = |q| crate::stats::percentile_sorted(&v, q);
        Some(Spread {
            ok: v.len(),
            median_e: p(50.0),
            min_e: v[0],
            max_e: v[v.len() - 1],
            p10_e: p(10.0),
            p90_e: p(90.0),
            spread_p90_p10_e: p(90.0) - p(10.0),
        })
    }
}

/// The content of `subaps_summary.json`.
#[derive(Debug, Clone, Serialize)]
pub struct SubapsSummary {
    /// Tool and version that wrote the files.
    pub tool: String,
    /// Where the map came from.
    pub map_source: String,
    /// Every option and input checksum the results depend on.
    pub options: Binding,
    /// How sub-apertures are given to shards.
    pub shard_rule: String,
    /// Sub-apertures by status word (every word listed, in the order of the legend).
    pub counts: serde_json::Map<String, serde_json::Value>,
    /// sigma_eff over the `ok` sub-apertures; null when none is `ok`.
    pub sigma_eff_ok: Option<Spread>,
    /// The files written (names in the directory).
    pub files: Vec<String>,
}

impl SubapsSummary {
    /// The summary of a job's `records` (index order) under `header`.
    pub fn new(header: &PartHeader, records: &[PartRecord]) -> SubapsSummary {
        SubapsSummary {
            tool: format!("detnoise {}", env!("CARGO_PKG_VERSION")),
            map_source: header.map_source.clone(),
            options: header.binding.clone(),
            shard_rule: "shard K of N holds the sub-apertures whose index is K-1 modulo N".into(),
            counts: Status::ALL
                .iter()
                .map(|s| {
                    let n = records.iter().filter(|r| r.status == *s).count();
                    (s.label().to_string(), n.into())
                })
                .collect(),
            sigma_eff_ok: Spread::of(records),
            files: OUTPUT_NAMES.iter().map(|s| s.to_string()).collect(),
        }
    }

    /// Sub-apertures whose status is `s`.
    pub fn count(&self, s: Status) -> usize {
        self.counts
            .get(s.label())
            .and_then(serde_json::Value::as_u64)
            .map_or(0, |n| n as usize)
    }
}

/// Write every file of [`OUTPUT_NAMES`] into `dir` from `header` and the job's `records` (in
/// index order); returns the summary and the paths written.
pub fn write_outputs(
    header: &PartHeader,
    records: &[PartRecord],
    dir: &Path,
) -> Result<(SubapsSummary, Vec<PathBuf>)> {
    let b = &header.binding;
    let rows: Vec<SubapRow> = records.iter().map(|r| SubapRow::new(r, b)).collect();
    let path = |name: &str| dir.join(name);
    write_atomic(
        &path(OUTPUT_NAMES[0]),
        render(&rows, TableFormat::Csv)?.as_bytes(),
    )?;
    let [gr, gc] = b.grid_shape;
    let mut sigma = vec![f64::NAN; gr * gc];
    let mut se = vec![f64::NAN; gr * gc];
    let mut status = vec![NO_SUBAP_CODE; gr * gc];
    for r in records {
        let cell = r.grid_row * gc + r.grid_col;
        status[cell] = status_code(r.status);
        if r.status == Status::Ok {
            sigma[cell] = r.sigma_eff_e;
            se[cell] = r.sigma_eff_se_e;
        }
    }
    let keys = fits_keys(header);
    let with = |what: &str| {
        let mut k = keys.clone();
        k.push(key(
            "CONTENT",
            KeyValue::Str(what.into()),
            "what the pixels hold",
        ));
        k
    };
    let only_ok = "NaN where the status is not ok or no sub-aperture";
    write_image(
        &path(OUTPUT_NAMES[1]),
        (gr, gc),
        ImageData::F64(&sigma),
        "electron",
        &with(&format!("effective read noise; {only_ok}")),
    )?;
    write_image(
        &path(OUTPUT_NAMES[2]),
        (gr, gc),
        ImageData::F64(&se),
        "electron",
        &with(&format!("standard error of sigma_eff; {only_ok}")),
    )?;
    let mut status_keys = with("status code of each sub-aperture (STATn keys)");
    status_keys.push(key(
        "STATNONE",
        KeyValue::I64(NO_SUBAP_CODE as i64),
        "no sub-aperture (masked or not fitting)",
    ));
    for s in Status::ALL {
        status_keys.push(key(
            &format!("STAT{}", status_code(s)),
            KeyValue::Str(s.label().into()),
            "status of this code",
        ));
    }
    write_image(
        &path(OUTPUT_NAMES[3]),
        (gr, gc),
        ImageData::I32(&status),
        "",
        &status_keys,
    )?;
    let (floor, what) = super::crlb::floor_image(header, records);
    write_image(
        &path(super::crlb::FLOOR_NAME),
        (gr, gc),
        ImageData::F64(&floor),
        "pixel",
        &with(&what),
    )?;
    for name in &OUTPUT_NAMES[4..6] {
        subaps_chart(header, records, &path(name))?;
    }
    let summary = SubapsSummary::new(header, records);
    write_json(&path(OUTPUT_NAMES[6]), &summary)?;
    // OUTPUT_NAMES[7], the Cramer-Rao floor, is written above with the other images.
    let cells: Vec<(usize, usize, EffectiveParts)> = records
        .iter()
        .map(|r| (r.grid_row, r.grid_col, r.parts))
        .collect();
    super::static_maps::write_maps(dir, (gr, gc), &cells, &keys)?;
    Ok((summary, OUTPUT_NAMES.iter().map(|n| path(n)).collect()))
}

/// The provenance keywords of the images: grid, configuration, precision, map checksum.
fn fits_keys(h: &PartHeader) -> Vec<Keyword> {
    let b = &h.binding;
    let int = |v: usize| KeyValue::I64(v as i64);
    vec![
        key("SUBSIZE", int(b.grid.size_px), "sub-aperture side, px"),
        key("SUBPITCH", int(b.grid.pitch_px), "sub-aperture pitch, px"),
        key(
            "SUBX0",
            int(b.grid.x0_px),
            "first sub-aperture's first column, px",
        ),
        key(
            "SUBY0",
            int(b.grid.y0_px),
            "first sub-aperture's first row, px",
        ),
        key("SPOT", KeyValue::Str(b.spot.clone()), "spot (px)"),
        key(
            "SAMPLING",
            KeyValue::Str(b.sampling.clone()),
            "spot sampling",
        ),
        key(
            "SIGNAL",
            KeyValue::F64(b.signal_photons),
            "photons per sub-aperture",
        ),
        key("QE", KeyValue::F64(b.qe), "photo-electrons per photon"),
        key(
            "ITERS",
            KeyValue::I64(b.iters as i64),
            "starting iterations, frames",
        ),
        key(
            "MAXITERS",
            KeyValue::I64(b.max_iters as i64),
            "iteration cap, frames",
        ),
        key(
            "TARGSE",
            KeyValue::F64(b.target_se_e),
            "target SE, e- (0 = off)",
        ),
        key(
            "TARGREL",
            KeyValue::F64(b.target_rel),
            "relative target SE (0 = off)",
        ),
        key(
            "SEED",
            KeyValue::Str(b.seed.to_string()),
            "seed of every sub-aperture",
        ),
        key(
            "BGGRID",
            KeyValue::Str(b.bg_grid.clone()),
            "background levels, e-",
        ),
        key(
            "CENTROID",
            KeyValue::Str(b.centroider.clone()),
            "centroider of every sub-aperture",
        ),
        key(
            "MAPB3",
            KeyValue::Str(b.map_blake3.clone()),
            "BLAKE3 of the map values",
        ),
        key(
            "MAPSRC",
            KeyValue::Str(h.map_source.clone()),
            "noise map (e-)",
        ),
    ]
}

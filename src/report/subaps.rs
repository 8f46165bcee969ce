//! The report's per-sub-aperture section (with `subaps` set): the effective read noise of
//! every sub-aperture of the lenslet geometry, each reading through its own window of the
//! report's measured noise map, at the operating point's spot and signal; its files in the
//! report directory and its part of the page.

use super::grid::Grid;
use super::html::{figure, key, num};
use super::options::ReportOptions;
use crate::calib::Map;
use crate::centroid::CentroiderSpec;
use crate::detector::PerPixelSigma;
use crate::effective::Status;
use crate::montecarlo::SimConfig;
use crate::output::html_escape as esc;
use crate::output::OutputDir;
use crate::progress::Observer;
use crate::subaps::{
    check_centroider, solve_all, write_outputs, Geometry, SubapsJob, SubapsSummary, OUTPUT_NAMES,
};
use crate::Result;
use std::fmt::Write as _;

/// Solve every sub-aperture of `geometry` on the measured `map` (e-) in the report's
/// configuration (the grid's size, the operating point's spot and signal, the report's
/// iterations, seed, sampling, QE and precision) and write its files into `dir`; returns the
/// summary (for summary.json and the page) and the names written.
pub(crate) fn subaps_section(
    o: &ReportOptions,
    grid: &Grid,
    geometry: &Geometry,
    map: &Map,
    dir: &OutputDir,
    observer: &dyn Observer,
) -> Result<(SubapsSummary, Vec<String>)> {
    let job = SubapsJob {
        map,
        geometry,
        config: config(o, grid, geometry),
        precision: o.precision_in_use(),
        centroider: centroider(o),
    };
    let (header, records) = solve_all(&job, observer)?;
    let (summary, _) = write_outputs(&header, &records, &dir.path(""))?;
    Ok((summary, OUTPUT_NAMES.map(String::from).to_vec()))
}

/// Check the geometry against the map the report will measure (`shape`, rows x cols px, from
/// the frames' headers) and the centroider against its windows, before any work: the errors
/// the section would otherwise meet after the whole report's Monte-Carlo.
pub(crate) fn check_geometry(
    o: &ReportOptions,
    grid: &Grid,
    geometry: &Geometry,
    (rows, cols): (usize, usize),
) -> Result<()> {
    geometry.layout(rows, cols)?;
    let cfg = config(o, grid, geometry);
    let n = cfg.subap_px;
    let window = PerPixelSigma::new(vec![1.0; n * n], "subap window".into());
    check_centroider(&cfg, centroider(o), &window)
}

/// The configuration of every sub-aperture: the grid's size, the operating point's spot and
/// signal, the report's iterations, seed, sampling and QE.
fn config(o: &ReportOptions, grid: &Grid, geometry: &Geometry) -> SimConfig {
    let op = o.operating_point();
    grid.config(geometry.grid.size_px, op.spot, op.signal_photons, o.qe)
}

/// The centroider of the section: the report's first.
fn centroider(o: &ReportOptions) -> CentroiderSpec {
    o.centroiders.first().copied().unwrap_or_default()
}

/// The page's section: the chart, the spread of sigma_eff over the sub-apertures and the
/// count by status.
pub(crate) fn section_html(h: &mut String, s: &SubapsSummary) {
    let b = &s.options;
    let g = &b.grid;
    let _ = write!(
        h,
        "<h2>Effective read noise per sub-aperture</h2><p>Each of the {} sub-apertures of the \
         lenslet grid ({}×{} px, pitch {} px, first at x {} px, y {} px; grid {}×{}{}) reads \
         through its own window of this camera's measured noise map, centroided with {}, at {}, \
         {} photons (the operating point's spot and signal), every sub-aperture on the same \
         random numbers: the \
         differences between them are the map's. This is the per-sub-aperture noise a \
         tomographic reconstructor's noise covariance wants.</p><div class=\"keys\">",
        b.subaps,
        g.size_px,
        g.size_px,
        g.pitch_px,
        g.x0_px,
        g.y0_px,
        b.grid_shape[0],
        b.grid_shape[1],
        if b.masked > 0 {
            format!(", {} masked", b.masked)
        } else {
            String::new()
        },
        esc(&b.centroider),
        esc(&b.spot),
        b.signal_photons,
    );
    match &s.sigma_eff_ok {
        Some(o) => {
            let e = |v: f64| format!("{} e⁻", num(v, 2));
            key(
                h,
                &format!("Median σ<sub>eff</sub> ({} ok sub-apertures)", o.ok),
                &e(o.median_e),
            );
            key(
                h,
                "Lowest – highest",
                &format!("{} – {}", num(o.min_e, 2), e(o.max_e)),
            );
            key(
                h,
                "Spread (10th to 90th percentile)",
                &format!(
                    "{} ({} – {})",
                    e(o.spread_p90_p10_e),
                    num(o.p10_e, 2),
                    num(o.p90_e, 2)
                ),
            );
        }
        None => key(
            h,
            "Median σ<sub>eff</sub>",
            "no sub-aperture is <span class=\"status\">ok</span>",
        ),
    }
    let counts: Vec<String> = Status::ALL
        .iter()
        .map(|st| {
            format!(
                "{} <span class=\"status\">{}</span>",
                s.count(*st),
                st.label()
            )
        })
        .collect();
    key(h, "Sub-apertures by status", &counts.join("<br>"));
    h.push_str("</div>");
    figure(
        h,
        "subaps_sigma_eff.png",
        "Effective read noise per sub-aperture over the detector",
        "Effective read noise (e⁻) of each sub-aperture at its place on the detector; only \
         <span class=\"status\">ok</span> values are coloured, the others show their status \
         word (grey, hatched) or, for a large grid, are grey.",
    );
    h.push_str(
        "<p class=\"note\">Files: subaps.csv (one row per sub-aperture: grid cell, \
         first pixel, σ<sub>eff</sub> with SE and status, R, iterations, the median and rms of \
         the map in its window), subaps_sigma_eff_e.fits (ok values only), \
         subaps_sigma_eff_se_e.fits, subaps_status.fits (status codes, STATn keywords), \
         subaps_sigma_eff.png/.svg, subaps_summary.json. For a large detector run \
         <code>detnoise subaps</code> (resumable, shardable) on rms_e.fits.</p>",
    );
}

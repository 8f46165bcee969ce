//! The report's `index.html`: one self-contained page (relative image links, inline CSS).
//!
//! Numbers that are not results never show as numbers: an effective noise whose status is not
//! `ok` shows its status word (and, for `imprecise`, its value and SE in grey), a missing value a
//! dash; the page carries a legend of the status words.

use super::compare::verdicts;
use super::html::{article, figure, fmt_effective, key, num, page_head, pm};
use super::result::{Compared, EmccdSummary, RealNoise, ReportSummary};
use crate::calib::darks::{RtsSummary, TemporalNoiseSummary};
use crate::charts::heatmaps::NoiseScale;
use crate::detector::ModelSpec;
use crate::effective::{EffectiveRecord, Status};
use crate::fit::pdf_fit::PdfFitReport;
use crate::fit::PdfModel;
use crate::output::html_escape as esc;
use crate::plot::Heatmap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// How the page writes a spot.
const SPOT_NOTATION: &str = "<span class=\"note\">Spots: <code>airy:D</code> is an Airy spot whose first dark ring is D px across; <code>gauss:SX,SY</code> a Gaussian spot of standard deviations SX and SY px.</span>";

/// Files of the page and its numbers.
pub(crate) const PAGE_FILES: [&str; 2] = ["summary.json", "index.html"];

/// The legend of the effective-noise status words.
fn status_legend(h: &mut String) {
    h.push_str("<h3>Status words</h3><dl class=\"legend\">");
    for s in Status::ALL {
        let _ = write!(
            h,
            "<dt><span class=\"status\">{}</span></dt><dd>{}</dd>",
            s.label(),
            esc(s.meaning())
        );
    }
    h.push_str("</dl>");
}

/// What to do where no constant sigma reproduces the camera: simulate it directly, with the
/// map or the fitted pdf this report wrote into `out_dir`.
fn unreachable_advice(h: &mut String, out_dir: &Path) {
    let file = |name: &str| esc(&out_dir.join(name).display().to_string());
    let _ = write!(
        h,
        "<p class=\"advice\">Some configurations are <span class=\"status\">unreachable</span>: no constant Gaussian read noise gives a centroid error as large as this camera's there (a few very noisy pixels dominate). Do not use a single σ for them: simulate the camera itself in the AO simulation, either its measured noise map (<code>detnoise simulate --model scmos-map --map {}</code>) or its fitted per-pixel distribution (<code>detnoise simulate --model scmos-random --pdf {}</code>), with your sub-aperture size, spot and signal (<code>--subap</code>, <code>--spot</code>, <code>--signal</code>). This report wrote both files for that purpose.</p>",
        file("rms_e.fits"),
        file("pdf_fit.json")
    );
}

/// The EMCCD report page: the EM-gain fit, then the comparison with sCMOS models;
/// `error_bars` is what the comparison chart's caption says of its error bars, `qe_section` the
/// simple model's effective QE factor (HTML, [`super::qe_factor::html_section`]).
pub fn emccd_html(
    s: &EmccdSummary,
    comparison: &[Compared],
    error_bars: &str,
    qe_section: &str,
) -> String {
    let f = &s.emgain;
    let op = &s.operating_point;
    let mut h = page_head();
    let _ = write!(h, "<h1>EMCCD report</h1><p class=\"note\">{} · {} frames of {}×{} px · conversion gain {:.4} e⁻/adu · exact register fit · {} iterations per point, seed {}{}</p>",
        esc(&s.tool), s.frames, s.shape[0], s.shape[1], s.gain_e_per_adu, s.iters, s.seed,
        if s.quick { " · <b>quick preview: reduced grid and iterations</b>" } else { "" });
    let _ = write!(h, "<p>Operating point: {}.</p>", esc(&op.describe()));
    h.push_str("<h2>Key numbers</h2><div class=\"keys\">");
    key(
        &mut h,
        &format!("EM gain ({})", esc(&f.em_gain_units)),
        &format!("{} ± {}", num(f.em_gain, 2), num(f.em_gain_se, 2)),
    );
    key(
        &mut h,
        "Read noise (output e⁻)",
        &format!("{} e⁻", num(s.read_noise_output_e, 1)),
    );
    key(
        &mut h,
        "Read noise / EM gain (input e⁻)",
        &format!("{} e⁻", num(s.read_noise_output_e / f.em_gain, 3)),
    );
    key(
        &mut h,
        "Mean input electrons per pixel",
        &format!("{} ± {}", num(f.lambda_e, 4), num(f.lambda_e_se, 4)),
    );
    key(&mut h, "Bias", &format!("{} adu", num(f.bias_adu, 2)));
    let _ = write!(h, "</div><p><b>Against sCMOS</b> (an EMCCD with this gain and read noise against an sCMOS with the paper's pdf, R at {} {}×{} px sub-aperture, {}):</p><ul>", article(op.subap_px as u64), op.subap_px, op.subap_px, esc(&op.spot));
    verdict_list(
        &mut h,
        comparison,
        op.signal_photons,
        (&ModelSpec::EmccdStochastic, "this EMCCD"),
        (&ModelSpec::ScmosRandom, "the sCMOS"),
    );
    h.push_str("<h2>Charts</h2>");
    figure(&mut h, "emgain.png", "EM-gain fit: histogram of all pixel samples with the fitted model", "Histogram of all pixel-samples (log counts) with the fitted Poisson-register-Gaussian model and its zero- and one-or-more-electron parts.");
    figure(&mut h, "r_vs_signal.png", "R against signal: this EMCCD against sCMOS models", &format!("Mean radial centroid error R against signal, {}×{} px, {}: this EMCCD (fitted gain and read noise) against sCMOS models. Lower is better. {}", op.subap_px, op.subap_px, esc(&op.spot), esc(error_bars)));
    h.push_str(qe_section);
    if let Some(c) = &s.camera {
        super::camera::section_html(&mut h, c);
    }
    h.push_str("<h2>Files</h2><p class=\"note\">summary.json (the fit with uncertainties and correlations, the operating point, the effective QE factor's key numbers, inputs with BLAKE3 checksums), r_vs_signal.csv/.svg, emgain.png, effective_qe.csv/.json (the QE factor of every configuration) and its chart.</p></body></html>\n");
    h
}

/// The verdicts of `mine` against `other` at each signal, the operating point's in bold.
fn verdict_list(
    h: &mut String,
    comparison: &[Compared],
    at_signal: f64,
    mine: (&ModelSpec, &str),
    other: (&ModelSpec, &str),
) {
    for (sig, v) in verdicts(comparison, mine, other) {
        if sig == at_signal {
            let _ = write!(
                h,
                "<li><b>{sig} photons (operating point): {}</b></li>",
                esc(&v)
            );
        } else {
            let _ = write!(h, "<li>{sig} photons: {}</li>", esc(&v));
        }
    }
    h.push_str("</ul>");
}

/// What the sCMOS page shows.
pub struct ScmosPage<'a> {
    /// The key numbers (summary.json).
    pub summary: &'a ReportSummary,
    /// The fit of the per-pixel noise distribution.
    pub fit: &'a PdfFitReport,
    /// The effective-noise table (fitted pdf, then measured map).
    pub effective: &'a [EffectiveRecord],
    /// R against signal per compared model.
    pub comparison: &'a [Compared],
    /// The heatmaps written (PNG and SVG).
    pub heatmaps: &'a [PathBuf],
    /// The heatmaps' colour scale.
    pub scale: &'a NoiseScale,
    /// What the comparison chart's caption says of its error bars.
    pub error_bars: &'a str,
    /// Whether photon transfer gave the gain (ptc.png and ptc_points.* were written).
    pub has_ptc: bool,
    /// The report's directory as given (for the commands that use its files).
    pub out_dir: &'a Path,
}

/// The sCMOS report page: key numbers, verdicts, charts and tables.
pub fn index_html(p: &ScmosPage) -> String {
    let s = p.summary;
    let op = &s.operating_point;
    let at = &op.at;
    let mut h = page_head();
    let _ = write!(h, "<h1>Read-noise report</h1><p class=\"note\">{} · {} dark frames of {}×{} px · gain {:.4} e⁻/adu ({}) · {} iterations per configuration, seed {}, {} sampling{}</p>",
        esc(&s.tool), s.frames, s.shape[0], s.shape[1], s.gain_e_per_adu, esc(&s.gain_source), s.iters, s.seed, esc(&s.sampling),
        if s.quick { " · <b>quick preview: reduced grid and iterations; run without --quick for full accuracy</b>" } else { "" });
    let _ = write!(
        h,
        "<p>Operating point of the headline numbers: {}. {SPOT_NOTATION}</p>",
        esc(&at.describe())
    );
    h.push_str("<h2>Key numbers</h2><div class=\"keys\">");
    key(
        &mut h,
        "Median read noise (the data-sheet number)",
        &format!("{} e⁻", num(s.median_rms_e, 3)),
    );
    key(
        &mut h,
        "Mean read noise",
        &format!("{} e⁻", num(s.mean_rms_e, 3)),
    );
    key(
        &mut h,
        "RMS of the per-pixel noise",
        &format!("{} e⁻", num(s.rms_rms_e, 3)),
    );
    key(
        &mut h,
        "Noisy pixels (above 3× median)",
        &format!("{} %", num(100.0 * s.frac_above_3x_median, 2)),
    );
    key(
        &mut h,
        &format!(
            "Effective read noise, {}×{} px, {}, {} photons (this camera's measured map)",
            at.subap_px,
            at.subap_px,
            esc(&at.spot),
            at.signal_photons
        ),
        &fmt_effective(
            op.sigma_eff_map_e,
            op.sigma_eff_map_se_e,
            op.sigma_eff_map_status,
        ),
    );
    key(
        &mut h,
        "Same, from the fitted distribution (the heatmaps' model)",
        &fmt_effective(
            op.sigma_eff_fitted_pdf_e,
            op.sigma_eff_fitted_pdf_se_e,
            op.sigma_eff_fitted_pdf_status,
        ),
    );
    h.push_str("</div>");
    let _ = write!(h, "<p>Use the effective read noise, not the median, as the Gaussian read noise of this camera in an AO simulation of {} {}×{} px sub-aperture. It is the constant read noise that gives the same mean centroid error R as the camera itself. Two models of the camera give it: its <b>measured map</b> (scmos-map: random windows of this camera's own per-pixel noise, the headline) and its <b>fitted distribution</b> (scmos-random: each pixel's noise drawn from the fit of the map's values, what the heatmaps below show). The table at the end gives both for every sub-aperture size, spot and signal; only values marked <span class=\"status\">ok</span> (shown as value ± SE) are results.</p>", article(at.subap_px as u64), at.subap_px, at.subap_px);
    let unreachable = p
        .effective
        .iter()
        .map(|r| r.effective.status)
        .chain([op.sigma_eff_map_status, op.sigma_eff_fitted_pdf_status])
        .any(|st| st == Status::Unreachable);
    if unreachable {
        unreachable_advice(&mut h, p.out_dir);
    }
    let _ = write!(h, "<p><b>Which detector wins</b> with the paper's centroider, plain cog (this camera's measured map against an EMCCD, R at {} {}×{} px sub-aperture, {}; the centroiders section below asks the same with each camera's best centroider, and the answer can differ):</p><ul>", article(at.subap_px as u64), at.subap_px, at.subap_px, esc(&at.spot));
    verdict_list(
        &mut h,
        p.comparison,
        at.signal_photons,
        (&ModelSpec::ScmosMap, "this camera"),
        (&ModelSpec::EmccdStochastic, "the EMCCD"),
    );
    charts(&mut h, p);
    real_noise_section(&mut h, &s.real_noise, &at.describe());
    if let Some(c) = &s.camera {
        super::camera::section_html(&mut h, c);
    }
    super::centroiders::section_html(&mut h, &s.centroiders, &op.at);
    if let Some(subaps) = &s.subaps {
        super::subaps::section_html(&mut h, subaps);
    }
    effective_table(&mut h, p.effective);
    h.push_str(&super::static_part::html_section(p.effective));
    fit_table(&mut h, p.fit);
    let _ = writeln!(h, "<h2>Files</h2><p class=\"note\">Maps (FITS, with BUNIT): offset_adu.fits, rms_adu.fits, rms_e.fits (usable with <code>detnoise simulate --model scmos-map --map</code>), flags.fits. Charts: rms_hist.png (the per-pixel read noise of every pixel, flagged ones included, log counts; the fit's chart above shows the unflagged ones), the heatmaps also as SVG, r_vs_signal.svg. Tables: effective_noise.csv/.json, r_vs_signal.csv, pdf_fit.json (usable with <code>detnoise simulate</code> or <code>detnoise effective --pdf</code>){}, summary.json (every number above with units, the operating point, every input with its BLAKE3 checksum), darks_summary.json.</p></body></html>",
        if p.has_ptc { ", ptc_points.csv/.json (the photon-transfer points: mean, variance and gain per light level)" } else { "" });
    h
}

/// "The camera's noise beyond Gaussian pixels": the pixel/row/column split, the telegraph
/// pixels, their example series, and the effective read noise of the richer models at the
/// operating point (`at`) beside the map's, with what each adds.
fn real_noise_section(h: &mut String, r: &RealNoise, at: &str) {
    let t = &r.temporal_noise;
    h.push_str("<h2>The camera's noise beyond Gaussian pixels</h2>");
    let _ = write!(h, "<p>Dark temporal noise split into its parts ({} frames; each part's rms with its SE): </p><table><tr><th>part</th><th>rms (e⁻)</th><th>rms (adu)</th></tr>", t.frames);
    for (name, e, se_e, adu, se_adu) in [
        (
            "pixel (independent per pixel)",
            t.pixel_rms_e,
            t.pixel_rms_se_e,
            t.pixel_rms_adu,
            t.pixel_rms_se_adu,
        ),
        (
            "row (shared along a row)",
            t.row_rms_e,
            t.row_rms_se_e,
            t.row_rms_adu,
            t.row_rms_se_adu,
        ),
        (
            "column (shared along a column)",
            t.column_rms_e,
            t.column_rms_se_e,
            t.column_rms_adu,
            t.column_rms_se_adu,
        ),
        (
            "total",
            t.total_rms_e,
            t.total_rms_se_e,
            t.total_rms_adu,
            t.total_rms_se_adu,
        ),
    ] {
        let _ = write!(
            h,
            "<tr><td>{name}</td><td>{}</td><td>{}</td></tr>",
            pm(e, se_e, 3),
            pm(adu, se_adu, 3)
        );
    }
    h.push_str("</table>");
    split_note(h, t);
    rts_sentence(h, &r.rts);
    if !r.rts.example_pixels.is_empty() {
        figure(h, "rts_series.png", "Example RTS pixel time series", "Example RTS pixels: output less the pixel's mean (e⁻) against frame, stacked apart; data in rts-series.csv (adu).");
    }
    if let Some(d) = &r.dark_frames {
        let _ = write!(h, "<p class=\"note\">scmos-frames: {}.</p>", esc(d));
    }
    let _ = write!(h, "<p>Effective read noise at {} with each model of the camera's noise, and what it adds to the measured map's (common random numbers; the SE of a difference combines both SEs, which overstates it). A difference is a result only when marked <span class=\"status\">ok</span> (both values ok, the difference at least 2 SE).</p><table><tr><th>model</th><th>σ<sub>eff</sub> ± SE (e⁻)</th><th>adds to the map's ± SE (e⁻)</th><th>status of the difference</th></tr>", esc(at));
    for row in &r.rows {
        let sigma = fmt_effective(
            row.sigma_eff_e.unwrap_or(f64::NAN),
            row.sigma_eff_se_e.unwrap_or(f64::NAN),
            row.status,
        );
        let adds = if row.adds_status == "ok" || row.adds_status == "not_resolved" {
            format!(
                "{:+.3} ± {:.3}",
                row.adds_e.unwrap_or(f64::NAN),
                row.adds_se_e.unwrap_or(f64::NAN)
            )
        } else {
            "–".into()
        };
        let _ = write!(h, "<tr><td>{}</td><td>{sigma}</td><td>{adds}</td><td><span class=\"status\">{}</span></td></tr>", esc(&row.model), esc(&row.adds_status));
    }
    h.push_str("</table>");
}

/// Why the pixel part can show above the total: the line parts are differences of variances,
/// negative by chance without line noise (shown as rms 0), and the pixel part is the total
/// less both.
fn split_note(h: &mut String, t: &TemporalNoiseSummary) {
    let (Some(pixel), Some(total), Some(se)) = (t.pixel_rms_e, t.total_rms_e, t.pixel_rms_se_e)
    else {
        return;
    };
    if pixel <= total {
        return;
    }
    let _ = write!(h, "<p class=\"note\">The pixel part is above the total by {} e⁻: the row and column parts are estimated as differences of variances, which come out negative by chance about half the time when a camera has no row or column noise (an rms of 0 here, the rms of a negative variance); the pixel part is the total less both, so it is then slightly above the total. The difference is within the pixel part's SE ({} e⁻): this camera shows no measurable row or column noise.</p>", num(pixel - total, 4), num(se, 4));
}

/// The telegraph pixels: how many, and their median span and dwell time when any was fitted
/// `ok`.
fn rts_sentence(h: &mut String, rts: &RtsSummary) {
    if rts.flagged == 0 {
        h.push_str("<p>Random-telegraph (RTS) pixels: none was flagged, so there is no span or dwell time to give.</p>");
        return;
    }
    let _ = write!(h, "<p>Random-telegraph (RTS) pixels: {} flagged, {} fitted, {} fitted <span class=\"status\">ok</span> ({} two-level, {} three-level)", rts.flagged, rts.fitted, rts.ok, rts.two_level, rts.three_level);
    match (rts.median_span_e, rts.median_dwell_frames) {
        (Some(span), Some(dwell)) => {
            let _ = write!(h, "; median span between a pixel's outer levels {} e⁻, median dwell time {} frames (per pixel in rts.csv / rts.fits).</p>", num(span, 2), num(dwell, 1));
        }
        _ => h.push_str("; none fitted ok, so no span or dwell time to give (per pixel in rts.csv / rts.fits).</p>"),
    }
}

/// The page's charts: the pdf fit, the comparison, the heatmaps, the noise histogram and the
/// photon transfer.
fn charts(h: &mut String, p: &ScmosPage) {
    let s = p.summary;
    h.push_str("<h2>Charts</h2>");
    figure(h, "pdf_fit.png", "Per-pixel read noise with the fitted distributions", &format!("Per-pixel read noise (e⁻) of the {} unflagged pixels with the fitted distributions; best by AIC: <b>{}</b>. Inset: log scale, showing the tail of noisy pixels.", s.pixels_used, esc(&s.pdf_best_model)));
    figure(h, "r_vs_signal.png", "R against signal for this camera, one-number models and an EMCCD", &format!("Mean radial centroid error R against signal: this camera (random windows of its measured noise map, and its fitted distribution), the one-number models (median, mean) and an EMCCD. Lower is better. {}", esc(p.error_bars)));
    let op = &s.operating_point;
    let _ = write!(h, "<p>The heatmaps show the effective read noise of the <b>fitted distribution</b> (scmos-random) over every sub-aperture size and spot, one chart per signal; the headline above is the <b>measured map</b>'s (scmos-map). At the operating point the fitted distribution gives {} and the measured map {}; the measured map's value for every configuration is in the table at the end and in effective_noise.csv.</p>",
        fmt_effective(op.sigma_eff_fitted_pdf_e, op.sigma_eff_fitted_pdf_se_e, op.sigma_eff_fitted_pdf_status),
        fmt_effective(op.sigma_eff_map_e, op.sigma_eff_map_se_e, op.sigma_eff_map_status));
    for path in p
        .heatmaps
        .iter()
        .filter(|q| q.extension().is_some_and(|e| e == "png"))
    {
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().to_string())
            .unwrap_or_default();
        let signal = name
            .trim_start_matches("effective_noise_S")
            .trim_end_matches(".png");
        figure(h, &name, &format!("Effective read noise by sub-aperture size and spot, {signal} photons"), &format!("Effective Gaussian read noise (e⁻) by sub-aperture size and spot, from the fitted distribution, at {signal} photons per sub-aperture; {}, the same for every signal; {} marks a value above it (drawn in its top colour). Grey hatched cells are not results: they show their status word (see the legend below).", esc(&p.scale.describe()), Heatmap::CLIPPED_MARK));
    }
    if p.has_ptc {
        figure(h, "ptc.png", "Photon transfer: variance against mean of the flats", "Photon transfer: variance against mean signal of the flats (dark-subtracted), with the fit that gives the conversion gain. The points are in ptc_points.csv/.json with each level's own gain.");
    }
}

/// The effective-noise table: value ± SE where `ok`, greyed with its word where `imprecise`,
/// the status word alone otherwise; then the legend of the words.
fn effective_table(h: &mut String, effective: &[EffectiveRecord]) {
    let _ = write!(h, "<h2>Effective read noise</h2><details><summary>Every configuration: {} rows, the fitted distribution's then the measured map's (also in effective_noise.csv and .json)</summary><table><tr>", effective.len());
    h.push_str("<th>detector model</th><th>sub-aperture (px)</th><th>spot</th><th>signal (photons)</th><th>σ<sub>eff</sub> ± SE (e⁻)</th><th>R ± SE (px)</th><th>R<sub>crlb</sub> (px): the floor of any unbiased centroid</th></tr>");
    for r in effective {
        let e = &r.effective;
        let _ = write!(
            h,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{} ± {}</td><td>{}</td></tr>",
            esc(&r.model),
            r.config.subap_px,
            esc(&r.config.spot.label()),
            r.config.signal_photons,
            fmt_effective(e.sigma_eff_e, e.sigma_eff_se_e, e.status),
            num(e.r_px, 4),
            num(e.r_se_px, 4),
            r.r_crlb_px.map_or("–".into(), |f| num(f, 4))
        );
    }
    h.push_str("</table></details>");
    status_legend(h);
}

/// The fit table's columns that need a word.
const FIT_COLUMNS: [(&str, &str); 3] = [
    ("ln L", "log-likelihood: the log of the probability density of the map's per-pixel noise values under the model, summed over pixels; higher fits better"),
    ("ΔAIC", "Akaike information criterion (2 × parameters − 2 ln L) less the best model's: 0 for the best, which the report uses; a model more than about 10 above it is clearly worse"),
    ("max CDF distance", "the largest gap between the model's cumulative distribution and the measured one (the Kolmogorov–Smirnov statistic): 0 is a perfect match"),
];

/// A fitted model of the per-pixel noise distribution, in words.
fn model_meaning(m: PdfModel) -> &'static str {
    match m {
        PdfModel::PaperScaled => "the paper's distribution (Basden 2015, Eq. 3) stretched along the noise axis by one fitted factor",
        PdfModel::PaperFamily => "the paper's functional form with its constants free: the edge and steepness of its core and the weights of its three power-law tail terms",
        PdfModel::LognormalTail => "a log-normal core plus a power-law tail of noisy pixels",
        PdfModel::Empirical => "the measured values themselves (no parameters; ln L and ΔAIC do not apply)",
    }
}

/// The table of fitted read-noise distributions.
fn fit_table(h: &mut String, fit: &PdfFitReport) {
    h.push_str("<h2>Fitted read-noise distributions</h2><table><tr><th>model</th><th>ln L</th><th>ΔAIC</th><th>max CDF distance</th><th>median (e⁻)</th><th>mean (e⁻)</th><th>rms (e⁻)</th><th>&gt;3× median</th></tr>");
    for (name, m) in &fit.models {
        let opt = |v: Option<f64>| v.map_or_else(|| "–".into(), |x| num(x, 1));
        let _ = write!(h, "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{} %</td></tr>", esc(name), opt(m.log_likelihood), opt(m.delta_aic), num(m.max_cdf_distance, 4), num(m.median_e, 3), num(m.mean_e, 3), num(m.rms_e, 3), num(100.0 * m.frac_above_3x_median, 2));
    }
    h.push_str("</table><h3>What the columns and models mean</h3><dl class=\"legend\">");
    let terms = FIT_COLUMNS
        .iter()
        .copied()
        .chain(PdfModel::ALL.map(|m| (m.name(), model_meaning(m))));
    for (term, meaning) in terms {
        let _ = write!(h, "<dt>{}</dt><dd>{meaning}</dd>", esc(term));
    }
    h.push_str("</dl>");
}

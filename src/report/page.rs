//! The report's `index.html`: one self-contained page (relative image links, inline CSS).

use super::compare::verdicts;
use super::result::{Compared, EmccdSummary, ReportSummary};
use crate::detector::ModelSpec;
use crate::effective::EffectiveRecord;
use crate::fit::pdf_fit::PdfFitReport;
use crate::output::html_escape as esc;
use std::fmt::Write as _;
use std::path::PathBuf;

fn fmt_sigma(v: f64, se: f64) -> String {
    if v.is_finite() {
        format!("{v:.2} ± {se:.2} e⁻")
    } else {
        "none (no Gaussian σ reproduces it)".into()
    }
}

/// The page's head and style sheet, shared by both kinds of report.
fn page_head() -> String {
    let mut h = String::new();
    let _ = write!(
        h,
        "<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\"><meta name=\"viewport\" content=\"width=device-width\"><title>detnoise report</title><style>\
body{{font-family:'DejaVu Sans',Helvetica,Arial,sans-serif;max-width:1100px;margin:1.5em auto;padding:0 1em;color:#1d1d1d;line-height:1.45}}\
h1{{font-size:1.6em;margin-bottom:.2em}}h2{{margin-top:1.8em;border-bottom:2px solid #ddd;padding-bottom:.2em}}\
.keys{{display:grid;grid-template-columns:repeat(auto-fill,minmax(230px,1fr));gap:.8em;margin:1em 0}}\
.key{{background:#f3f6fa;border:1px solid #d5dde8;border-radius:6px;padding:.7em .9em}}.key b{{display:block;font-size:1.45em;color:#0b4f8a}}\
figure{{margin:1.5em 0}}figure img{{max-width:100%;border:1px solid #e3e3e3}}figcaption{{color:#444;font-size:.93em}}\
table{{border-collapse:collapse;font-size:.88em;margin:.8em 0}}td,th{{border:1px solid #ccc;padding:.25em .55em;text-align:right}}th{{background:#f0f0f0}}\
.note{{color:#555;font-size:.9em}}</style></head><body>"
    );
    h
}

/// The EMCCD report page: the EM-gain fit, then the comparison with sCMOS models.
pub fn emccd_html(s: &EmccdSummary, comparison: &[Compared]) -> String {
    let f = &s.emgain;
    let mut h = page_head();
    let _ = write!(h, "<h1>EMCCD report</h1><p class=\"note\">{} · {} frames of {}×{} px · conversion gain {:.4} e⁻/adu · exact register fit · {} iterations per point, seed {}{}</p>",
        esc(&s.tool), s.frames, s.shape[0], s.shape[1], s.gain_e_per_adu, s.iters, s.seed,
        if s.quick { " · <b>quick preview: reduced grid and iterations</b>" } else { "" });
    h.push_str("<h2>Key numbers</h2><div class=\"keys\">");
    let key = |h: &mut String, label: &str, value: String| {
        let _ = write!(h, "<div class=\"key\">{label}<b>{value}</b></div>");
    };
    key(
        &mut h,
        &format!("EM gain ({})", esc(&f.em_gain_units)),
        format!("{:.2} ± {:.2}", f.em_gain, f.em_gain_se),
    );
    key(
        &mut h,
        "Read noise (output e⁻)",
        format!("{:.1} e⁻", s.read_noise_output_e),
    );
    key(
        &mut h,
        "Read noise / EM gain (input e⁻)",
        format!("{:.3} e⁻", s.read_noise_output_e / f.em_gain),
    );
    key(
        &mut h,
        "Mean input electrons per pixel",
        format!("{:.4} ± {:.4}", f.lambda_e, f.lambda_e_se),
    );
    key(&mut h, "Bias", format!("{:.2} adu", f.bias_adu));
    h.push_str("</div><p><b>Against sCMOS</b> (an EMCCD with this gain and read noise against an sCMOS with the paper's pdf, R at the operating sub-aperture and spot):</p><ul>");
    for (sig, v) in verdicts(
        comparison,
        (&ModelSpec::EmccdStochastic, "this EMCCD"),
        (&ModelSpec::ScmosRandom, "the sCMOS"),
    ) {
        let _ = write!(h, "<li>{sig} photons: {}</li>", esc(&v));
    }
    h.push_str("</ul><h2>Charts</h2>");
    let _ = write!(h, "<figure><img src=\"emgain.png\" alt=\"EM-gain fit\"><figcaption>Histogram of all pixel-samples (log counts) with the fitted Poisson-register-Gaussian model and its zero- and one-or-more-electron parts.</figcaption></figure>");
    let _ = write!(h, "<figure><img src=\"r_vs_signal.png\" alt=\"R against signal\"><figcaption>Mean radial centroid error R against signal, {}×{} px, {}: this EMCCD (fitted gain and read noise) against sCMOS models. Lower is better; error bars are one standard error.</figcaption></figure>", s.subap_px, s.subap_px, esc(&s.spot));
    h.push_str("<h2>Files</h2><p class=\"note\">summary.json (the fit with uncertainties and correlations, inputs with SHA-256), r_vs_signal.csv/.svg, emgain.png.</p></body></html>\n");
    h
}

/// The sCMOS report page: key numbers, verdicts, charts and tables.
pub fn index_html(
    s: &ReportSummary,
    fit: &PdfFitReport,
    effective: &[EffectiveRecord],
    comparison: &[Compared],
    heatmaps: &[PathBuf],
    has_ptc: bool,
) -> String {
    let op = &s.operating_point;
    let mut h = page_head();
    let _ = write!(h, "<h1>Read-noise report</h1><p class=\"note\">{} · {} dark frames of {}×{} px · gain {:.4} e⁻/adu ({}) · {} iterations per configuration, seed {}, {} sampling{}</p>",
        esc(&s.tool), s.frames, s.shape[0], s.shape[1], s.gain_e_per_adu, esc(&s.gain_source), s.iters, s.seed, esc(&s.sampling),
        if s.quick { " · <b>quick preview: reduced grid and iterations; run without --quick for full accuracy</b>" } else { "" });
    h.push_str("<h2>Key numbers</h2><div class=\"keys\">");
    let key = |h: &mut String, label: &str, value: String| {
        let _ = write!(h, "<div class=\"key\">{label}<b>{value}</b></div>");
    };
    key(
        &mut h,
        "Median read noise (the data-sheet number)",
        format!("{:.3} e⁻", s.median_rms_e),
    );
    key(&mut h, "Mean read noise", format!("{:.3} e⁻", s.mean_rms_e));
    key(
        &mut h,
        "RMS of the per-pixel noise",
        format!("{:.3} e⁻", s.rms_rms_e),
    );
    key(
        &mut h,
        "Noisy pixels (above 3× median)",
        format!("{:.2} %", 100.0 * s.frac_above_3x_median),
    );
    key(
        &mut h,
        &format!(
            "Effective read noise, {}×{} px, {}, {} photons (measured map)",
            op.subap_px,
            op.subap_px,
            esc(&op.spot),
            op.signal_photons
        ),
        fmt_sigma(op.sigma_eff_map_e, op.sigma_eff_map_se_e),
    );
    key(
        &mut h,
        "Same, from the fitted distribution",
        fmt_sigma(op.sigma_eff_fitted_pdf_e, op.sigma_eff_fitted_pdf_se_e),
    );
    h.push_str("</div>");
    let _ = write!(h, "<p>Use the effective read noise, not the median, as the Gaussian read noise of this camera in an AO simulation of a {}×{} px sub-aperture. The full table below gives it for every sub-aperture size, spot and signal.</p>", op.subap_px, op.subap_px);
    h.push_str("<p><b>Which detector wins</b> (this camera's measured map against an EMCCD, R at the operating sub-aperture and spot):</p><ul>");
    for (sig, v) in verdicts(
        comparison,
        (&ModelSpec::ScmosMap, "this camera"),
        (&ModelSpec::EmccdStochastic, "the EMCCD"),
    ) {
        let _ = write!(h, "<li>{sig} photons: {}</li>", esc(&v));
    }
    h.push_str("</ul><h2>Charts</h2>");
    let fig = |h: &mut String, src: &str, cap: &str| {
        let _ = write!(
            h,
            "<figure><img src=\"{src}\" alt=\"{}\"><figcaption>{cap}</figcaption></figure>",
            esc(cap)
        );
    };
    fig(&mut h, "pdf_fit.png", &format!("Per-pixel read noise (e⁻) of the {} unflagged pixels with the fitted distributions; best by AIC: <b>{}</b>. Inset: log scale, showing the tail of noisy pixels.", s.pixels_used, esc(&s.pdf_best_model)));
    fig(&mut h, "r_vs_signal.png", "Mean radial centroid error R against signal: this camera (random windows of its measured noise map, and its fitted distribution), the one-number models (median, mean) and an EMCCD. Lower is better; error bars are one standard error.");
    for p in heatmaps
        .iter()
        .filter(|p| p.extension().is_some_and(|e| e == "png"))
    {
        let name = p
            .file_name()
            .map(|n| n.to_string_lossy().to_string())
            .unwrap_or_default();
        fig(&mut h, &name, "Effective Gaussian read noise (e⁻) by sub-aperture size and spot, from the fitted distribution, at the signal in the title. A dash: no constant σ reproduces the camera.");
    }
    fig(
        &mut h,
        "rms_hist.png",
        "Histogram of the per-pixel read noise (log counts), all pixels including flagged ones.",
    );
    if has_ptc {
        fig(&mut h, "ptc.png", "Photon transfer: variance against mean signal of the flats (dark-subtracted), with the fit that gives the conversion gain.");
    }
    h.push_str("<h2>Effective read noise</h2><table><tr><th>detector model</th><th>sub-aperture (px)</th><th>spot</th><th>signal (photons)</th><th>σ<sub>eff</sub> (e⁻)</th><th>SE (e⁻)</th><th>R (px)</th><th>status</th></tr>");
    for r in effective {
        let status = serde_json::to_value(r.effective.status)
            .ok()
            .and_then(|v| v.as_str().map(String::from))
            .unwrap_or_default();
        let _ = write!(h, "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{:.3}</td><td>{:.3}</td><td>{:.4}</td><td>{}</td></tr>", esc(&r.model), r.config.subap_px, esc(&r.config.spot.label()), r.config.signal_photons, r.effective.sigma_eff_e, r.effective.sigma_eff_se_e, r.effective.r_px, status);
    }
    h.push_str("</table><h2>Fitted read-noise distributions</h2><table><tr><th>model</th><th>ln L</th><th>ΔAIC</th><th>max CDF distance</th><th>median (e⁻)</th><th>mean (e⁻)</th><th>rms (e⁻)</th><th>&gt;3× median</th></tr>");
    for (name, m) in &fit.models {
        let opt = |v: Option<f64>| v.map(|x| format!("{x:.1}")).unwrap_or_else(|| "–".into());
        let _ = write!(h, "<tr><td>{}</td><td>{}</td><td>{}</td><td>{:.4}</td><td>{:.3}</td><td>{:.3}</td><td>{:.3}</td><td>{:.2} %</td></tr>", esc(name), opt(m.log_likelihood), opt(m.delta_aic), m.max_cdf_distance, m.median_e, m.mean_e, m.rms_e, 100.0 * m.frac_above_3x_median);
    }
    h.push_str("</table><h2>Files</h2><p class=\"note\">Maps (FITS, with BUNIT): offset_adu.fits, rms_adu.fits, rms_e.fits, flags.fits. Tables: effective_noise.csv/.json, r_vs_signal.csv, pdf_fit.json (usable with <code>detnoise effective --pdf</code>), summary.json (every number above with units, inputs with SHA-256), darks_summary.json.</p></body></html>\n");
    h
}

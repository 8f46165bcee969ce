//! The EMCCD figures: the three readout models at two spot sizes (Figs. 3, 4), R against EM
//! gain (Fig. 5) and Poisson-probability thresholding (Fig. 6).

use super::figure::{airy, curves, parse, r_figure, save_line, strings, Ctx, Curve, LineFigure};
use super::options::FigureInfo;
use crate::detector::pp::PpRule;
use crate::detector::{ModelParams, ModelSpec};
use crate::montecarlo::sweep;
use crate::plot::SeriesStyle;
use crate::progress::Silent;
use crate::Result;

/// R against EM gain, 8x8 px, D = 4 px, `signal` photons: one curve per model of `specs`
/// (built with `base` at each gain), each gain a run of its own (the gain changes the models,
/// not the configuration).
fn gain_curves(
    ctx: &Ctx,
    base: &ModelParams,
    gains: &[f64],
    signal: f64,
    specs: &[ModelSpec],
    labels: &[String],
) -> Result<Vec<Curve>> {
    let cfg = ctx.cfg(8, airy(4.0), signal);
    let mut records = Vec::new();
    for &gain in gains {
        let params = ModelParams {
            em_gain: gain,
            ..base.clone()
        };
        records.extend(sweep(std::slice::from_ref(&cfg), specs, &params, &Silent)?);
    }
    Ok(curves(gains, &records, labels))
}

pub(super) fn fig_emccd_models(ctx: &Ctx, number: u32, d: f64) -> Result<FigureInfo> {
    let names = ["emccd-simple", "emccd-stochastic", "emccd-distribution"];
    let specs = parse(&names);
    let mut curves = Vec::new();
    // Colour by sub-aperture, line style by model, as in the paper.
    let styles = [
        crate::plot::SeriesStyle::Line,
        crate::plot::SeriesStyle::LineMarkers,
        crate::plot::SeriesStyle::Markers,
    ];
    for (g, n) in ctx.pick(&[4usize, 8, 16], &[4, 16]).into_iter().enumerate() {
        let labels: Vec<String> = names.iter().map(|m| format!("{m}, {n}x{n}")).collect();
        let signals = ctx.signals();
        let grid = ctx.grid(&[n], &[airy(d)], &signals);
        let group = ctx.curves(&signals, &grid, &specs, &labels)?;
        curves.extend(group.into_iter().zip(styles).map(|(c, st)| Curve {
            look: Some((g, st)),
            ..c
        }));
    }
    save_line(ctx, r_figure(number, if d < 5.0 { "emccd-models-d2" } else { "emccd-models-d10" }, format!("EMCCD readout models, Airy spot D = {d} px"), format!("Mean radial centroid error R against signal for the three EMCCD models (g = 500, 520 stages, 50 e- read noise) and several sub-aperture sizes, spot diameter {d} px."), ("signal (photons per sub-aperture)", "signal_photons"), true, curves))
}

pub(super) fn fig05_gain(ctx: &Ctx) -> Result<FigureInfo> {
    let gains = ctx.pick(
        &[
            2.0, 5.0, 10.0, 20.0, 50.0, 100.0, 200.0, 500.0, 1000.0, 2000.0,
        ],
        &[5.0, 100.0, 1000.0],
    );
    let names = ["emccd-stochastic", "emccd-distribution"];
    let specs = parse(&names);
    let mut curves = Vec::new();
    for s in ctx.pick(&[20.0, 50.0, 200.0, 1000.0], &[20.0, 1000.0]) {
        let labels: Vec<String> = names.iter().map(|m| format!("{m}, S = {s}")).collect();
        curves.extend(gain_curves(ctx, &ctx.params, &gains, s, &specs, &labels)?);
    }
    save_line(ctx, r_figure(5, "r-vs-em-gain", "R against EM gain, 8x8 px, D = 4 px", "Mean radial error against the EMCCD mean gain (read noise 50 e- before division by the gain) at several signal levels (photons per sub-aperture).", ("EM gain (e-/e-)", "em_gain_e_per_e"), true, curves))
}

pub(super) fn fig06_pp(ctx: &Ctx) -> Result<FigureInfo> {
    let gains = ctx.pick(
        &[20.0, 50.0, 100.0, 200.0, 500.0, 1000.0, 2000.0],
        &[50.0, 1000.0],
    );
    let names = ["emccd-stochastic", "emccd-pp", "emccd-pp-uncorrected"];
    let specs = parse(&names);
    // The per-pixel prior runs on the same streams (same seed and configuration), so its R
    // pairs with the same emccd-stochastic R.
    let pixel_prior = ModelParams {
        pp_rule: PpRule::PixelPrior,
        ..ctx.params.clone()
    };
    let mut curves = Vec::new();
    for (si, s) in ctx
        .pick(&[20.0, 50.0, 200.0, 1000.0], &[20.0, 1000.0])
        .into_iter()
        .enumerate()
    {
        let raw = gain_curves(ctx, &ctx.params, &gains, s, &specs, &strings(&names))?;
        let per_pixel = gain_curves(
            ctx,
            &pixel_prior,
            &gains,
            s,
            &specs[1..2],
            &strings(&names[1..2]),
        )?;
        for (label, thresholded, style) in [
            ("corrected", &raw[1], SeriesStyle::LineMarkers),
            ("uncorrected", &raw[2], SeriesStyle::Markers),
            ("pixel prior, corrected", &per_pixel[0], SeriesStyle::Line),
        ] {
            curves.push(Curve {
                name: format!("S = {s}, {label}"),
                points: ratio_points(&raw[0], thresholded),
                look: Some((si, style)),
            });
        }
    }
    save_line(ctx, LineFigure {
        number: 6,
        slug: "pp-thresholding",
        title: "Poisson-probability thresholding: improvement over the analogue EMCCD".into(),
        caption: "Ratio R(emccd-stochastic) / R(thresholded) against EM gain, 8x8 px, D = 4 px, with and without the photometric correction, and with the per-pixel prior (corrected, lines without markers); above 1 is an improvement. The thresholds are a reconstruction of Basden, Haniff & Mackay (2003): boundaries n(n+1)/lambda in units of g for the sub-aperture mean lambda (or, with the per-pixel prior, each pixel's own mean level in the centred noiseless spot, the counts then corrected to the posterior mean E[n | K] under that prior), the 0|1 boundary at equal zero- and one-electron likelihood. Error bars treat the two R as independent (conservative).".into(),
        x_label: "EM gain (e-/e-)".into(),
        y_label: "improvement ratio R(stochastic) / R(PP)".into(),
        columns: ("em_gain_e_per_e", "improvement_ratio", "improvement_ratio_se"),
        log_x: true,
        log_y: false,
        reference: Some((1.0, "no improvement".into())),
        curves,
    })
}

/// R(analogue) / R(thresholded) at each gain, with the SE of a ratio of independent values.
fn ratio_points(analogue: &Curve, thresholded: &Curve) -> Vec<(f64, f64, f64)> {
    analogue
        .points
        .iter()
        .zip(&thresholded.points)
        .map(|(a, b)| {
            let ratio = a.1 / b.1;
            (
                a.0,
                ratio,
                ratio * ((a.2 / a.1).powi(2) + (b.2 / b.1).powi(2)).sqrt(),
            )
        })
        .collect()
}

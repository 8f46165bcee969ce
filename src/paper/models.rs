//! Figures comparing the readout models: all models against signal (Figs. 7, 8), against
//! sub-aperture size (Fig. 9) and spot diameter (Fig. 10), elongated laser-guide-star spots
//! (Fig. 13) and with each camera's QE (Fig. 14).

use super::figure::{airy, parse, r_figure, save_line, strings, Ctx};
use super::options::FigureInfo;
use crate::spot::Spot;
use crate::Result;

/// The full set of models compared in Figs. 7-10.
const ALL_MODELS: [&str; 8] = [
    "emccd-simple",
    "emccd-stochastic",
    "emccd-distribution",
    "emccd-pp",
    "scmos-median",
    "scmos-mean",
    "scmos-fixed:0",
    "scmos-random",
];

pub(super) fn fig_all_models(ctx: &Ctx, number: u32, n: usize) -> Result<FigureInfo> {
    let specs = parse(&ALL_MODELS);
    let signals = ctx.signals();
    let grid = ctx.grid(&[n], &[airy(2.0)], &signals);
    let curves = ctx.curves(&signals, &grid, &specs, &strings(&ALL_MODELS))?;
    save_line(ctx, r_figure(number, if n == 16 { "all-models-16x16" } else { "all-models-4x4" }, format!("All readout models, {n}x{n} px, D = 2 px"), format!("Mean radial error against signal for every readout model, {n}x{n} px sub-aperture, Airy spot D = 2 px."), ("signal (photons per sub-aperture)", "signal_photons"), true, curves))
}

pub(super) fn fig09_subap(ctx: &Ctx) -> Result<FigureInfo> {
    let names = [
        "emccd-simple",
        "emccd-stochastic",
        "scmos-median",
        "scmos-mean",
        "scmos-random",
    ];
    let specs = parse(&names);
    let sizes = ctx.pick(&[4.0, 6.0, 8.0, 10.0, 12.0, 14.0, 16.0], &[4.0, 16.0]);
    let subaps: Vec<usize> = sizes.iter().map(|&n| n as usize).collect();
    let grid = ctx.grid(&subaps, &[airy(2.0)], &[50.0]);
    let curves = ctx.curves(&sizes, &grid, &specs, &strings(&names))?;
    save_line(ctx, r_figure(9, "r-vs-subaperture", "R against sub-aperture size, S = 50 photons, D = 2 px", "Mean radial error against the linear sub-aperture size (pixels per side) for EMCCD and sCMOS models at 50 photons per sub-aperture.", ("sub-aperture size (px per side)", "subap_px"), false, curves))
}

pub(super) fn fig10_diameter(ctx: &Ctx) -> Result<FigureInfo> {
    let names = [
        "emccd-stochastic",
        "scmos-median",
        "scmos-mean",
        "scmos-random",
    ];
    let specs = parse(&names);
    let ds = ctx.pick(&[1.0, 2.0, 4.0, 6.0, 8.0, 10.0], &[2.0, 8.0]);
    let mut curves = Vec::new();
    for n in [4usize, 16] {
        let labels: Vec<String> = names.iter().map(|m| format!("{m}, {n}x{n}")).collect();
        let spots: Vec<Spot> = ds.iter().map(|&d| airy(d)).collect();
        let grid = ctx.grid(&[n], &spots, &[50.0]);
        curves.extend(ctx.curves(&ds, &grid, &specs, &labels)?);
    }
    save_line(ctx, r_figure(10, "r-vs-spot-diameter", "R against spot diameter, S = 50 photons", "Mean radial error against the Airy first-minimum diameter for 4x4 and 16x16 px sub-apertures at 50 photons.", ("spot diameter, first Airy minimum (px)", "spot_diameter_px"), false, curves))
}

pub(super) fn fig13_lgs(ctx: &Ctx) -> Result<FigureInfo> {
    let names = [
        "emccd-stochastic",
        "scmos-median",
        "scmos-mean",
        "scmos-random",
        "scmos-fixed:0",
    ];
    let specs = parse(&names);
    let elong = ctx.pick(&[1.0, 1.5, 2.0, 3.0, 4.0, 5.0], &[1.0, 3.0]);
    let gauss = |sy: f64| Spot::Gauss {
        sigma_x_px: 1.0,
        sigma_y_px: sy,
    };
    let spots: Vec<Spot> = elong.iter().map(|&sy| gauss(sy)).collect();
    let grid = ctx.grid(&[16], &spots, &[50.0]);
    let curves = ctx.curves(&elong, &grid, &specs, &strings(&names))?;
    save_line(ctx, r_figure(13, "lgs-elongation", "Laser guide star elongation, 16x16 px, S = 50 photons", "Mean radial error against the standard deviation of the elongated axis of a 2-D Gaussian spot (the other axis 1 px, comparable with an Airy spot of D = 6 px).", ("elongated-axis standard deviation (px)", "sigma_y_px"), false, curves))
}

pub(super) fn fig14_qe(ctx: &Ctx) -> Result<FigureInfo> {
    let groups: [(&[&str], f64); 2] = [
        (
            &["emccd-simple", "emccd-stochastic", "emccd-distribution"],
            0.95,
        ),
        (&["scmos-median", "scmos-mean", "scmos-random"], 0.70),
    ];
    let mut curves = Vec::new();
    for (names, qe) in groups {
        let specs = parse(names);
        let labels: Vec<String> = names.iter().map(|m| format!("{m}, QE {qe}")).collect();
        let signals = ctx.signals();
        let mut grid = ctx.grid(&[4], &[airy(2.0)], &signals);
        grid.shared.qe = qe;
        curves.extend(ctx.curves(&signals, &grid, &specs, &labels)?);
    }
    save_line(ctx, r_figure(14, "qe-scaling-4x4", "QE included: EMCCD 95 %, sCMOS 70 %, 4x4 px", "Mean radial error against incident signal for a 4x4 px sub-aperture, D = 2 px, with QE 0.95 for the EMCCD models and 0.70 for the sCMOS models.", ("incident signal (photons per sub-aperture)", "signal_photons"), true, curves))
}

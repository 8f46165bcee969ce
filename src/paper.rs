//! Every figure of Basden (2015), regenerated: data (CSV), PNG and SVG, and an index page.
//!
//! The figures use `point` sampling (spot evaluated at pixel centres) as the paper most likely
//! did (the Durham platform's `createAiryDisc`); `integrated` redraws them the other way.

use crate::detector::{ModelParams, ModelSpec, Readout};
use crate::effective::effective_sigma;
use crate::montecarlo::{run, SimConfig};
use crate::output::write_atomic;
use crate::pdf::paper_shape;
use crate::plot::{Heatmap, HistNorm, Histogram, Image, ImageGrid, Inset, LineChart, Series};
use crate::spot::{Sampling, Spot};
use crate::Result;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Signal levels of the paper's figures (photons per sub-aperture).
const SIGNALS: [f64; 6] = [20.0, 50.0, 100.0, 200.0, 500.0, 1000.0];

/// Options of a figure run.
#[derive(Debug, Clone)]
pub struct PaperOptions {
    /// Monte-Carlo iterations per configuration.
    pub iters: u64,
    /// Seed.
    pub seed: u64,
    /// Spot sampling.
    pub sampling: Sampling,
    /// Coarser grids for a fast smoke run (same files, fewer points).
    pub quick: bool,
}

/// One produced figure.
#[derive(Debug, Clone, serde::Serialize)]
pub struct FigureInfo {
    /// Figure number in the paper.
    pub number: u32,
    /// Title.
    pub title: String,
    /// Caption, with the settings used.
    pub caption: String,
    /// Files written (relative to the output directory).
    pub files: Vec<String>,
}

/// A curve of R against x with standard errors, optionally with a fixed colour and style.
#[derive(Debug, Clone)]
struct Curve {
    name: String,
    points: Vec<(f64, f64, f64)>,
    look: Option<(usize, crate::plot::SeriesStyle)>,
}

/// A line figure ready to draw.
struct LineFigure {
    number: u32,
    slug: &'static str,
    title: String,
    caption: String,
    x_label: String,
    y_label: String,
    /// CSV column names of x, y and y's standard error, with their units.
    columns: (&'static str, &'static str, &'static str),
    log_x: bool,
    log_y: bool,
    reference: Option<(f64, String)>,
    curves: Vec<Curve>,
}

/// Figure context: options, output directory, the paper's pdf and model parameters.
struct Ctx<'a> {
    opts: &'a PaperOptions,
    dir: &'a Path,
    params: ModelParams,
}

impl Ctx<'_> {
    fn cfg(&self, subap_px: usize, spot: Spot, signal: f64) -> SimConfig {
        SimConfig {
            spot,
            sampling: self.opts.sampling,
            signal_photons: signal,
            iters: self.opts.iters,
            seed: self.opts.seed,
            ..SimConfig::paper(subap_px)
        }
    }

    fn pick<T: Copy>(&self, full: &[T], quick: &[T]) -> Vec<T> {
        if self.opts.quick {
            quick.to_vec()
        } else {
            full.to_vec()
        }
    }

    fn signals(&self) -> Vec<f64> {
        self.pick(&SIGNALS, &[20.0, 200.0, 1000.0])
    }

    fn sampling_note(&self) -> String {
        format!(
            "{} sampling of the spot, {} iterations per point, seed {}; error bars are one standard error.",
            match self.opts.sampling {
                Sampling::Point => "Point (pixel-centre)",
                Sampling::Integrated => "Pixel-integrated",
            },
            self.opts.iters,
            self.opts.seed
        )
    }
}

/// For each x, run `models(x)` on `cfg(x)` together (common random numbers) and collect one
/// curve per model, named by `names`.
fn sweep(
    xs: &[f64],
    cfg: impl Fn(f64) -> SimConfig,
    models: impl Fn(&SimConfig, f64) -> Result<Vec<Box<dyn Readout>>>,
    names: &[String],
) -> Result<Vec<Curve>> {
    let mut curves: Vec<Curve> = names
        .iter()
        .map(|n| Curve {
            name: n.clone(),
            points: Vec::new(),
            look: None,
        })
        .collect();
    for &x in xs {
        let c = cfg(x);
        let built = models(&c, x)?;
        let refs: Vec<&dyn Readout> = built.iter().map(|m| m.as_ref()).collect();
        for (curve, r) in curves.iter_mut().zip(run(&c, &refs, &|_| {})?) {
            curve.points.push((x, r.r_px, r.r_se_px));
        }
    }
    Ok(curves)
}

/// Build `specs` with `params` for the configuration's sub-aperture.
fn build(specs: &[ModelSpec], params: &ModelParams, n: usize) -> Result<Vec<Box<dyn Readout>>> {
    specs.iter().map(|s| s.build(params, n)).collect()
}

fn parse(names: &[&str]) -> Vec<ModelSpec> {
    names
        .iter()
        .map(|n| ModelSpec::parse(n).expect("known model"))
        .collect()
}

fn strings(names: &[&str]) -> Vec<String> {
    names.iter().map(|s| s.to_string()).collect()
}

fn airy(d: f64) -> Spot {
    Spot::Airy { diameter_px: d }
}

/// Regenerate every figure into `dir` (which must exist); returns what was written.
pub fn generate(
    opts: &PaperOptions,
    dir: &Path,
    on_figure: &dyn Fn(&str),
) -> Result<Vec<FigureInfo>> {
    let ctx = Ctx {
        opts,
        dir,
        params: ModelParams::default(),
    };
    type FigFn = fn(&Ctx) -> Result<FigureInfo>;
    let figures: [(&str, FigFn); 14] = [
        ("Fig. 1 rms pdf", fig01_pdf),
        ("Fig. 2 noise patterns", fig02_patterns),
        ("Fig. 3 EMCCD models, D = 2", |c| {
            fig_emccd_models(c, 3, 2.0)
        }),
        ("Fig. 4 EMCCD models, D = 10", |c| {
            fig_emccd_models(c, 4, 10.0)
        }),
        ("Fig. 5 R vs EM gain", fig05_gain),
        ("Fig. 6 thresholding", fig06_pp),
        ("Fig. 7 all models 16x16", |c| fig_all_models(c, 7, 16)),
        ("Fig. 8 all models 4x4", |c| fig_all_models(c, 8, 4)),
        ("Fig. 9 R vs sub-aperture", fig09_subap),
        ("Fig. 10 R vs spot diameter", fig10_diameter),
        ("Fig. 11 constant sigmas", fig11_constants),
        ("Fig. 12 effective read noise", fig12_effective),
        ("Fig. 13 LGS elongation", fig13_lgs),
        ("Fig. 14 QE scaling", fig14_qe),
    ];
    let mut out = Vec::new();
    for (label, f) in figures {
        on_figure(label);
        out.push(f(&ctx)?);
    }
    Ok(out)
}

/// A figure of R (px, log scale) against `x_label`.
fn r_figure(
    number: u32,
    slug: &'static str,
    title: impl Into<String>,
    caption: impl Into<String>,
    (x_label, x_col): (&str, &'static str),
    log_x: bool,
    curves: Vec<Curve>,
) -> LineFigure {
    LineFigure {
        number,
        slug,
        title: title.into(),
        caption: caption.into(),
        x_label: x_label.into(),
        y_label: "R, mean radial error (px)".into(),
        columns: (x_col, "r_px", "r_se_px"),
        log_x,
        log_y: true,
        reference: None,
        curves,
    }
}

/// Draw a line figure (PNG, SVG) and write its CSV.
fn save_line(ctx: &Ctx, fig: LineFigure) -> Result<FigureInfo> {
    let stem = format!("fig{:02}-{}", fig.number, fig.slug);
    let mut chart = LineChart::new(fig.title.clone(), fig.x_label.clone(), fig.y_label.clone());
    chart.log_x = fig.log_x;
    chart.log_y = fig.log_y;
    chart.series = fig
        .curves
        .iter()
        .map(|c| {
            let s = Series::with_errors(c.name.clone(), c.points.iter().copied());
            match c.look {
                Some((colour, style)) => s.coloured(colour).styled(style),
                None => s,
            }
        })
        .collect();
    if let Some((y, label)) = &fig.reference {
        chart.reference.push(crate::plot::RefLine {
            y: *y,
            label: label.clone(),
        });
    }
    let (x_col, y_col, se_col) = fig.columns;
    let mut csv = format!("series,{x_col},{y_col},{se_col}\n");
    for c in &fig.curves {
        for (x, y, se) in &c.points {
            let _ = writeln!(csv, "\"{}\",{x},{y},{se}", c.name);
        }
    }
    write_atomic(&ctx.dir.join(format!("{stem}.csv")), csv.as_bytes())?;
    chart.save(ctx.dir.join(format!("{stem}.png")))?;
    chart.save(ctx.dir.join(format!("{stem}.svg")))?;
    Ok(FigureInfo {
        number: fig.number,
        title: fig.title,
        caption: format!("{} {}", fig.caption, ctx.sampling_note()),
        files: ["png", "svg", "csv"]
            .iter()
            .map(|e| format!("{stem}.{e}"))
            .collect(),
    })
}

fn fig01_pdf(ctx: &Ctx) -> Result<FigureInfo> {
    let pdf = ctx.params.pdf.clone();
    let mut rng = crate::rng::stream(ctx.opts.seed, 1, 0xf1);
    let n = if ctx.opts.quick { 20_000 } else { 200_000 };
    let samples: Vec<f64> = (0..n).map(|_| pdf.sample(&mut rng)).collect();
    let tab = crate::pdf::paper();
    let curve: Vec<(f64, f64)> = (0..=2000)
        .map(|k| {
            let x = k as f64 * 0.005;
            (x, tab.density(x))
        })
        .collect();
    let mut h = Histogram::new(
        "Per-pixel rms read noise of an sCMOS camera (paper Eq. 3 on [0, 10] e-)",
        "rms read noise (e-)",
        "probability density (1/e-)",
        samples,
    );
    h.sample_label = format!("{n} pixels drawn from the pdf");
    h.norm = HistNorm::Density;
    // The whole support, so that the log inset shows the 1/x^2 tail up to the 10 e- cut.
    h.range = Some((0.0, 10.0));
    h.bins = crate::plot::Bins::Count(500);
    h.curves = vec![Series::new("paper pdf, Eq. 3", curve.iter().copied())
        .styled(crate::plot::SeriesStyle::Line)];
    h.inset = Some(Inset {
        title: "log scale, 0-10 e-".into(),
        x_range: Some((0.0, 10.0)),
    });
    let stem = "fig01-rms-pdf";
    h.save(ctx.dir.join(format!("{stem}.png")))?;
    h.save(ctx.dir.join(format!("{stem}.svg")))?;
    let mut csv = String::from("rms_e,pdf_per_e,paper_shape_unnormalised\n");
    for (x, f) in &curve {
        let _ = writeln!(csv, "{x},{f},{}", paper_shape(*x));
    }
    write_atomic(&ctx.dir.join(format!("{stem}.csv")), csv.as_bytes())?;
    Ok(FigureInfo {
        number: 1,
        title: "Distribution of per-pixel rms read noise".into(),
        caption: format!(
            "The paper's pdf (Eq. 3) truncated to [0, 10] e-: median {:.4} e-, mean {:.4} e-, rms {:.4} e-, {:.2} % of pixels above 3x the median. Histogram of {n} sampled pixels with the pdf; inset on a log scale shows the 1/x^2 tail.",
            pdf.median(),
            pdf.mean(),
            pdf.rms(),
            100.0 * pdf.frac_above_median_times(3.0)
        ),
        files: ["png", "svg", "csv"].iter().map(|e| format!("{stem}.{e}")).collect(),
    })
}

fn fig02_patterns(ctx: &Ctx) -> Result<FigureInfo> {
    let stem = "fig02-noise-patterns";
    let mut csv = String::from("pattern,row,col,rms_e\n");
    let mut images = Vec::new();
    for k in 0..10u32 {
        let p = crate::detector::PerPixelSigma::fixed_pattern(
            ctx.params.pdf.as_ref(),
            16,
            ctx.params.pattern_seed,
            k,
        );
        let s = p.sigma_e();
        for (i, v) in s.iter().enumerate() {
            let _ = writeln!(csv, "{k},{},{},{v}", i / 16, i % 16);
        }
        let max = s.iter().cloned().fold(0.0, f64::max);
        let mean = s.iter().sum::<f64>() / s.len() as f64;
        images.push(Image {
            title: format!("#{k}: max {max:.1}, mean {mean:.2}"),
            width: 16,
            height: 16,
            data: s.to_vec(),
        });
    }
    let mut grid = ImageGrid::new(
        "Ten fixed sCMOS noise patterns, 16x16 px, drawn from the rms pdf",
        images,
        "rms read noise (e-)",
    );
    grid.columns = 5;
    grid.save(ctx.dir.join(format!("{stem}.png")))?;
    grid.save(ctx.dir.join(format!("{stem}.svg")))?;
    write_atomic(&ctx.dir.join(format!("{stem}.csv")), csv.as_bytes())?;
    Ok(FigureInfo {
        number: 2,
        title: "Fixed noise patterns".into(),
        caption: format!("Per-pixel rms read noise (e-) of the ten seeded patterns #0-#9 (models scmos-fixed:0..9, --pattern-seed {}); panel titles give each pattern's worst pixel and mean.", ctx.params.pattern_seed),
        files: ["png", "svg", "csv"].iter().map(|e| format!("{stem}.{e}")).collect(),
    })
}

fn fig_emccd_models(ctx: &Ctx, number: u32, d: f64) -> Result<FigureInfo> {
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
        let group = sweep(
            &ctx.signals(),
            |s| ctx.cfg(n, airy(d), s),
            |c, _| build(&specs, &ctx.params, c.subap_px),
            &labels,
        )?;
        curves.extend(group.into_iter().zip(styles).map(|(c, st)| Curve {
            look: Some((g, st)),
            ..c
        }));
    }
    save_line(ctx, r_figure(number, if d < 5.0 { "emccd-models-d2" } else { "emccd-models-d10" }, format!("EMCCD readout models, Airy spot D = {d} px"), format!("Mean radial centroid error R against signal for the three EMCCD models (g = 500, 520 stages, 50 e- read noise) and several sub-aperture sizes, spot diameter {d} px."), ("signal (photons per sub-aperture)", "signal_photons"), true, curves))
}

fn fig05_gain(ctx: &Ctx) -> Result<FigureInfo> {
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
        curves.extend(sweep(
            &gains,
            |_| ctx.cfg(8, airy(4.0), s),
            |c, g| {
                let params = ModelParams {
                    gain: g,
                    ..ctx.params.clone()
                };
                build(&specs, &params, c.subap_px)
            },
            &labels,
        )?);
    }
    save_line(ctx, r_figure(5, "r-vs-em-gain", "R against EM gain, 8x8 px, D = 4 px", "Mean radial error against the EMCCD mean gain (read noise 50 e- before division by the gain) at several signal levels (photons per sub-aperture).", ("EM gain (e-/e-)", "em_gain_e_per_e"), true, curves))
}

fn fig06_pp(ctx: &Ctx) -> Result<FigureInfo> {
    let gains = ctx.pick(
        &[20.0, 50.0, 100.0, 200.0, 500.0, 1000.0, 2000.0],
        &[50.0, 1000.0],
    );
    let names = ["emccd-stochastic", "emccd-pp", "emccd-pp-uncorrected"];
    let specs = parse(&names);
    let mut curves = Vec::new();
    for (si, s) in ctx
        .pick(&[20.0, 50.0, 200.0, 1000.0], &[20.0, 1000.0])
        .into_iter()
        .enumerate()
    {
        let raw = sweep(
            &gains,
            |_| ctx.cfg(8, airy(4.0), s),
            |c, g| {
                let params = ModelParams {
                    gain: g,
                    ..ctx.params.clone()
                };
                build(&specs, &params, c.subap_px)
            },
            &strings(&names),
        )?;
        for (label, k, style) in [
            ("corrected", 1, crate::plot::SeriesStyle::LineMarkers),
            ("uncorrected", 2, crate::plot::SeriesStyle::Markers),
        ] {
            let points = raw[0]
                .points
                .iter()
                .zip(&raw[k].points)
                .map(|(a, b)| {
                    let ratio = a.1 / b.1;
                    (
                        a.0,
                        ratio,
                        ratio * ((a.2 / a.1).powi(2) + (b.2 / b.1).powi(2)).sqrt(),
                    )
                })
                .collect();
            curves.push(Curve {
                name: format!("S = {s}, {label}"),
                points,
                look: Some((si, style)),
            });
        }
    }
    save_line(ctx, LineFigure {
        number: 6,
        slug: "pp-thresholding",
        title: "Poisson-probability thresholding: improvement over the analogue EMCCD".into(),
        caption: "Ratio R(emccd-stochastic) / R(thresholded) against EM gain, 8x8 px, D = 4 px, with and without the photometric correction; above 1 is an improvement. The thresholds are a reconstruction of Basden, Haniff & Mackay (2003): boundaries n(n+1)/lambda in units of g for the sub-aperture mean lambda, the 0|1 boundary at equal zero- and one-electron likelihood. Error bars treat the two R as independent (conservative).".into(),
        x_label: "EM gain (e-/e-)".into(),
        y_label: "improvement ratio R(stochastic) / R(PP)".into(),
        columns: ("em_gain_e_per_e", "improvement_ratio", "improvement_ratio_se"),
        log_x: true,
        log_y: false,
        reference: Some((1.0, "no improvement".into())),
        curves,
    })
}

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

fn fig_all_models(ctx: &Ctx, number: u32, n: usize) -> Result<FigureInfo> {
    let specs = parse(&ALL_MODELS);
    let curves = sweep(
        &ctx.signals(),
        |s| ctx.cfg(n, airy(2.0), s),
        |c, _| build(&specs, &ctx.params, c.subap_px),
        &strings(&ALL_MODELS),
    )?;
    save_line(ctx, r_figure(number, if n == 16 { "all-models-16x16" } else { "all-models-4x4" }, format!("All readout models, {n}x{n} px, D = 2 px"), format!("Mean radial error against signal for every readout model, {n}x{n} px sub-aperture, Airy spot D = 2 px."), ("signal (photons per sub-aperture)", "signal_photons"), true, curves))
}

fn fig09_subap(ctx: &Ctx) -> Result<FigureInfo> {
    let names = [
        "emccd-simple",
        "emccd-stochastic",
        "scmos-median",
        "scmos-mean",
        "scmos-random",
    ];
    let specs = parse(&names);
    let sizes = ctx.pick(&[4.0, 6.0, 8.0, 10.0, 12.0, 14.0, 16.0], &[4.0, 16.0]);
    let curves = sweep(
        &sizes,
        |n| ctx.cfg(n as usize, airy(2.0), 50.0),
        |c, _| build(&specs, &ctx.params, c.subap_px),
        &strings(&names),
    )?;
    save_line(ctx, r_figure(9, "r-vs-subaperture", "R against sub-aperture size, S = 50 photons, D = 2 px", "Mean radial error against the linear sub-aperture size (pixels per side) for EMCCD and sCMOS models at 50 photons per sub-aperture.", ("sub-aperture size (px per side)", "subap_px"), false, curves))
}

fn fig10_diameter(ctx: &Ctx) -> Result<FigureInfo> {
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
        curves.extend(sweep(
            &ds,
            |d| ctx.cfg(n, airy(d), 50.0),
            |c, _| build(&specs, &ctx.params, c.subap_px),
            &labels,
        )?);
    }
    save_line(ctx, r_figure(10, "r-vs-spot-diameter", "R against spot diameter, S = 50 photons", "Mean radial error against the Airy first-minimum diameter for 4x4 and 16x16 px sub-apertures at 50 photons.", ("spot diameter, first Airy minimum (px)", "spot_diameter_px"), false, curves))
}

fn fig11_constants(ctx: &Ctx) -> Result<FigureInfo> {
    use crate::plot::SeriesStyle;
    let sigmas = ctx.pick(&[0.5, 0.8, 1.0, 1.5, 2.0, 3.0, 4.0], &[0.8, 2.0]);
    let patterns = if ctx.opts.quick { 2 } else { 10 };
    let mut names: Vec<String> = vec!["scmos-random".into()];
    names.extend((0..patterns).map(|k| format!("scmos-fixed:{k}")));
    names.extend(sigmas.iter().map(|s| format!("scmos-constant:{s}")));
    let specs: Vec<ModelSpec> = names
        .iter()
        .map(|n| ModelSpec::parse(n).expect("known"))
        .collect();
    let labels: Vec<String> = std::iter::once("random (expected detector)".to_string())
        .chain((0..patterns).map(|k| format!("fixed pattern #{k}")))
        .chain(sigmas.iter().map(|s| format!("constant {s} e-")))
        .collect();
    // The paper's panels: left 4x4, right 16x16; random solid, fixed patterns as markers, constants as lines.
    let mut info: Option<FigureInfo> = None;
    for (n, slug) in [
        (4usize, "constant-sigmas-4x4"),
        (16, "constant-sigmas-16x16"),
    ] {
        let curves = sweep(
            &ctx.signals(),
            |s| ctx.cfg(n, airy(2.0), s),
            |c, _| build(&specs, &ctx.params, c.subap_px),
            &labels,
        )?;
        let styled = curves
            .into_iter()
            .enumerate()
            .map(|(k, c)| {
                let look = match k {
                    0 => (0, SeriesStyle::LineMarkers),
                    k if k <= patterns => (7, SeriesStyle::Markers),
                    k => (k - patterns, SeriesStyle::Line),
                };
                Curve {
                    look: Some(look),
                    ..c
                }
            })
            .collect();
        let part = save_line(ctx, r_figure(
            11,
            slug,
            format!("sCMOS noise models, {n}x{n} px, D = 2 px"),
            "Mean radial error against signal, 4x4 and 16x16 px (one panel each), D = 2 px: constant sigmas (e-), the ten fixed patterns (the spread of real detectors) and the random model (the expected detector).",
            ("signal (photons per sub-aperture)", "signal_photons"),
            true,
            styled,
        ))?;
        info = Some(match info {
            None => part,
            Some(mut first) => {
                first.files.extend(part.files);
                first
            }
        });
    }
    Ok(info.expect("two panels"))
}

fn fig12_effective(ctx: &Ctx) -> Result<FigureInfo> {
    let sizes = ctx.pick(&[4usize, 6, 8, 10, 12, 14, 16], &[4, 8]);
    let ds = ctx.pick(&[1.0, 2.0, 4.0, 6.0, 8.0, 10.0], &[2.0, 6.0]);
    let signals = SIGNALS;
    let model = ModelSpec::ScmosRandom;
    let mut csv = String::from(
        "subap_px,spot_diameter_px,signal_photons,sigma_eff_e,sigma_eff_se_e,r_px,r_se_px\n",
    );
    let mut files = vec!["fig12-effective-read-noise.csv".to_string()];
    for s in signals {
        let mut values = vec![vec![0.0; sizes.len()]; ds.len()];
        for (i, &n) in sizes.iter().enumerate() {
            let det = model.build(&ctx.params, n)?;
            for (j, &d) in ds.iter().enumerate() {
                let e = effective_sigma(&ctx.cfg(n, airy(d), s), det.as_ref(), &|_| {})?;
                values[j][i] = e.sigma_eff_e;
                let _ = writeln!(
                    csv,
                    "{n},{d},{s},{},{},{},{}",
                    e.sigma_eff_e, e.sigma_eff_se_e, e.r_px, e.r_se_px
                );
            }
        }
        let stem = format!("fig12-effective-read-noise-S{s}");
        let mut h = Heatmap::new(
            format!("Effective sCMOS read noise (e-), S = {s} photons"),
            "sub-aperture size (px per side)",
            "spot diameter, first Airy minimum (px)",
            sizes.iter().map(|n| n.to_string()).collect(),
            ds.iter().map(|d| d.to_string()).collect(),
            values,
            "effective rms read noise (e-)",
        );
        h.decimals = 2;
        // A few large values (wide spots in large sub-apertures) would flatten the scale; the
        // printed numbers stay exact.
        h.range = Some((0.0, 6.0));
        h.save(ctx.dir.join(format!("{stem}.png")))?;
        h.save(ctx.dir.join(format!("{stem}.svg")))?;
        files.push(format!("{stem}.png"));
        files.push(format!("{stem}.svg"));
    }
    write_atomic(
        &ctx.dir.join("fig12-effective-read-noise.csv"),
        csv.as_bytes(),
    )?;
    Ok(FigureInfo {
        number: 12,
        title: "Effective Gaussian read noise of an sCMOS camera".into(),
        caption: format!("The constant sigma (e-) whose R equals that of scmos-random with the paper's pdf, by sub-aperture size and spot diameter, one panel per signal level; the pdf's median is {:.3} e-. Colours saturate at 6 e-; a dash marks a configuration where no constant sigma reaches the detector's R: a few very noisy pixels pull the centroid further than any uniform Gaussian noise does. {}", ctx.params.pdf.median(), ctx.sampling_note()),
        files,
    })
}

fn fig13_lgs(ctx: &Ctx) -> Result<FigureInfo> {
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
    let curves = sweep(
        &elong,
        |sy| ctx.cfg(16, gauss(sy), 50.0),
        |c, _| build(&specs, &ctx.params, c.subap_px),
        &strings(&names),
    )?;
    save_line(ctx, r_figure(13, "lgs-elongation", "Laser guide star elongation, 16x16 px, S = 50 photons", "Mean radial error against the standard deviation of the elongated axis of a 2-D Gaussian spot (the other axis 1 px, comparable with an Airy spot of D = 6 px).", ("elongated-axis standard deviation (px)", "sigma_y_px"), false, curves))
}

fn fig14_qe(ctx: &Ctx) -> Result<FigureInfo> {
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
        curves.extend(sweep(
            &ctx.signals(),
            |s| SimConfig {
                qe,
                ..ctx.cfg(4, airy(2.0), s)
            },
            |c, _| build(&specs, &ctx.params, c.subap_px),
            &labels,
        )?);
    }
    save_line(ctx, r_figure(14, "qe-scaling-4x4", "QE included: EMCCD 95 %, sCMOS 70 %, 4x4 px", "Mean radial error against incident signal for a 4x4 px sub-aperture, D = 2 px, with QE 0.95 for the EMCCD models and 0.70 for the sCMOS models.", ("incident signal (photons per sub-aperture)", "signal_photons"), true, curves))
}

/// Write `index.html` and `README.md` listing every figure with its caption.
pub fn write_index(
    dir: &Path,
    figures: &[FigureInfo],
    opts: &PaperOptions,
) -> Result<Vec<PathBuf>> {
    let esc = crate::output::html_escape;
    let mut html = String::from("<!DOCTYPE html><html><head><meta charset=\"utf-8\"><title>detnoise: figures of Basden (2015)</title><style>body{font-family:sans-serif;max-width:1100px;margin:2em auto;padding:0 1em;color:#222}figure{margin:2em 0;border-top:1px solid #ccc;padding-top:1em}img{max-width:100%}figcaption{margin-top:.5em;line-height:1.4}</style></head><body>");
    let _ = write!(html, "<h1>Figures of Basden (2015), regenerated by detnoise {}</h1><p>{} iterations per point, seed {}, {} sampling{}. Each figure links its SVG and CSV.</p>", env!("CARGO_PKG_VERSION"), opts.iters, opts.seed, if opts.sampling == Sampling::Point { "point" } else { "integrated" }, if opts.quick { " (quick mode: coarse grids)" } else { "" });
    let mut md = format!("# Figures of Basden (2015), regenerated by detnoise\n\n{} iterations per point, seed {}.\n\n", opts.iters, opts.seed);
    for f in figures {
        let _ = write!(
            html,
            "<figure id=\"fig{}\"><h2>Fig. {}: {}</h2>",
            f.number,
            f.number,
            esc(&f.title)
        );
        for png in f.files.iter().filter(|p| p.ends_with(".png")) {
            let _ = write!(html, "<img src=\"{png}\" alt=\"{}\">", esc(&f.title));
        }
        let links: Vec<String> = f
            .files
            .iter()
            .filter(|p| !p.ends_with(".png"))
            .map(|p| format!("<a href=\"{p}\">{p}</a>"))
            .collect();
        let _ = write!(
            html,
            "<figcaption>{} <br>{}</figcaption></figure>",
            esc(&f.caption),
            links.join(" · ")
        );
        let _ = writeln!(md, "## Fig. {}: {}\n\n{}\n", f.number, f.title, f.caption);
        for p in &f.files {
            if p.ends_with(".png") {
                let _ = writeln!(md, "![{}]({p})", f.title);
            }
        }
        md.push('\n');
    }
    html.push_str("</body></html>\n");
    let (h, m) = (dir.join("index.html"), dir.join("README.md"));
    write_atomic(&h, html.as_bytes())?;
    write_atomic(&m, md.as_bytes())?;
    Ok(vec![h, m])
}

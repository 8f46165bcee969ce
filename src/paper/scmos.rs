//! The sCMOS noise figures: the rms pdf (Fig. 1), fixed noise patterns (Fig. 2), constant
//! sigmas against the per-pixel models (Fig. 11) and the effective read noise (Fig. 12).

use super::figure::{airy, r_figure, save_line, Ctx, Curve, SIGNALS};
use super::options::FigureInfo;
use crate::charts::heatmaps::{save_heatmaps, NoiseScale};
use crate::detector::ModelSpec;
use crate::effective::{effective_table, Precision};
use crate::output::write_atomic;
use crate::pdf::paper_shape;
use crate::plot::{HistNorm, Histogram, Image, ImageGrid, Inset, Series};
use crate::progress::Silent;
use crate::spot::Spot;
use crate::Result;
use std::fmt::Write as _;

pub(super) fn fig01_pdf(ctx: &Ctx) -> Result<FigureInfo> {
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

pub(super) fn fig02_patterns(ctx: &Ctx) -> Result<FigureInfo> {
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

pub(super) fn fig11_constants(ctx: &Ctx) -> Result<FigureInfo> {
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
        let signals = ctx.signals();
        let grid = ctx.grid(&[n], &[airy(2.0)], &signals);
        let curves = ctx.curves(&signals, &grid, &specs, &labels)?;
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

pub(super) fn fig12_effective(ctx: &Ctx) -> Result<FigureInfo> {
    let sizes = ctx.pick(&[4usize, 6, 8, 10, 12, 14, 16], &[4, 8]);
    let ds = ctx.pick(&[1.0, 2.0, 4.0, 6.0, 8.0, 10.0], &[2.0, 6.0]);
    let model = ModelSpec::ScmosRandom;
    let stem = "fig12-effective-read-noise";
    let mut csv = String::from(
        "subap_px,spot_diameter_px,signal_photons,iters,sigma_eff_e,sigma_eff_se_e,r_px,r_se_px,status\n",
    );
    let spots: Vec<Spot> = ds.iter().map(|&d| airy(d)).collect();
    // The default precision target, starting at this run's iterations; a quick run caps
    // them like the report's preview.
    let cap = if ctx.opts.quick {
        Precision::QUICK_MAX_ITERS
    } else {
        Precision::DEFAULT_MAX_ITERS
    };
    let precision = Precision {
        max_iters: cap.max(ctx.opts.iters),
        ..Precision::default()
    };
    let mut records = Vec::new();
    for s in SIGNALS {
        // Sub-aperture-major, then spot: record i * ds.len() + j is size i, diameter j.
        let configs = ctx.grid(&sizes, &spots, &[s]).configs()?;
        let table = effective_table(
            &configs,
            std::slice::from_ref(&model),
            &ctx.params,
            &precision,
            &Silent,
        )?;
        for (k, rec) in table.iter().enumerate() {
            let (n, d, e) = (sizes[k / ds.len()], ds[k % ds.len()], &rec.effective);
            // Values that are not results (unreachable, no eligible level) are empty cells
            // beside their status, never NaN.
            let cell = |v: f64| {
                if v.is_finite() {
                    v.to_string()
                } else {
                    String::new()
                }
            };
            let _ = writeln!(
                csv,
                "{n},{d},{s},{},{},{},{},{},{}",
                e.iters,
                cell(e.sigma_eff_e),
                cell(e.sigma_eff_se_e),
                cell(e.r_px),
                cell(e.r_se_px),
                e.status.label()
            );
        }
        records.extend(table);
    }
    // The paper's fixed scale: a few large values (wide spots in large sub-apertures) would
    // flatten a scale set by the data; the printed numbers stay exact.
    let scale = NoiseScale::fixed(6.0, "the paper's scale");
    let mut files = vec![format!("{stem}.csv")];
    files.extend(
        save_heatmaps(
            &records,
            &scale,
            &|s| format!("Effective sCMOS read noise (e-), S = {s} photons"),
            &|s, ext| ctx.dir.join(format!("{stem}-S{s}.{ext}")),
        )?
        .iter()
        .filter_map(|p| p.file_name().map(|n| n.to_string_lossy().into_owned())),
    );
    write_atomic(&ctx.dir.join(format!("{stem}.csv")), csv.as_bytes())?;
    Ok(FigureInfo {
        number: 12,
        title: "Effective Gaussian read noise of an sCMOS camera".into(),
        caption: format!("The constant sigma (e-) whose R equals that of scmos-random with the paper's pdf, by sub-aperture size and spot diameter, one panel per signal level; the pdf's median is {:.3} e-. Each value has a standard error of at most {} e- or {} % of it, iterations added from {} up to {} per configuration. Colour scale 0-6 e- (the paper's) for every panel, values above it in its top colour with a corner mark. Cells that are not `ok` are grey and hatched with their status: `unreachable` where no constant sigma reaches the detector's R (a few very noisy pixels pull the centroid further than any uniform Gaussian noise does), `imprecise` where the standard error missed its target at the cap; the CSV gives every cell's status. {}", ctx.params.pdf.median(), Precision::DEFAULT_TARGET_SE_E, 100.0 * Precision::DEFAULT_TARGET_REL, ctx.opts.iters, precision.max_iters, ctx.sampling_note()),
        files,
    })
}

//! Chart tests: every kind draws with text to PNG and SVG; PNGs decode to the right size and are not blank.

use super::render::{ensure_fonts, Chart};
use super::*;
use crate::error::{Error, Result};
use std::path::{Path, PathBuf};

/// Decodes `path` and checks its size and that it has real content (many distinct, non-white pixels).
pub(super) fn check_png(path: &Path, size: (u32, u32)) {
    let img = image::open(path).expect("PNG decodes").to_rgb8();
    assert_eq!(img.dimensions(), size, "{}", path.display());
    let non_white = img.pixels().filter(|p| p.0 != [255, 255, 255]).count();
    let total = (size.0 * size.1) as usize;
    // Axes, text and data cover well over 1 % of any chart; a blank or failed render covers none.
    assert!(
        non_white * 100 > total,
        "{}: only {non_white} of {total} pixels drawn",
        path.display()
    );
    let mut colours: Vec<[u8; 3]> = img.pixels().map(|p| p.0).collect();
    colours.sort_unstable();
    colours.dedup();
    assert!(
        colours.len() > 20,
        "{}: only {} colours",
        path.display(),
        colours.len()
    );
}

/// Checks the SVG is complete and contains the given texts.
pub(super) fn check_svg(path: &Path, texts: &[&str]) {
    let s = std::fs::read_to_string(path).unwrap();
    assert!(
        s.starts_with("<svg") && s.trim_end().ends_with("</svg>"),
        "{}",
        path.display()
    );
    for t in texts {
        assert!(s.contains(t), "{} lacks text {t:?}", path.display());
    }
}

/// Writes `name`.png and `name`.svg via `save` into a kept directory (DETNOISE_PLOT_DIR) or a temp dir.
pub(super) fn both(
    name: &str,
    size: (u32, u32),
    texts: &[&str],
    save: impl Fn(&Path) -> Result<()>,
) {
    let tmp = tempfile::tempdir().unwrap();
    let dir: PathBuf = std::env::var_os("DETNOISE_PLOT_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| tmp.path().to_path_buf());
    std::fs::create_dir_all(&dir).unwrap();
    let png = dir.join(format!("{name}.png"));
    let svg = dir.join(format!("{name}.svg"));
    save(&png).unwrap();
    save(&svg).unwrap();
    check_png(&png, size);
    check_svg(&svg, texts);
}

fn r_vs_signal() -> LineChart {
    let mut c = LineChart::new(
        "Centroid error vs signal, 16×16 px, D = 2 px",
        "signal (photons per sub-aperture)",
        "R, mean radial error (px)",
    );
    c.log_x = true;
    let signals: [f64; 6] = [20.0, 50.0, 100.0, 200.0, 500.0, 1000.0];
    for (k, (name, a)) in [
        ("EMCCD stochastic", 1.0),
        ("sCMOS median 0.8 e⁻", 0.7),
        ("sCMOS random", 1.4),
    ]
    .into_iter()
    .enumerate()
    {
        let pts = signals
            .iter()
            .map(|&s| (s, a * 2.0 / s.sqrt() + 0.01 * k as f64, 0.004));
        c.series.push(Series::with_errors(name, pts));
    }
    c.reference.push(RefLine {
        y: 0.05,
        label: "requirement 0.05 px".into(),
    });
    c
}

#[test]
fn line_chart_png_and_svg() {
    let c = r_vs_signal();
    both(
        "line",
        c.size,
        &["R, mean radial error (px)", "EMCCD stochastic"],
        |p| c.save(p),
    );
    let mut d = r_vs_signal();
    d.log_y = true;
    d.title = "Log-log variant".into();
    both("line_loglog", d.size, &["Log-log variant"], |p| d.save(p));
}

#[test]
fn unknown_extension_is_usage_error_and_leaves_no_file() {
    let dir = tempfile::tempdir().unwrap();
    for name in ["chart.jpg", "chart", "chart.png.txt"] {
        let p = dir.path().join(name);
        let err = r_vs_signal().save(&p).unwrap_err();
        assert!(matches!(err, Error::Usage { .. }), "{err}");
        assert_eq!(err.exit_code(), 2);
        assert!(!p.exists());
    }
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

#[test]
fn absurd_canvas_size_is_a_usage_error() {
    let dir = tempfile::tempdir().unwrap();
    let mut c = r_vs_signal();
    c.size = (0, 600);
    assert!(matches!(
        c.save(dir.path().join("a.png")),
        Err(Error::Usage { .. })
    ));
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

#[test]
fn no_data_is_an_error_and_leaves_no_file() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("empty.png");
    let c = LineChart::new("t", "x", "y");
    assert!(c.save(&p).is_err());
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

fn lognormal_samples(n: usize) -> Vec<f64> {
    use rand_distr::{Distribution, LogNormal};
    let d = LogNormal::new(-0.2, 0.45).unwrap();
    let mut rng = crate::rng::stream(7, 0, 0);
    (0..n).map(|_| d.sample(&mut rng)).collect()
}

fn lognormal_pdf(x: f64) -> f64 {
    let (mu, s) = (-0.2, 0.45);
    if x <= 0.0 {
        return 0.0;
    }
    (-(x.ln() - mu).powi(2) / (2.0 * s * s)).exp() / (x * s * (2.0 * std::f64::consts::PI).sqrt())
}

fn rms_histogram() -> Histogram {
    let mut h = Histogram::new(
        "Per-pixel read-noise distribution",
        "read noise rms (e⁻)",
        "probability density (1/e⁻)",
        lognormal_samples(20_000),
    );
    h.sample_label = "measured map (20,000 px)".into();
    h.range = Some((0.0, 4.0));
    h.curves.push(Series::new(
        "fitted pdf",
        (1..400).map(|i| {
            let x = i as f64 * 0.01;
            (x, lognormal_pdf(x))
        }),
    ));
    h
}

#[test]
fn histogram_with_inset_png_and_svg() {
    let mut h = rms_histogram();
    h.inset = Some(Inset {
        title: "log scale".into(),
        x_range: None,
    });
    both(
        "hist_inset",
        h.size,
        &["probability density (1/e⁻)", "fitted pdf", "log scale"],
        |p| h.save(p),
    );
}

#[test]
fn histogram_log_y_png_and_svg() {
    let mut h = rms_histogram();
    h.title = "Read-noise distribution, log scale".into();
    h.log_y = true;
    h.norm = HistNorm::Count;
    h.y_label = "pixels per bin".into();
    h.curves.clear();
    h.bins = Bins::Count(60);
    both(
        "hist_log",
        h.size,
        &["Read-noise distribution, log scale"],
        |p| h.save(p),
    );
}

#[test]
fn histogram_binning() {
    let mut h = Histogram::new("t", "x", "y", vec![0.0, 0.5, 1.0, 1.0, 2.0, f64::NAN]);
    h.bins = Bins::Edges(vec![0.0, 1.0, 2.0]);
    h.norm = HistNorm::Count;
    let (edges, counts) = h.binned().unwrap();
    assert_eq!(edges, [0.0, 1.0, 2.0]);
    // Bins are [0, 1) and [1, 2], the last closed so the maximum is counted.
    assert_eq!(counts, [2.0, 3.0]);
    h.norm = HistNorm::Density;
    let (_, d) = h.binned().unwrap();
    assert_eq!(d, [0.4, 0.6]);
    // Density integrates to 1 over a range holding all samples.
    let h = rms_histogram();
    let (e, d) = Histogram { range: None, ..h }.binned().unwrap();
    let area: f64 = e.windows(2).zip(&d).map(|(w, v)| (w[1] - w[0]) * v).sum();
    assert!((area - 1.0).abs() < 1e-12, "{area}");
}

#[test]
fn histogram_from_zero_starts_bins_and_axis_at_zero() {
    let mut h = rms_histogram();
    h.range = None;
    let min = h.samples.iter().cloned().fold(f64::INFINITY, f64::min);
    assert!(min > 0.05, "{min}");
    assert_eq!(h.binned().unwrap().0[0], min);
    h.from_zero = true;
    let (edges, counts) = h.binned().unwrap();
    assert_eq!(edges[0], 0.0);
    assert!(counts.iter().filter(|c| **c > 0.0).count() > 10);
    // A given range still wins.
    h.range = Some((0.5, 4.0));
    assert_eq!(h.binned().unwrap().0[0], 0.5);
}

#[test]
fn histogram_outline_never_crosses_an_empty_bin() {
    // Bins of width 1 from 0: full, full, empty, full, empty, empty, full (floor at -2).
    let heights = [3.0, 1.0, 0.0, 2.0, 0.0, 0.0, 0.5];
    let bars: Vec<Option<[(f64, f64); 2]>> = heights
        .iter()
        .enumerate()
        .map(|(i, &h)| (h > 0.0).then_some([(i as f64, -2.0), (i as f64 + 1.0, h)]))
        .collect();
    let runs = super::hist::outline_runs(&bars, -2.0);
    assert_eq!(runs.len(), 3, "{runs:?}");
    assert_eq!(
        runs[0],
        [
            (0.0, -2.0),
            (0.0, 3.0),
            (1.0, 3.0),
            (1.0, 1.0),
            (2.0, 1.0),
            (2.0, -2.0)
        ]
    );
    for run in &runs {
        assert_eq!((run[0].1, run[run.len() - 1].1), (-2.0, -2.0), "{run:?}");
        for w in run.windows(2) {
            let ((x0, y0), (x1, y1)) = (w[0], w[1]);
            // Steps and tops only: never a diagonal.
            assert!(x0 == x1 || y0 == y1, "diagonal {w:?}");
            // A top lies over one non-empty bin.
            if y0 == y1 && y0 > -2.0 {
                let bin = x0.min(x1).floor() as usize;
                assert!(
                    heights[bin] > 0.0 && x0.max(x1) <= bin as f64 + 1.0,
                    "{w:?}"
                );
            }
        }
    }
    // A log-count histogram with gaps draws (many bins: the envelope path).
    let mut h = Histogram::new(
        "gaps",
        "read noise (e⁻)",
        "pixels",
        (0..300)
            .map(|i| {
                if i % 7 == 0 {
                    9.0
                } else {
                    1.0 + (i % 5) as f64 * 0.1
                }
            })
            .collect(),
    );
    h.log_y = true;
    h.norm = HistNorm::Count;
    h.bins = Bins::Count(100);
    h.from_zero = true;
    both("hist_gaps", h.size, &["gaps"], |p| h.save(p));
}

fn eff_heatmap() -> Heatmap {
    let subap = [4, 6, 8, 10, 12, 14, 16];
    let spots = [1, 2, 4, 6, 8, 10];
    let values = spots
        .iter()
        .map(|&d| {
            subap
                .iter()
                .map(|&n| 0.8 + 0.03 * n as f64 + 0.02 * d as f64)
                .collect()
        })
        .collect();
    let mut h = Heatmap::new(
        "Effective read noise, signal 50 photons",
        "sub-aperture size (px)",
        "spot diameter D (px)",
        subap.iter().map(|n| format!("{n}×{n}")).collect(),
        spots.iter().map(|d| d.to_string()).collect(),
        values,
        "σ_eff (e⁻)",
    );
    h.values[2][3] = f64::NAN;
    h
}

#[test]
fn heatmap_png_and_svg() {
    let h = eff_heatmap();
    both(
        "heatmap",
        h.size,
        &["σ_eff (e⁻)", "16×16", "1.22"],
        |p| h.save(p),
    );
    let mut bad = eff_heatmap();
    bad.values.pop();
    let dir = tempfile::tempdir().unwrap();
    assert!(matches!(
        bad.save(dir.path().join("bad.png")),
        Err(Error::Usage { .. })
    ));
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

#[test]
fn image_grid_png_and_svg() {
    let s = lognormal_samples(2560);
    let images = (0..10)
        .map(|k| Image {
            title: format!("pattern {}", k + 1),
            width: 16,
            height: 16,
            data: s[k * 256..(k + 1) * 256].to_vec(),
        })
        .collect();
    let mut g = ImageGrid::new(
        "Ten 16×16 per-pixel noise patterns",
        images,
        "read noise rms (e⁻)",
    );
    g.columns = 5;
    both(
        "images",
        g.size(),
        &["pattern 10", "read noise rms (e⁻)"],
        |p| g.save(p),
    );
    // A large image is block-averaged, not drawn pixel by pixel.
    let big = Image {
        title: "big".into(),
        width: 300,
        height: 200,
        data: vec![1.0; 60_000],
    };
    let g = ImageGrid::new("one big image", vec![big], "adu");
    both("image_big", g.size(), &["big"], |p| g.save(p));
}

#[test]
fn scatter_fit_png_and_svg() {
    let pts: Vec<(f64, f64)> = (0..25)
        .map(|i| {
            let m = 10f64 * 1.4f64.powi(i);
            (
                m,
                (m / 0.5 + 25.0) * (1.0 + 0.03 * ((i * 7 % 5) as f64 - 2.0)),
            )
        })
        .collect();
    let s = ScatterFit::new(
        "Photon transfer curve",
        "mean signal (adu)",
        "variance (adu²)",
        pts,
        "pixels",
    )
    .with_fit_fn("fit: 0.50 e⁻/adu, read noise 5.0 adu", |m| m / 0.5 + 25.0);
    both(
        "ptc",
        s.size,
        &["Photon transfer curve", "variance (adu²)"],
        |p| s.save(p),
    );
}

#[test]
fn charts_are_written_with_normal_permissions() {
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("perm.svg");
        r_vs_signal().save(&p).unwrap();
        let mode = std::fs::metadata(&p).unwrap().permissions().mode();
        assert_eq!(mode & 0o044, 0o044, "mode {mode:o}");
    }
}

#[test]
fn line_chart_many_series_linear_axes() {
    let mut c = LineChart::new(
        "R vs sub-aperture size, D = 2 px, 50 photons",
        "sub-aperture size (px)",
        "R (px)",
    );
    let names = [
        "EMCCD simple",
        "EMCCD stochastic",
        "EMCCD distribution",
        "sCMOS median",
        "sCMOS mean",
        "sCMOS fixed",
        "sCMOS random",
        "sCMOS map",
    ];
    for (k, name) in names.iter().enumerate() {
        let pts = (2..=8).map(|h| {
            let n = 2.0 * h as f64;
            (n, 0.05 + 0.004 * n * (1.0 + 0.15 * k as f64), 0.01)
        });
        c.series.push(Series::with_errors(*name, pts));
    }
    // Non-positive and NaN values are skipped on a log axis instead of failing.
    c.series
        .push(Series::new("", [(4.0, f64::NAN), (6.0, 0.2)]));
    both(
        "line_many",
        c.size,
        &["sCMOS map", "sub-aperture size (px)"],
        |p| c.save(p),
    );
    c.log_y = true;
    c.title = "A very long title that would not fit on the canvas at the normal title size, so it shrinks to fit".into();
    c.series.push(Series::new("", [(4.0, -1.0), (6.0, 0.0)]));
    both("line_many_logy", c.size, &["sCMOS map"], |p| c.save(p));
}

#[test]
fn failed_write_leaves_no_file_and_keeps_old_one() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("no_such_dir").join("chart.png");
    assert!(matches!(
        r_vs_signal().save(&missing),
        Err(Error::Io { .. })
    ));
    assert!(!missing.exists());
    // A chart that cannot be drawn leaves an existing file untouched.
    let p = dir.path().join("chart.svg");
    std::fs::write(&p, "old").unwrap();
    assert!(LineChart::new("t", "x", "y").save(&p).is_err());
    assert_eq!(std::fs::read_to_string(&p).unwrap(), "old");
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    // A successful save replaces it.
    r_vs_signal().save(&p).unwrap();
    check_svg(&p, &["EMCCD stochastic"]);
}

#[test]
fn text_width_measures_the_embedded_font() {
    ensure_fonts().unwrap();
    let t = "A very long title";
    let regular = style::text_width(t, 26.0);
    let bold = style::text_width_styled(t, 26.0, true);
    eprintln!("regular {regular} px, bold {bold} px");
    assert!(regular > 150 && regular < 300, "{regular}");
    assert!(bold > regular);
}

#[test]
fn pdf_only_with_log_inset() {
    // The paper's Fig. 1: a model pdf (no samples) with a log-scale inset of its tail.
    let pdf = |x: f64| {
        ((10.0 * x - 6.5).tanh() + 1.0)
            * (1.0 / (x.powi(10) + 0.1)
                + 1.0 / (2.0 * (x.powi(4) + 0.1))
                + 1.0 / (2.0 * (x * x + 0.1)))
    };
    let xs: Vec<f64> = (0..=1000).map(|i| i as f64 * 0.01).collect();
    let norm: f64 = xs
        .windows(2)
        .map(|w| 0.5 * (pdf(w[0]) + pdf(w[1])) * (w[1] - w[0]))
        .sum();
    let mut h = Histogram::new(
        "sCMOS read-noise pdf (Basden 2015, Eq. 3)",
        "rms (e⁻)",
        "pdf (1/e⁻)",
        vec![],
    );
    h.range = Some((0.0, 3.0));
    h.curves.push(Series::new(
        "paper pdf",
        xs.iter().map(|&x| (x, pdf(x) / norm)),
    ));
    h.inset = Some(Inset {
        title: "log scale, 0-10 e⁻".into(),
        x_range: Some((0.0, 10.0)),
    });
    both(
        "pdf_inset",
        h.size,
        &["paper pdf", "log scale, 0-10 e⁻"],
        |p| h.save(p),
    );
    // Neither samples nor curves: nothing to draw.
    let empty = Histogram::new("t", "x", "y", vec![f64::NAN]);
    let dir = tempfile::tempdir().unwrap();
    assert!(empty.save(dir.path().join("e.png")).is_err());
}

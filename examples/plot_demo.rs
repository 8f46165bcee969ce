//! Writes one chart of each kind with the `detnoise::plot` API, as PNG and SVG.
//!
//! `cargo run --example plot_demo -- OUT_DIR` (default `plot-demo/`)

use detnoise::plot::{
    Heatmap, Histogram, Image, ImageGrid, Inset, LineChart, RefLine, ScatterFit, Series,
};

fn main() -> detnoise::Result<()> {
    let out = std::path::PathBuf::from(
        std::env::args()
            .nth(1)
            .unwrap_or_else(|| "plot-demo".into()),
    );
    std::fs::create_dir_all(&out).map_err(|e| detnoise::Error::io(&out, e))?;

    // Line chart: R against signal on a log x axis, with standard-error bars and a reference line.
    let mut line = LineChart::new(
        "R vs signal, 16×16 px, D = 2 px",
        "signal (photons)",
        "R (px)",
    );
    line.log_x = true;
    for (name, a) in [("EMCCD stochastic", 1.0), ("sCMOS random", 1.3)] {
        let pts =
            [20.0, 50.0, 100.0, 200.0, 500.0, 1000.0].map(|s: f64| (s, a / s.sqrt(), 0.01 * a));
        line.series.push(Series::with_errors(name, pts));
    }
    line.reference.push(RefLine {
        y: 0.05,
        label: "0.05 px".into(),
    });

    // Histogram with a fitted pdf and a log-y inset (a deterministic sample of a Rayleigh law).
    let n = 20_000;
    let samples: Vec<f64> = (0..n)
        .map(|i| (-2.0 * (1.0 - (i as f64 + 0.5) / n as f64).ln()).sqrt())
        .collect();
    let mut hist = Histogram::new("Per-pixel noise", "rms (e⁻)", "density (1/e⁻)", samples);
    hist.sample_label = "pixels".into();
    hist.curves.push(Series::new(
        "Rayleigh pdf",
        (1..300).map(|i| {
            let x = i as f64 * 0.015;
            (x, x * (-x * x / 2.0).exp())
        }),
    ));
    hist.inset = Some(Inset {
        title: "log scale".into(),
        x_range: None,
    });

    // Heatmap of a value over two categorical axes.
    let heat = Heatmap::new(
        "Effective read noise, 50 photons",
        "sub-aperture size (px)",
        "spot diameter (px)",
        ["4", "8", "16"].map(String::from).to_vec(),
        ["1", "2", "4"].map(String::from).to_vec(),
        vec![
            vec![0.9, 1.0, 1.1],
            vec![1.0, 1.1, 1.2],
            vec![1.1, 1.2, 1.4],
        ],
        "σ_eff (e⁻)",
    );

    // Image grid with a shared colour scale.
    let images = (0..4)
        .map(|k| Image {
            title: format!("pattern {k}"),
            width: 16,
            height: 16,
            data: (0..256)
                .map(|i| ((i * (k + 3)) % 17) as f64 / 8.0)
                .collect(),
        })
        .collect();
    let grid = ImageGrid::new("Noise patterns", images, "rms (e⁻)");

    // Log-log scatter with a fitted curve.
    let ptc_pts: Vec<(f64, f64)> = (0..20)
        .map(|i| 10f64 * 1.5f64.powi(i))
        .map(|m| (m, 2.0 * m + 25.0))
        .collect();
    let ptc = ScatterFit::new(
        "Photon transfer",
        "mean (adu)",
        "variance (adu²)",
        ptc_pts,
        "pixels",
    )
    .with_fit_fn("var = 2 mean + 25", |m| 2.0 * m + 25.0);

    for ext in ["png", "svg"] {
        line.save(out.join(format!("line.{ext}")))?;
        hist.save(out.join(format!("hist.{ext}")))?;
        heat.save(out.join(format!("heatmap.{ext}")))?;
        grid.save(out.join(format!("images.{ext}")))?;
        ptc.save(out.join(format!("ptc.{ext}")))?;
    }
    println!("charts written to {}", out.display());
    Ok(())
}

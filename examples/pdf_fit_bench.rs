//! Benchmark and recovery figures of `fit_pdf` on maps drawn from the paper's pdf
//! (64x64 and 512x512) and from a log-normal: fit seconds, paper-scaled scale in SE,
//! median/mean errors and the paper-family's largest parameter correlation.
//!
//! Run: `cargo run --release --example pdf_fit_bench`.

use detnoise::fit::{fit_pdf, PdfFitOptions};
use detnoise::pdf::{paper, RmsPdf};
use detnoise::rng::stream;
use rand_distr::{Distribution, LogNormal};
use std::time::Instant;

fn report(name: &str, values: &[f64]) -> detnoise::Result<()> {
    let t = Instant::now();
    let r = fit_pdf(values, &PdfFitOptions::default())?;
    println!(
        "{name}: {} values, fit {:.2} s, best {}",
        r.n_values,
        t.elapsed().as_secs_f64(),
        r.best_model
    );
    let ps = &r.models["paper-scaled"];
    let (s, se) = (ps.params["scale"], ps.param_se["scale"].unwrap_or(f64::NAN));
    println!(
        "  paper-scaled scale {s:.5} +- {se:.5} ({:+.2} SE from 1)",
        (s - 1.0) / se
    );
    for (m, f) in &r.models {
        let max_r = f.correlations.as_ref().map_or(f64::NAN, |c| {
            c.iter()
                .enumerate()
                .flat_map(|(i, row)| {
                    row.iter()
                        .enumerate()
                        .filter(move |(j, _)| *j != i)
                        .map(|(_, v)| v.abs())
                })
                .fold(0.0, f64::max)
        });
        println!(
            "  {m:<15} dAIC {:>8.1} maxCDF {:.4} median {:+.3} % mean {:+.3} % >3xmed {:.4} (map {:.4}) max|r| {max_r:.3}",
            f.delta_aic.unwrap_or(f64::NAN),
            f.max_cdf_distance,
            100.0 * (f.median_e / r.data.median_e - 1.0),
            100.0 * (f.mean_e / r.data.mean_e - 1.0),
            f.frac_above_3x_median,
            r.data.frac_above_3x_median
        );
    }
    Ok(())
}

fn main() -> detnoise::Result<()> {
    let p = paper();
    for side in [64usize, 512] {
        let mut rng = stream(100, side as u64, 0);
        let v: Vec<f64> = (0..side * side).map(|_| p.sample(&mut rng)).collect();
        report(&format!("paper {side}x{side}"), &v)?;
    }
    let ln = LogNormal::new(0.0, 0.3).expect("valid");
    let mut rng = stream(101, 0, 0);
    let v: Vec<f64> = (0..256 * 256).map(|_| ln.sample(&mut rng)).collect();
    report("lognormal 256x256", &v)
}

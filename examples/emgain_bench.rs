//! Benchmark of the EM-gain fit (issue 5 speed target: well under 10 s each) on synthetic
//! EMCCD samples (exact register, g = 300, 520 stages, read noise 50 e-, 10 e-/adu,
//! lambda 0.1, integer adu): 5000 frames of 3x3 and 100 frames of 512x512.
//!
//! Run: `cargo run --release --example emgain_bench` (prints seconds per stage).

use detnoise::detector::EmRegister;
use detnoise::fit::emgain::{fit_emgain, EmGainOptions, EmShape, ValueHistogram};
use detnoise::rng::stream;
use detnoise::stats::poisson;
use rand_distr::{Distribution, Normal};
use std::time::Instant;

fn main() -> detnoise::Result<()> {
    let reg = EmRegister::new(300.0, 520)?;
    let noise = Normal::new(0.0, 50.0).expect("valid sigma");
    for (frames, side) in [(5000usize, 3usize), (100, 512)] {
        let t = Instant::now();
        let mut hist = ValueHistogram::new(1.0);
        let mut frame = vec![0.0; side * side];
        for f in 0..frames {
            // One stream per frame, as a reader would deliver them.
            let mut rng = stream(42, f as u64, 0);
            for v in frame.iter_mut() {
                let k = poisson(0.1, &mut rng) as u64;
                *v = (500.0 + (reg.sample(k, &mut rng) + noise.sample(&mut rng)) / 10.0).round();
            }
            hist.add_all(&frame)?;
        }
        let t_hist = t.elapsed().as_secs_f64();
        for (name, shape) in [
            ("exponential", EmShape::Gamma),
            (
                "gamma, register F^2",
                EmShape::RegisterGamma { stages: 520 },
            ),
            ("register", EmShape::Register { stages: 520 }),
        ] {
            // Serial CIC on auto (the default): both models fitted where the law has it.
            let opts = EmGainOptions {
                shape: Some(shape),
                gain_e_per_adu: Some(10.0),
                ..Default::default()
            };
            let t = Instant::now();
            let fit = fit_emgain(&hist, &opts)?;
            println!(
                "{frames} x {side}x{side} ({:.1e} samples): synthesis+histogram {t_hist:.2} s, fit ({name}) {:.2} s: gain {:.2} +- {:.2} e-/e-, read noise {:.3} adu, lambda {:.4}",
                hist.total(),
                t.elapsed().as_secs_f64(),
                fit.em_gain,
                fit.em_gain_se,
                fit.read_noise_adu,
                fit.lambda_e
            );
        }
    }
    Ok(())
}

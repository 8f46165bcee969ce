//! Every figure of Basden (2015), regenerated: data (CSV), PNG and SVG, and an index page.
//!
//! The figures use `point` sampling (spot evaluated at pixel centres) as the paper most likely
//! did (the Durham platform's `createAiryDisc`); `integrated` redraws them the other way.

mod emccd;
mod figure;
mod index;
mod models;
mod options;
mod scmos;

pub use index::write_index;
pub use options::{FigureInfo, PaperOptions};

use crate::detector::ModelParams;
use crate::progress::Observer;
use crate::Result;
use figure::Ctx;
use std::path::Path;

/// Monte-Carlo pixel-frames (iterations x pixels x models) of a generation per iteration of
/// `iters`, for the full and the quick grids: counted over every run of a generation, the
/// effective-noise pilots at their share of the iterations (10 % in full, all in quick).
const PIXEL_FRAMES_PER_ITER: (u64, u64) = (586_805, 41_168);
/// Drawing and writing one figure costs about as much time as this many pixel-frames (about
/// 0.3 s of one core, measured): the quick run is mostly drawing.
const PIXEL_FRAMES_PER_FIGURE: u64 = 6_000_000;

/// Regenerate every figure into `dir` (which must exist); returns what was written.
/// `observer` sees one stage, `paper`, of 14 figures, with a step named after each figure.
pub fn generate(
    opts: &PaperOptions,
    dir: &Path,
    observer: &dyn Observer,
) -> Result<Vec<FigureInfo>> {
    let ctx = Ctx {
        opts,
        dir,
        params: ModelParams::default(),
    };
    type FigFn = fn(&Ctx) -> Result<FigureInfo>;
    let figures: [(&str, FigFn); 14] = [
        ("Fig. 1 rms pdf", scmos::fig01_pdf),
        ("Fig. 2 noise patterns", scmos::fig02_patterns),
        ("Fig. 3 EMCCD models, D = 2", |c| {
            emccd::fig_emccd_models(c, 3, 2.0)
        }),
        ("Fig. 4 EMCCD models, D = 10", |c| {
            emccd::fig_emccd_models(c, 4, 10.0)
        }),
        ("Fig. 5 R vs EM gain", emccd::fig05_gain),
        ("Fig. 6 thresholding", emccd::fig06_pp),
        ("Fig. 7 all models 16x16", |c| {
            models::fig_all_models(c, 7, 16)
        }),
        ("Fig. 8 all models 4x4", |c| models::fig_all_models(c, 8, 4)),
        ("Fig. 9 R vs sub-aperture", models::fig09_subap),
        ("Fig. 10 R vs spot diameter", models::fig10_diameter),
        ("Fig. 11 constant sigmas", scmos::fig11_constants),
        ("Fig. 12 effective read noise", scmos::fig12_effective),
        ("Fig. 13 LGS elongation", models::fig13_lgs),
        ("Fig. 14 QE scaling", models::fig14_qe),
    ];
    let per_iter = if opts.quick {
        PIXEL_FRAMES_PER_ITER.1
    } else {
        PIXEL_FRAMES_PER_ITER.0
    };
    let n = figures.len() as u64;
    let work = opts.iters * per_iter + n * PIXEL_FRAMES_PER_FIGURE;
    observer.begin("paper", n, work);
    let out = figures
        .into_iter()
        .map(|(label, f)| {
            observer.step(label);
            let info = f(&ctx);
            observer.advance(1);
            info
        })
        .collect();
    observer.end();
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::progress::Recorder;
    use crate::spot::Sampling;
    use std::sync::atomic::Ordering::Relaxed;

    #[test]
    fn quick_generation_writes_every_figure_and_reports_each_step() {
        let opts = PaperOptions {
            iters: 20,
            seed: 1,
            sampling: Sampling::Point,
            quick: true,
        };
        let dir = tempfile::tempdir().unwrap();
        let recorder = Recorder::default();
        let figures = generate(&opts, dir.path(), &recorder).unwrap();
        let numbers: Vec<u32> = figures.iter().map(|f| f.number).collect();
        assert_eq!(numbers, (1..=14).collect::<Vec<u32>>());
        for f in &figures {
            for file in &f.files {
                assert!(dir.path().join(file).is_file(), "{file}");
            }
        }
        let work = 20 * PIXEL_FRAMES_PER_ITER.1 + 14 * PIXEL_FRAMES_PER_FIGURE;
        assert_eq!(
            *recorder.stages.lock().unwrap(),
            [("paper".to_string(), 14, work)]
        );
        let steps = recorder.steps.lock().unwrap();
        assert_eq!(steps.len(), 14);
        assert_eq!(steps[11], "Fig. 12 effective read noise");
        assert_eq!(recorder.advanced.load(Relaxed), 14);
        assert_eq!(recorder.ended.load(Relaxed), 1);
    }
}

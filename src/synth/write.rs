//! A synthetic stack written to disk: the frames in the chosen format, the truth maps beside
//! it and a manifest of what was simulated.

use std::path::{Path, PathBuf};

use rayon::prelude::*;
use serde::Serialize;

use super::spec::{Camera, SynthSpec};
use super::truth::{draw_truth, frame};
use crate::detector::register::EmRegister;
use crate::error::{Error, Result};
use crate::io::fits::{key, KeyValue};
use crate::io::StackFormat;
use crate::output::write_json;
use crate::pdf::RmsPdf;
use crate::stats::median;

/// Manifest of a synthetic stack: the spec, the truth summary and the truth map files.
#[derive(Debug, Serialize)]
pub struct Manifest {
    /// Tool name and version.
    pub tool: String,
    /// The stack file.
    pub stack: PathBuf,
    /// Its format.
    pub format: StackFormat,
    /// What was simulated.
    pub spec: SynthSpec,
    /// Label of the read-noise pdf used (sCMOS).
    pub rms_pdf: String,
    /// Truth map files (FITS), by quantity.
    pub truth_maps: std::collections::BTreeMap<String, PathBuf>,
    /// Median of the per-pixel read noise (e-).
    pub rms_e_median: f64,
    /// Mean of the per-pixel read noise (e-).
    pub rms_e_mean: f64,
    /// EM register excess noise factor squared (EMCCD).
    pub excess_noise_factor_sq: Option<f64>,
    /// Note on how integer storage changes the measured noise.
    pub note: String,
}

/// Simulate `spec` and write the stack to `out` in `format`, its truth maps beside it
/// (`<out stem>.truth-<quantity>.fits`) and `<out stem>.manifest.json`. Returns the manifest.
pub fn write_synthetic(
    spec: &SynthSpec,
    pdf: &dyn RmsPdf,
    format: StackFormat,
    out: &Path,
) -> Result<Manifest> {
    let here = out.parent().unwrap_or(Path::new(""));
    write_synthetic_in(spec, pdf, format, out, here)
}

/// Quantities of the truth maps written beside a synthetic stack.
const TRUTH_MAPS: [&str; 4] = ["offset_adu", "rms_e", "rms_adu", "gain_e_per_adu"];

/// Every file [`write_synthetic`] writes for the stack `out`: the stack, its truth maps and
/// its manifest.
pub fn output_files(out: &Path) -> Vec<PathBuf> {
    let stem = stack_stem(out);
    let beside = |suffix: &str| stem.with_file_name(format!("{}.{suffix}", file_name(&stem)));
    std::iter::once(out.to_path_buf())
        .chain(
            TRUTH_MAPS
                .iter()
                .map(|q| beside(&format!("truth-{q}.fits"))),
        )
        .chain([beside("manifest.json")])
        .collect()
}

/// [`write_synthetic`] with every file written into the directory `dir` under its final name
/// (a staging directory moved into place by the caller); the manifest names the final paths.
pub fn write_synthetic_in(
    spec: &SynthSpec,
    pdf: &dyn RmsPdf,
    format: StackFormat,
    out: &Path,
    dir: &Path,
) -> Result<Manifest> {
    let staged = |p: &Path| dir.join(p.file_name().unwrap_or_default());
    let files = output_files(out);
    if spec.frames == 0 || spec.shape.0 == 0 || spec.shape.1 == 0 {
        return Err(Error::invalid(
            "shape",
            "need at least one row and column, and `frames` at least 1",
        ));
    }
    let truth = draw_truth(spec, pdf);
    let register = match &spec.camera {
        Camera::Emccd(p) => {
            EmRegister::check(p.em_gain, p.stages, "em_gain")?;
            Some(EmRegister::new(p.em_gain, p.stages)?)
        }
        Camera::Scmos(_) => None,
    };
    // Frames are generated in parallel batches (each from its own stream) and written in order.
    let batch = 32;
    let mut queue: std::collections::VecDeque<Vec<f64>> = Default::default();
    let mut next_k = 0usize;
    let mut next = || {
        if queue.is_empty() {
            let end = (next_k + batch).min(spec.frames);
            let frames: Vec<Vec<f64>> = (next_k..end)
                .into_par_iter()
                .map(|k| frame(spec, &truth, register.as_ref(), k))
                .collect();
            queue.extend(frames);
            next_k = end;
        }
        queue
            .pop_front()
            .expect("frame count checked by the writer")
    };
    let keys = vec![
        key(
            "DNSEED",
            KeyValue::I64(spec.seed as i64),
            "detnoise synth seed",
        ),
        key(
            "DNLIGHT",
            KeyValue::F64(spec.light_e),
            "mean light per pixel per frame (e-)",
        ),
        key(
            "DNDET",
            KeyValue::Str(match spec.camera {
                Camera::Scmos(_) => "scmos".into(),
                Camera::Emccd(_) => "emccd".into(),
            }),
            "simulated detector",
        ),
    ];
    let stack_file = staged(out);
    match format {
        StackFormat::Fits => crate::io::fits::write_cube(
            &stack_file,
            spec.shape,
            spec.frames,
            spec.u16_samples,
            &mut next,
            &keys,
        )?,
        StackFormat::Tiff => crate::io::tiff::write_pages(
            &stack_file,
            spec.shape,
            spec.frames,
            spec.u16_samples,
            &mut next,
        )?,
        StackFormat::Exr => crate::io::exr::write_layers(
            &stack_file,
            spec.shape,
            spec.frames,
            spec.u16_samples,
            &mut next,
        )?,
    }
    let mut truth_maps = std::collections::BTreeMap::new();
    let rms_adu = truth.rms_adu();
    let maps = [
        &truth.offset_adu,
        &truth.rms_e,
        &rms_adu,
        &truth.gain_e_per_adu,
    ];
    for ((name, map), p) in TRUTH_MAPS.iter().zip(maps).zip(&files[1..]) {
        map.write_fits(&staged(p), &keys)?;
        truth_maps.insert(name.to_string(), p.clone());
    }
    let manifest = Manifest {
        tool: format!("detnoise {}", env!("CARGO_PKG_VERSION")),
        stack: out.to_path_buf(),
        format,
        spec: spec.clone(),
        rms_pdf: pdf.label(),
        truth_maps,
        rms_e_median: median(&truth.rms_e.data),
        rms_e_mean: truth.rms_e.data.iter().sum::<f64>() / truth.rms_e.data.len() as f64,
        excess_noise_factor_sq: register.as_ref().map(|r| r.excess_noise_factor_sq()),
        note: "Integer storage rounds each sample: the measured variance in adu is about rms_adu^2 + 1/12 (quantisation) for rms_adu above ~0.5 adu.".into(),
    };
    write_json(&staged(&files[5]), &manifest)?;
    Ok(manifest)
}

fn file_name(p: &Path) -> String {
    p.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default()
}

/// `out` without its stack extension (`.fits`, `.tif`, `.tiff`, `.exr`).
pub fn stack_stem(out: &Path) -> PathBuf {
    let ext = out.extension().and_then(|e| e.to_str());
    let is_stack = |e: &str| StackFormat::ALL.iter().any(|f| f.extensions().contains(&e));
    if ext.is_some_and(is_stack) {
        out.with_extension("")
    } else {
        out.to_path_buf()
    }
}

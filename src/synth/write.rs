//! A synthetic stack written to disk: the frames in the chosen format, the truth maps beside
//! it and a manifest of what was simulated.

use std::collections::{BTreeMap, VecDeque};
use std::path::{Path, PathBuf};

use rayon::prelude::*;
use serde::Serialize;

use super::defects::ChainStates;
use super::format::SynthFormat;
use super::spec::{Camera, SynthSpec};
use super::truth::{draw_truth, frame_with, Truth};
use crate::calib::darks::{write_rts_csv, RtsLevelRow, RtsRow};
use crate::calib::{Map, Unit};
use crate::detector::register::EmRegister;
use crate::error::{Error, Result};
use crate::io::fits::{key, KeyValue, Keyword};
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
    pub format: SynthFormat,
    /// What was simulated.
    pub spec: SynthSpec,
    /// Label of the read-noise pdf used (sCMOS).
    pub rms_pdf: String,
    /// Truth map files (FITS), by quantity.
    pub truth_maps: BTreeMap<String, PathBuf>,
    /// Median of the per-pixel read noise (e-).
    pub rms_e_median: f64,
    /// Mean of the per-pixel read noise (e-).
    pub rms_e_mean: f64,
    /// EM register excess noise factor squared (EMCCD).
    pub excess_noise_factor_sq: Option<f64>,
    /// Note on how integer storage changes the measured noise.
    pub note: String,
    /// What the injected defects came to (sCMOS with defects only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub defects: Option<DefectsManifest>,
}

/// The injected defects of a synthetic stack, as drawn.
#[derive(Debug, Serialize)]
pub struct DefectsManifest {
    /// RTS pixels injected.
    pub rts_pixels: usize,
    /// Their table (columns of `darks`' rts.csv; levels relative to the pixel's mean), if any.
    pub rts_truth: Option<PathBuf>,
    /// Stationary occupancy of each RTS level.
    pub rts_occupancy: Option<Vec<f64>>,
    /// Hot pixels injected.
    pub hot_pixels: usize,
    /// What the truth maps and table mean for the defects.
    pub note: String,
}

/// Simulate `spec` and write the stack to `out` in `format`, its truth maps beside it
/// (`<out stem>.truth-<quantity>.fits`) and `<out stem>.manifest.json`. Returns the manifest.
pub fn write_synthetic(
    spec: &SynthSpec,
    pdf: &dyn RmsPdf,
    format: SynthFormat,
    out: &Path,
) -> Result<Manifest> {
    let here = out.parent().unwrap_or(Path::new(""));
    write_synthetic_in(spec, pdf, format, out, here)
}

/// Quantities of the truth maps written beside a synthetic stack.
const TRUTH_MAPS: [&str; 4] = ["offset_adu", "rms_e", "rms_adu", "gain_e_per_adu"];

/// Every file [`write_synthetic`] writes for the stack `out` of a Gaussian camera: the stack,
/// its truth maps and its manifest.
pub fn output_files(out: &Path) -> Vec<PathBuf> {
    std::iter::once(out.to_path_buf())
        .chain(
            TRUTH_MAPS
                .iter()
                .map(|q| beside(out, &format!("truth-{q}.fits"))),
        )
        .chain([beside(out, "manifest.json")])
        .collect()
}

/// The truth files of `spec`'s defects beside the stack `out`: the RTS table and the hot
/// pixels' dark-signal map, when there are such pixels.
pub fn defect_files(out: &Path, spec: &SynthSpec) -> (Option<PathBuf>, Option<PathBuf>) {
    match &spec.camera {
        Camera::Scmos(p) => (
            p.defects
                .rts
                .as_ref()
                .filter(|r| r.fraction > 0.0)
                .map(|_| beside(out, "truth-rts.csv")),
            (p.defects.hot_fraction > 0.0).then(|| beside(out, "truth-hot_dark_e.fits")),
        ),
        Camera::Emccd(_) => (None, None),
    }
}

/// [`output_files`] and the defects' truth files of `spec`.
pub fn output_files_for(out: &Path, spec: &SynthSpec) -> Vec<PathBuf> {
    let (rts, hot) = defect_files(out, spec);
    output_files(out)
        .into_iter()
        .chain(rts)
        .chain(hot)
        .collect()
}

/// The RTS truth table: per RTS pixel its levels relative to its mean (the stationary
/// occupancies' weighted mean of its levels), in adu and e- with its own gain.
fn rts_truth_rows(spec: &SynthSpec, truth: &Truth) -> Vec<RtsRow> {
    let Some(chain) = &truth.defects.chain else {
        return Vec::new();
    };
    let cols = spec.shape.1;
    truth
        .defects
        .rts
        .iter()
        .map(|p| {
            let g = truth.gain_e_per_adu.data[p.index];
            let mean: f64 = p
                .heights_e
                .iter()
                .zip(chain.occupancy())
                .map(|(h, o)| h * o)
                .sum();
            let levels = p
                .heights_e
                .iter()
                .zip(chain.occupancy().iter().zip(chain.dwell_frames()))
                .map(|(h, (o, d))| RtsLevelRow {
                    level_adu: (h - mean) / g,
                    level_se_adu: None,
                    occupancy: *o,
                    occupancy_se: None,
                    width_adu: truth.rms_e.data[p.index] / g,
                    dwell_frames: *d,
                    dwell_se_frames: None,
                })
                .collect();
            RtsRow {
                x_px: p.index % cols,
                y_px: p.index / cols,
                status: "ok",
                levels,
                gain_e_per_adu: Some(g),
            }
        })
        .collect()
}

/// [`write_synthetic`] with every file written into the directory `dir` under its final name
/// (a staging directory moved into place by the caller); the manifest names the final paths.
pub fn write_synthetic_in(
    spec: &SynthSpec,
    pdf: &dyn RmsPdf,
    format: SynthFormat,
    out: &Path,
    dir: &Path,
) -> Result<Manifest> {
    let staged = |p: &Path| dir.join(p.file_name().unwrap_or_default());
    check(spec)?;
    let truth = draw_truth(spec, pdf);
    let register = em_register(spec)?;
    let keys = header_keys(spec);
    let mut frames = FrameBatches::new(spec, &truth, register.as_ref());
    format.write(
        &staged(out),
        spec.shape,
        spec.frames,
        spec.u16_samples,
        &mut || frames.next(),
        &keys,
    )?;
    let (truth_maps, rts_file) = write_truth_files(spec, &truth, out, &staged, &keys)?;
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
        defects: defects_manifest(spec, &truth, rts_file),
    };
    write_json(&staged(&beside(out, "manifest.json")), &manifest)?;
    Ok(manifest)
}

/// Fail unless `spec` has frames and pixels and its sCMOS defects are consistent.
fn check(spec: &SynthSpec) -> Result<()> {
    if spec.frames == 0 || spec.shape.0 == 0 || spec.shape.1 == 0 {
        return Err(Error::invalid(
            "shape",
            "need at least one row and column, and `frames` at least 1",
        ));
    }
    if let Camera::Scmos(p) = &spec.camera {
        p.defects.check()?;
    }
    Ok(())
}

/// The EM register of an EMCCD spec (checked), none for sCMOS.
fn em_register(spec: &SynthSpec) -> Result<Option<EmRegister>> {
    match &spec.camera {
        Camera::Emccd(p) => {
            EmRegister::check(p.em_gain, p.stages, "em_gain")?;
            Ok(Some(EmRegister::new(p.em_gain, p.stages)?))
        }
        Camera::Scmos(_) => Ok(None),
    }
}

/// The FITS keys that mark the stack and its truth maps as `synth`'s: seed, light, detector.
fn header_keys(spec: &SynthSpec) -> Vec<Keyword> {
    vec![
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
    ]
}

/// Frames generated per parallel batch.
const BATCH: usize = 32;

/// The frames of a synthetic stack in order, generated in parallel batches (each frame from
/// its own stream, so the thread count does not matter).
struct FrameBatches<'a> {
    spec: &'a SynthSpec,
    truth: &'a Truth,
    register: Option<&'a EmRegister>,
    chains: ChainStates,
    queue: VecDeque<Vec<f64>>,
    next_k: usize,
}

impl<'a> FrameBatches<'a> {
    fn new(spec: &'a SynthSpec, truth: &'a Truth, register: Option<&'a EmRegister>) -> Self {
        FrameBatches {
            spec,
            truth,
            register,
            chains: ChainStates::new(&truth.defects, spec.seed),
            queue: VecDeque::new(),
            next_k: 0,
        }
    }

    /// The next frame (e- per pixel, as stored); called at most `spec.frames` times.
    fn next(&mut self) -> Vec<f64> {
        if self.queue.is_empty() {
            self.draw_batch();
        }
        self.queue
            .pop_front()
            .expect("frame count checked by the writer")
    }

    /// Draw the next batch: RTS chains step in frame order, the frames then draw in parallel.
    fn draw_batch(&mut self) {
        let (start, end) = (self.next_k, (self.next_k + BATCH).min(self.spec.frames));
        let levels: Vec<Vec<u8>> = (start..end)
            .map(|_| {
                let l = self.chains.levels.clone();
                self.chains.advance(&self.truth.defects);
                l
            })
            .collect();
        let (spec, truth, register) = (self.spec, self.truth, self.register);
        let frames: Vec<Vec<f64>> = (start..end)
            .into_par_iter()
            .zip(&levels)
            .map(|(k, l)| frame_with(spec, truth, register, k, l))
            .collect();
        self.queue.extend(frames);
        self.next_k = end;
    }
}

/// Write the truth maps, and the defects' truth table and map, beside the stack `out` (each
/// through `staged`); returns the maps' final paths by quantity and the table's path.
fn write_truth_files(
    spec: &SynthSpec,
    truth: &Truth,
    out: &Path,
    staged: &dyn Fn(&Path) -> PathBuf,
    keys: &[Keyword],
) -> Result<(BTreeMap<String, PathBuf>, Option<PathBuf>)> {
    let mut truth_maps = BTreeMap::new();
    let rms_adu = truth.rms_adu();
    let maps = [
        &truth.offset_adu,
        &truth.rms_e,
        &rms_adu,
        &truth.gain_e_per_adu,
    ];
    for (name, map) in TRUTH_MAPS.iter().zip(maps) {
        let p = beside(out, &format!("truth-{name}.fits"));
        map.write_fits(&staged(&p), keys)?;
        truth_maps.insert(name.to_string(), p);
    }
    let (rts_file, hot_file) = defect_files(out, spec);
    if let Some(p) = &rts_file {
        write_rts_csv(&staged(p), &rts_truth_rows(spec, truth))?;
    }
    if let Some(p) = &hot_file {
        let (rows, cols) = spec.shape;
        let m = Map::new(
            rows,
            cols,
            truth.defects.hot_dark_e.clone(),
            Unit::Electrons,
        );
        m.write_fits(&staged(p), keys)?;
        truth_maps.insert("hot_dark_e".into(), p.clone());
    }
    Ok((truth_maps, rts_file))
}

/// What the injected defects came to (sCMOS with defects; none otherwise).
fn defects_manifest(
    spec: &SynthSpec,
    truth: &Truth,
    rts_file: Option<PathBuf>,
) -> Option<DefectsManifest> {
    match &spec.camera {
        Camera::Scmos(p) if !p.defects.is_none() => Some(DefectsManifest {
            rts_pixels: truth.defects.rts.len(),
            rts_truth: rts_file,
            rts_occupancy: truth.defects.chain.as_ref().map(|c| c.occupancy().to_vec()),
            hot_pixels: truth.defects.hot_dark_e.iter().filter(|d| **d > 0.0).count(),
            note: "offset_adu is the offset without defects: an RTS pixel's mean is above it by its levels' occupancy-weighted mean height (the RTS table's levels are relative to that mean), a hot pixel's by hot_dark_e / gain; rms_e is the pixel's own Gaussian noise, to which row and column noise, RTS levels and hot pixels' shot noise add".into(),
        }),
        _ => None,
    }
}

/// The file `<out stem>.<suffix>` beside the stack `out`.
fn beside(out: &Path, suffix: &str) -> PathBuf {
    let stem = stack_stem(out);
    stem.with_file_name(format!("{}.{suffix}", file_name(&stem)))
}

fn file_name(p: &Path) -> String {
    p.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default()
}

/// `out` without its stack extension (`.fits`, `.tif`, `.tiff`, `.exr`).
pub fn stack_stem(out: &Path) -> PathBuf {
    let ext = out.extension().and_then(|e| e.to_str());
    let is_stack = |e: &str| SynthFormat::ALL.iter().any(|f| f.extensions().contains(&e));
    if ext.is_some_and(is_stack) {
        out.with_extension("")
    } else {
        out.to_path_buf()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::named_as_truth_map;
    use crate::synth::{Defects, RtsParams, ScmosParams};

    #[test]
    fn the_reader_knows_every_truth_map_by_its_name() {
        let defects = Defects {
            rts: Some(RtsParams {
                fraction: 0.1,
                steps_e: vec![8.0],
                step_spread: 0.25,
                dwell_frames: vec![30.0, 10.0],
                occupancy: None,
            }),
            hot_fraction: 0.1,
            hot_dark_e: 50.0,
            ..Defects::default()
        };
        let spec = SynthSpec {
            camera: Camera::Scmos(ScmosParams {
                offset_adu: 100.0,
                offset_spread_adu: 2.0,
                gain_e_per_adu: 0.25,
                gain_spread: 0.02,
                defects,
            }),
            shape: (4, 4),
            frames: 2,
            light_e: 0.0,
            seed: 1,
            u16_samples: true,
        };
        let out = Path::new("dir/x-100e.fits");
        let files = output_files_for(out, &spec);
        let maps: Vec<&PathBuf> = files
            .iter()
            .filter(|p| p.extension().is_some_and(|e| e == "fits") && p.as_path() != out)
            .collect();
        assert_eq!(maps.len(), TRUTH_MAPS.len() + 1, "{files:?}");
        for p in &files {
            assert_eq!(named_as_truth_map(p), maps.contains(&p), "{}", p.display());
        }
    }
}

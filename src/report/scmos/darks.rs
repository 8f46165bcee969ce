//! The darks' part of an sCMOS report: the dark maps and their files, the conversion gain
//! (given, or from photon transfer on the flats), the noise map in e⁻ and the fit of its
//! distribution.

use crate::calib::darks::write_outputs as write_dark_outputs;
use crate::calib::darks::{dark_maps_hashed, require_dark, DarkMaps, DarkOptions, DarkSummary};
use crate::calib::ptc::chart as ptc_chart;
use crate::calib::ptc::POINTS_NAMES;
use crate::calib::ptc::{photon_transfer, write_points, DarkReference, PtcOptions, PtcResult};
use crate::calib::summary::{inputs, Checksum, InputFile};
use crate::calib::Map;
use crate::fit::pdf_fit::chart as pdf_fit_chart;
use crate::fit::pdf_fit::{fit_pdf, PdfFitOptions, PdfFitReport};
use crate::io::FrameStack;
use crate::output::OutputDir;
use crate::progress::Observer;
use crate::report::options::{GainSource, ReportOptions};
use crate::{Error, Result};
use std::sync::Arc;

/// The dark calibration's summary in a report (`darks` names it summary.json).
const DARKS_SUMMARY: &str = "darks_summary.json";

/// Files of the fit of the per-pixel noise distribution.
const PDF_FIT_FILES: [&str; 2] = ["pdf_fit.json", "pdf_fit.png"];

/// Files of photon transfer (with flats).
const PTC_FILES: [&str; 3] = ["ptc.png", POINTS_NAMES[0], POINTS_NAMES[1]];

/// The files this part may write: the dark calibration's (its summary renamed), the fit's and
/// photon transfer's.
pub(super) fn outputs() -> impl Iterator<Item = &'static str> {
    crate::calib::darks::OUTPUT_NAMES
        .into_iter()
        .map(|n| {
            if n == "summary.json" {
                DARKS_SUMMARY
            } else {
                n
            }
        })
        .chain(PDF_FIT_FILES)
        .chain(PTC_FILES)
}

/// The conversion gain and where it came from.
pub(super) struct Gain {
    pub e_per_adu: f64,
    pub source: &'static str,
    pub se_e_per_adu: Option<f64>,
    pub ptc: Option<PtcResult>,
    /// The flats' input records (with BLAKE3), empty when the gain was given.
    pub flat_inputs: Vec<InputFile>,
}

/// What the darks gave.
pub(super) struct Darks {
    /// The dark maps (offset, rms, flags, telegraph pixels).
    pub maps: DarkMaps,
    /// The conversion gain.
    pub gain: Gain,
    /// The dark calibration's summary (its files, temporal noise, RTS, inputs).
    pub summary: DarkSummary,
    /// The noise map (e⁻), flagged pixels NaN.
    pub rms_e: Arc<Map>,
    /// Its finite positive values (e⁻): the pixels the distribution is fitted to.
    pub values: Vec<f64>,
}

/// Compute the dark maps of `stack` (hashing the darks as they are read), take the gain, and
/// write the dark calibration's files into `dir`.
pub(super) fn calibrate(
    o: &ReportOptions,
    stack: &FrameStack,
    dir: &OutputDir,
    observer: &dyn Observer,
) -> Result<Darks> {
    let dark_opts = DarkOptions::default();
    // The darks are hashed from the frames read for the statistics, not read a second time.
    let (maps, darks_inputs) = dark_maps_hashed(stack, &dark_opts, Checksum::Blake3)?;
    if let Some(warning) = require_dark(stack, &maps, o.accept_illuminated)? {
        observer.warn(&warning);
    }
    let gain = conversion_gain(o, &maps)?;
    // What photon transfer says to distrust (an EM register in the flats, a fit that cannot
    // be checked) is the report's to say too.
    for warning in gain.ptc.iter().flat_map(|p| &p.warnings) {
        observer.warn(warning);
    }
    let summary = write_dark_outputs(
        &dir.path(""),
        stack,
        &maps,
        &dark_opts,
        Some(gain.e_per_adu),
        darks_inputs,
        DARKS_SUMMARY,
    )?;
    // Noise map in e-, flagged pixels excluded (NaN) from the statistics and the windows.
    let rms_e = maps
        .rms_adu
        .masked(&maps.flags)
        .to_electrons(gain.e_per_adu)
        .with_source(o.darks_paths[0].display().to_string());
    let rms_e = Arc::new(rms_e);
    let values: Vec<f64> = rms_e
        .data
        .iter()
        .copied()
        .filter(|v| v.is_finite() && *v > 0.0)
        .collect();
    if values.len() < 16 {
        return Err(Error::input(
            &o.darks_paths[0],
            format!(
                "only {} unflagged pixels with a positive noise: too few to fit a distribution",
                values.len()
            ),
        ));
    }
    Ok(Darks {
        maps,
        gain,
        summary,
        rms_e,
        values,
    })
}

/// Fit the distribution of the per-pixel noise `values` (e⁻) and write the fit's files into
/// `dir`; returns the fit and the names written.
pub(super) fn fit_noise(
    values: &[f64],
    dir: &OutputDir,
) -> Result<(PdfFitReport, [&'static str; 2])> {
    let fit = fit_pdf(values, &PdfFitOptions::default())?;
    let [json, png] = PDF_FIT_FILES;
    fit.write_json(&dir.path(json))?;
    pdf_fit_chart(&fit, values, &dir.path(png))?;
    Ok((fit, PDF_FIT_FILES))
}

/// Write photon transfer's chart and points when it gave the gain; returns the names written.
pub(super) fn write_ptc(gain: &Gain, dir: &OutputDir) -> Result<Vec<&'static str>> {
    let Some(p) = &gain.ptc else {
        return Ok(Vec::new());
    };
    ptc_chart(p, &dir.path(PTC_FILES[0]))?;
    write_points(p, &dir.path(""))?;
    Ok(PTC_FILES.to_vec())
}

/// The gain: from photon transfer when flats are given, else the caller's; never guessed.
fn conversion_gain(o: &ReportOptions, maps: &DarkMaps) -> Result<Gain> {
    match o.gain_source()? {
        GainSource::Given(g) => Ok(Gain {
            e_per_adu: g,
            source: "given",
            se_e_per_adu: None,
            ptc: None,
            flat_inputs: Vec::new(),
        }),
        GainSource::PhotonTransfer => {
            let flats: Vec<FrameStack> = o
                .flats_paths
                .iter()
                .map(|f| FrameStack::open(std::slice::from_ref(f)))
                .collect::<Result<_>>()?;
            let dark = DarkReference::from_stats(&maps.stats);
            let p = photon_transfer(&flats, &dark, &PtcOptions::default())?;
            let flat_inputs = flats
                .iter()
                .map(|f| inputs(f, Checksum::Blake3))
                .collect::<Result<Vec<_>>>()?;
            Ok(Gain {
                e_per_adu: p.gain_e_per_adu,
                source: "ptc",
                se_e_per_adu: Some(p.gain_err_e_per_adu),
                ptc: Some(p),
                flat_inputs: flat_inputs.into_iter().flatten().collect(),
            })
        }
    }
}

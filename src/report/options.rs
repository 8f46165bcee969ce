//! What a report is asked to do: the camera's frames, the conversion gain, the grid of
//! configurations, the Monte-Carlo settings, the readout-model parameters and the output
//! directory, checked together before any frame is read.

use super::grid::{Grid, GridChoice};
use super::point::OperatingPoint;
use crate::detector::{EmRegister, ModelParams};
use crate::effective::Precision;
use crate::montecarlo::SimConfig;
use crate::spot::{Sampling, Spot};
use crate::{Error, Result};
use std::path::PathBuf;

/// The kind of camera a report is about.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
pub enum DetectorKind {
    /// sCMOS: per-pixel read noise, fitted distribution, effective read noise.
    #[default]
    Scmos,
    /// EMCCD: EM gain, read noise and mean electrons fitted to the frames' histogram.
    Emccd,
}

/// The options of a report. Lists left `None` take the full grid, or with `quick` the preview.
#[derive(Debug, Clone)]
pub struct ReportOptions {
    /// The camera type.
    pub detector: DetectorKind,
    /// Dark frames: files, directories or glob patterns (FITS, TIFF, OpenEXR).
    pub darks_paths: Vec<PathBuf>,
    /// Flat stacks, one per light level, for photon transfer (sCMOS only).
    pub flats_paths: Vec<PathBuf>,
    /// Conversion gain (e- per adu); required without flats, refused with them.
    pub gain_e_per_adu: Option<f64>,
    /// Sub-aperture sizes of the effective-noise table (px per side, 2 to 128).
    pub subaps_px: Option<Vec<usize>>,
    /// Spots of the table (sizes at least 0.1 px).
    pub spots: Option<Vec<Spot>>,
    /// Signals of the table (photons per sub-aperture; signal x QE at most 1e9).
    pub signals_photons: Option<Vec<f64>>,
    /// The configuration of the headline numbers (default 8x8 px, airy:2, 50 photons); simulated
    /// beside the grid when it is not one of the grid's configurations.
    pub operating_point: Option<OperatingPoint>,
    /// Starting Monte-Carlo iterations per configuration (2 to 1e9; `quick` caps them at 2,000).
    pub iters: u64,
    /// Precision target of each effective read noise and the iteration cap (at least `iters`;
    /// `quick` lowers the cap to [`Precision::QUICK_MAX_ITERS`]).
    pub precision: Precision,
    /// Seed of every random stream.
    pub seed: u64,
    /// Spot sampling.
    pub sampling: Sampling,
    /// Quantum efficiency of this (sCMOS) camera in the comparison, (0, 1].
    pub qe: f64,
    /// Quantum efficiency of the EMCCD in the comparison, (0, 1].
    pub qe_emccd: f64,
    /// Use dark frames that look illuminated (sCMOS only); otherwise they are refused.
    pub accept_illuminated: bool,
    /// Fast preview: the reduced grid where left unset, and at most 2,000 iterations.
    pub quick: bool,
    /// Readout-model parameters (EM gain e-/e-, read noise e- rms, sCMOS pdf); the report
    /// replaces what it measures (the sCMOS pdf and map, or the EM gain and read noise).
    pub model_params: ModelParams,
    /// Files the model parameters were read from (a pdf fit, a noise map): never overwritten.
    pub model_input_paths: Vec<PathBuf>,
    /// Output directory, written only when the whole report succeeded.
    pub out_dir: PathBuf,
    /// Write into an existing `out_dir` that holds other files (never replacing them).
    pub force: bool,
    /// Lenslet geometry of the per-sub-aperture map (sCMOS): with it the report adds the
    /// effective read noise of every sub-aperture of its measured map at the operating point's
    /// spot and signal; None: no such section.
    pub subaps: Option<crate::subaps::Geometry>,
    /// Centroiders compared in the sCMOS report's centroider section (`cog` is always the
    /// reference); the first one also reads the per-sub-aperture map.
    pub centroiders: Vec<crate::centroid::CentroiderSpec>,
    /// Run the measured map through every centroider over the whole grid (every spot and
    /// signal); otherwise over the grid's sub-aperture sizes at the operating point's spot and
    /// signal only.
    pub centroider_full_grid: bool,
}

impl Default for ReportOptions {
    fn default() -> Self {
        ReportOptions {
            detector: DetectorKind::Scmos,
            darks_paths: Vec::new(),
            flats_paths: Vec::new(),
            gain_e_per_adu: None,
            subaps_px: None,
            spots: None,
            signals_photons: None,
            operating_point: None,
            iters: 10_000,
            precision: Precision::default(),
            seed: 1,
            sampling: Sampling::Integrated,
            qe: 1.0,
            qe_emccd: 1.0,
            accept_illuminated: false,
            quick: false,
            model_params: ModelParams::default(),
            model_input_paths: Vec::new(),
            out_dir: PathBuf::new(),
            force: false,
            subaps: None,
            centroiders: crate::centroid::CENTROIDERS
                .iter()
                .map(crate::centroid::CentroiderSpec::of)
                .collect(),
            centroider_full_grid: false,
        }
    }
}

/// Where the conversion gain comes from.
pub(crate) enum GainSource {
    /// Given by the caller (e- per adu).
    Given(f64),
    /// Measured by photon transfer on the flats.
    PhotonTransfer,
}

impl ReportOptions {
    /// Check every option (inputs, grid, Monte-Carlo settings, register, conversion gain)
    /// before any frame is read; the error names the field at fault.
    pub fn validate(&self) -> Result<()> {
        if self.darks_paths.is_empty() {
            return Err(Error::invalid("darks_paths", "no dark frames given"));
        }
        if self.out_dir.as_os_str().is_empty() {
            return Err(Error::invalid("out", "no output directory given"));
        }
        self.check_lists()?;
        if !(self.qe_emccd.is_finite() && self.qe_emccd > 0.0 && self.qe_emccd <= 1.0) {
            return Err(Error::invalid(
                "qe_emccd",
                format!("{}: QE must be in (0, 1]", self.qe_emccd),
            ));
        }
        let grid = self.grid();
        // `precision_in_use` only lowers the cap towards the starting iterations: valid when
        // this is.
        self.precision.validate(grid.iters)?;
        // The comparison runs the EMCCD at its own QE: both must be valid configurations.
        for cfg in grid.configs(self.qe) {
            SimConfig {
                qe: self.qe_emccd,
                ..cfg.clone()
            }
            .validate()?;
            cfg.validate()?;
        }
        // The headline is simulated at both QEs too (this camera, and the EMCCD compared).
        let op = self.operating_point();
        for qe in [self.qe, self.qe_emccd] {
            grid.config(op.subap_px, op.spot, op.signal_photons, qe)
                .validate()
                .map_err(|e| op.blame(e))?;
        }
        if let Some(g) = &self.subaps {
            g.grid.validate()?;
            if self.detector == DetectorKind::Emccd {
                return Err(Error::invalid(
                    "subap_grid",
                    "the per-sub-aperture map reads an sCMOS noise map: an EMCCD report has none",
                ));
            }
        }
        let p = &self.model_params;
        EmRegister::check(p.em_gain, p.stages, "em_gain")?;
        self.gain_source().map(|_| ())
    }

    /// Empty lists and spots too small to simulate are refused.
    fn check_lists(&self) -> Result<()> {
        let empty = [
            ("subaps_px", self.subaps_px.as_ref().map(Vec::len)),
            ("spots", self.spots.as_ref().map(Vec::len)),
            (
                "signals_photons",
                self.signals_photons.as_ref().map(Vec::len),
            ),
        ];
        if let Some((field, _)) = empty.iter().find(|(_, n)| *n == Some(0)) {
            return Err(Error::invalid(*field, "empty list"));
        }
        for spot in self.spots.iter().flatten() {
            spot.validate()?;
        }
        Ok(())
    }

    /// The operating point of the headline numbers: the one given, or the default.
    pub fn operating_point(&self) -> OperatingPoint {
        self.operating_point.unwrap_or_default()
    }

    /// The precision the effective-noise table runs with: `precision`, with `quick` its cap
    /// lowered to [`Precision::QUICK_MAX_ITERS`] (never below the starting iterations).
    pub(crate) fn precision_in_use(&self) -> Precision {
        let mut p = self.precision;
        if self.quick {
            p.max_iters = p
                .max_iters
                .min(Precision::QUICK_MAX_ITERS)
                .max(self.grid().iters);
        }
        p
    }

    /// The grid of configurations these options ask for.
    pub(crate) fn grid(&self) -> Grid {
        Grid::resolve(&GridChoice {
            subaps_px: self.subaps_px.as_deref(),
            spots: self.spots.as_deref(),
            signals_photons: self.signals_photons.as_deref(),
            iters: self.iters,
            seed: self.seed,
            sampling: self.sampling,
            quick: self.quick,
        })
    }

    /// Where the conversion gain comes from: given, or photon transfer on the flats; an
    /// error when neither or both are given, or flats for an EMCCD.
    pub(crate) fn gain_source(&self) -> Result<GainSource> {
        let flats = !self.flats_paths.is_empty();
        match (self.gain_e_per_adu, flats, self.detector) {
            (Some(g), false, _) if !(g.is_finite() && g > 0.0) => Err(Error::invalid(
                "gain_e_per_adu",
                format!("{g}: must be a number > 0 e- per adu"),
            )),
            (Some(g), false, _) => Ok(GainSource::Given(g)),
            (None, true, DetectorKind::Scmos) => Ok(GainSource::PhotonTransfer),
            (Some(_), true, DetectorKind::Scmos) => Err(Error::invalid(
                "gain_e_per_adu",
                "give either `flats_paths` (photon transfer) or `gain_e_per_adu`, not both",
            )),
            (_, true, DetectorKind::Emccd) => Err(Error::invalid(
                "flats_paths",
                "an EMCCD report takes the conversion gain from `gain_e_per_adu` (photon \
                 transfer at unity EM gain, or the data sheet), not from flats",
            )),
            (None, false, DetectorKind::Scmos) => Err(Error::invalid(
                "gain_e_per_adu",
                "no conversion gain: give `gain_e_per_adu` G (e- per adu, from the camera's data sheet) or flat stacks with `flats_paths` so photon transfer can measure it",
            )),
            (None, false, DetectorKind::Emccd) => Err(Error::invalid(
                "gain_e_per_adu",
                "an EMCCD report needs the conversion gain in e- per adu (photon transfer at unity EM gain, or the data sheet)",
            )),
        }
    }
}

#[cfg(test)]
mod precision_tests {
    use super::*;

    fn options(quick: bool, iters: u64, max_iters: u64) -> ReportOptions {
        ReportOptions {
            darks_paths: vec!["darks.fits".into()],
            gain_e_per_adu: Some(0.25),
            out_dir: "out".into(),
            quick,
            iters,
            precision: Precision {
                max_iters,
                ..Precision::default()
            },
            ..ReportOptions::default()
        }
    }

    #[test]
    fn the_cap_is_checked_against_the_starting_iterations_and_lowered_by_quick() {
        options(false, 10_000, 80_000).validate().unwrap();
        let err = options(false, 10_000, 5_000).validate().unwrap_err();
        assert!(err.to_string().contains("`max_iters`"), "{err}");
        // Quick starts at 2,000 iterations, so a cap of 5,000 is fine there...
        options(true, 10_000, 5_000).validate().unwrap();
        // ...and it lowers the cap to its own, never below the start.
        let quick = options(true, 10_000, 80_000).precision_in_use();
        assert_eq!(quick.max_iters, Precision::QUICK_MAX_ITERS);
        assert_eq!(
            options(false, 10_000, 80_000).precision_in_use().max_iters,
            80_000
        );
        let mut small = options(true, 100, 100);
        small.precision.max_iters = 100;
        assert_eq!(small.precision_in_use().max_iters, 100);
    }
}

//! What the standard does not give and detnoise can: the per-pixel maps (system gain, dark
//! current, temporal dark noise) with their standard errors, written as FITS images and
//! summarised (mean and pixel-to-pixel spread, each with its SE), and the effective read
//! noise of the dark noise map for a Shack-Hartmann sub-aperture, beside the datasheet's
//! sigma_d.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use super::dataset::EmvaDataset;
use super::datasheet::Datasheet;
use super::pixel_maps::{pixel_maps, PixelMaps};
use super::quantity::{Quantity, QuantityStatus};
use super::sheet::{Row, Section, Sheet};
use super::temporal::IMPRECISE_RELATIVE_SE;
use crate::calib::{Map, Unit};
use crate::detector::{ModelParams, ModelSpec};
use crate::effective::{effective_sigma, Effective, Precision, Status};
use crate::error::{Error, Result};
use crate::io::fits::{key, write_image, ImageData, KeyValue, Keyword};
use crate::montecarlo::SimConfig;
use crate::report::OperatingPoint;

/// The dark noise map's file: the name `report` and `simulate --model scmos-map --map` read.
pub const RMS_MAP: &str = "rms_e.fits";

/// How the effective read noise is computed.
#[derive(Clone, Debug, PartialEq)]
pub struct BeyondOptions {
    /// The sub-aperture, spot and signal (the report's operating point).
    pub point: OperatingPoint,
    /// Precision target and iteration cap of the effective read noise.
    pub precision: Precision,
}

impl Default for BeyondOptions {
    /// The report's operating point (8x8 px, airy:2, 50 photons) at the quick precision
    /// (the default targets, the cap lowered to [`Precision::QUICK_MAX_ITERS`] frames).
    fn default() -> Self {
        BeyondOptions {
            point: OperatingPoint::default(),
            precision: Precision {
                max_iters: Precision::QUICK_MAX_ITERS,
                ..Precision::default()
            },
        }
    }
}

impl BeyondOptions {
    /// The Monte-Carlo configuration: the report's (QE 1, 10,000 starting frames, seed 1,
    /// integrated sampling, automatic background grid) at the operating point.
    pub fn config(&self) -> SimConfig {
        let p = &self.point;
        SimConfig {
            spot: p.spot,
            signal_photons: p.signal_photons,
            ..SimConfig::paper(p.subap_px)
        }
    }

    /// Check the point and the precision (before any frame is read); the errors name
    /// `operating_point`.
    pub fn validate(&self) -> Result<()> {
        let cfg = self.config();
        cfg.validate().map_err(|e| self.point.blame(e))?;
        self.precision.validate(cfg.iters)
    }

    /// Check that frames of `shape` (rows, cols) hold the sub-aperture.
    pub fn check_shape(&self, shape: (usize, usize), source: &Path) -> Result<()> {
        let n = self.point.subap_px;
        if shape.0 < n || shape.1 < n {
            return Err(Error::invalid(
                "operating_point",
                format!(
                    "{}: the {n}x{n} px sub-aperture does not fit in the dataset's {}x{} px \
                     frames ({})",
                    self.point.text(),
                    shape.0,
                    shape.1,
                    source.display()
                ),
            ));
        }
        Ok(())
    }
}

/// The maps and the effective read noise of one dataset.
#[derive(Clone, Debug)]
pub struct Beyond {
    /// The per-pixel maps.
    pub maps: PixelMaps,
    /// The effective read noise of the dark noise map (e-).
    pub effective: Effective,
    /// Where it was computed.
    pub options: BeyondOptions,
    /// The system gain K the maps in e- were converted with (DN/e-) and its SE.
    pub k: Quantity,
}

/// The maps of `dataset` (a second pass over its pairs) and the effective read noise of its
/// dark noise map.
pub fn beyond(
    dataset: &EmvaDataset,
    datasheet: &Datasheet,
    options: &BeyondOptions,
) -> Result<Beyond> {
    let maps = pixel_maps(dataset, &datasheet.points, &datasheet.temporal)?;
    let (rows, cols) = maps.shape;
    let map = Map::new(rows, cols, maps.dark_noise_e.clone(), Unit::Electrons).with_source(RMS_MAP);
    let params = ModelParams {
        map: Some(Arc::new(map)),
        ..ModelParams::default()
    };
    let readout = ModelSpec::ScmosMap.build(&params, options.point.subap_px)?;
    let effective = effective_sigma(
        &options.config(),
        readout.as_ref(),
        &options.precision,
        &crate::progress::Silent,
    )?;
    Ok(Beyond {
        maps,
        effective,
        options: options.clone(),
        k: datasheet.temporal.system_gain_dn_per_e.clone(),
    })
}

/// One FITS map: file name, values, BUNIT, what the pixels hold.
type MapFile<'a> = (&'static str, &'a [f64], &'static str, &'static str);

impl Beyond {
    /// The FITS maps written (the dark current's only when it was measured).
    fn files(&self) -> Vec<MapFile<'_>> {
        let m = &self.maps;
        let mut files: Vec<MapFile> = vec![
            (
                "gain_dn_per_e.fits",
                &m.gain_dn_per_e,
                "adu/electron",
                "system gain K of the pixel",
            ),
            (
                "gain_se_dn_per_e.fits",
                &m.gain_se_dn_per_e,
                "adu/electron",
                "standard error of the pixel's K",
            ),
            (
                RMS_MAP,
                &m.dark_noise_e,
                Unit::Electrons.bunit(),
                "temporal dark noise at zero exposure",
            ),
            (
                "rms_se_e.fits",
                &m.dark_noise_se_e,
                Unit::Electrons.bunit(),
                "standard error of the dark noise",
            ),
        ];
        if m.has_dark_current {
            files.push((
                "dark_current_e_per_s.fits",
                &m.dark_current_e_per_s,
                "electron/s",
                "dark current of the pixel",
            ));
            files.push((
                "dark_current_se_e_per_s.fits",
                &m.dark_current_se_e_per_s,
                "electron/s",
                "standard error of the dark current",
            ));
        }
        files
    }

    /// Write the FITS maps into `dir`; their paths.
    pub fn write(&self, dir: &Path) -> Result<Vec<PathBuf>> {
        let mut written = Vec::new();
        for (name, data, bunit, what) in self.files() {
            let keys: Vec<Keyword> = vec![
                key("DNWHAT", KeyValue::Str(what.into()), "what the pixels hold"),
                key(
                    "KGAIN",
                    KeyValue::F64(self.k.value),
                    "system gain K of the datasheet (DN/e-)",
                ),
            ];
            let path = dir.join(name);
            write_image(&path, self.maps.shape, ImageData::F64(data), bunit, &keys)?;
            written.push(path);
        }
        Ok(written)
    }

    /// The section "Beyond the standard": each map's mean and spread, the effective read
    /// noise.
    pub fn section(&self) -> Section {
        let m = &self.maps;
        let k_rel = (self.k.se / self.k.value).abs();
        let k_rel = if k_rel.is_finite() { k_rel } else { 0.0 };
        let mut rows = Vec::new();
        let mut summary = |key: &str, what: &str, unit: &str, v: &[f64], se: &[f64], rel| {
            let (mean, spread) = summarise(v, se, rel);
            rows.push(Row::new(
                &format!("{key}_mean_{}", unit_key(unit)),
                &format!("{what}, mean over the pixels"),
                unit,
                mean,
            ));
            rows.push(Row::new(
                &format!("{key}_spread_{}", unit_key(unit)),
                &format!("{what}, pixel-to-pixel spread (SD less the measurement noise)"),
                unit,
                spread,
            ));
        };
        summary(
            "gain_map",
            "System gain K per pixel",
            "DN/e-",
            &m.gain_dn_per_e,
            &m.gain_se_dn_per_e,
            0.0,
        );
        if m.has_dark_current {
            summary(
                "dark_current_map",
                "Dark current per pixel",
                "e-/s",
                &m.dark_current_e_per_s,
                &m.dark_current_se_e_per_s,
                k_rel,
            );
        }
        summary(
            "dark_noise_map",
            "Temporal dark noise per pixel (rms_e.fits)",
            "e-",
            &m.dark_noise_e,
            &m.dark_noise_se_e,
            k_rel,
        );
        rows.push(Row::new(
            "effective_read_noise_e",
            &format!(
                "Effective read noise for a Shack-Hartmann sub-aperture ({}, cog), of the dark \
                 noise map; compare σ_d",
                self.options.point.describe()
            ),
            "e-",
            effective_quantity(&self.effective),
        ));
        Section {
            title: "Beyond the standard".into(),
            rows,
        }
    }

    /// Remarks for the sheet's notes: how the maps and the effective read noise were made.
    pub fn notes(&self) -> Vec<String> {
        let mut notes = Vec::new();
        if !self.maps.has_dark_current {
            notes.push(format!(
                "dark pairs at fewer than {} exposure times: no dark current map is written, \
                 and the dark noise map (rms_e.fits) holds the noise at the pairs' exposure, \
                 dark current's shot noise included",
                super::temporal::MIN_DARK_EXPOSURES
            ));
        }
        let p = &self.options.precision;
        notes.push(format!(
            "effective read noise: scmos-map of rms_e.fits at {} (QE 1, integrated sampling, \
             cog, seed 1), its SE target the larger of {} e- and {} of the value, at most {} \
             frames (the quick previews' cap)",
            self.options.point.describe(),
            p.target_se_e,
            p.target_rel,
            p.max_iters
        ));
        notes
    }

    /// Add the section and the notes to `sheet`.
    pub fn add_to(&self, sheet: &mut Sheet) {
        sheet.sections.push(self.section());
        sheet.notes.extend(self.notes());
    }
}

/// The unit as a key's tail: `DN/e-` -> `dn_per_e`, `e-/s` -> `e_per_s`, `e-` -> `e`.
fn unit_key(unit: &str) -> String {
    unit.to_lowercase().replace('-', "").replace('/', "_per_")
}

/// Pixels farther than this many robust SDs from a map's median are left out of its mean and
/// spread (hot or defect pixels), well beyond the maps' own skewed tails.
pub const CLIP_ROBUST_SD: f64 = 5.0;

/// A map's mean over its pixels and its pixel-to-pixel spread (the SD with the mean
/// measurement variance `se`^2 removed), each with its SE, over the pixels within
/// [`CLIP_ROBUST_SD`] robust SDs of the median. The mean, not the median: a pixel's K or
/// noise is a variance's estimate, skewed, whose median lies below the truth (by 2 % for K
/// from 40 pairs). `k_rel` is the relative SE of the global K the map was converted with
/// (common to every pixel, added to both).
pub fn summarise(values: &[f64], se: &[f64], k_rel: f64) -> (Quantity, Quantity) {
    let finite: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
    let (median, robust) = crate::stats::median_and_robust_sigma(&finite);
    let kept: Vec<(f64, f64)> = values
        .iter()
        .zip(se)
        .filter(|(v, s)| (*v - median).abs() <= CLIP_ROBUST_SD * robust && s.is_finite())
        .map(|(v, s)| (*v, *s))
        .collect();
    if kept.len() < 2 {
        let why = "fewer than 2 pixels with a value";
        return (Quantity::unavailable(why), Quantity::unavailable(why));
    }
    let n = kept.len() as f64;
    let mean = kept.iter().map(|p| p.0).sum::<f64>() / n;
    let var = kept.iter().map(|p| (p.0 - mean).powi(2)).sum::<f64>() / (n - 1.0);
    let noise2 = kept.iter().map(|p| p.1 * p.1).sum::<f64>() / n;
    let sd = var.sqrt();
    let mean_se = (sd / n.sqrt()).hypot(mean * k_rel);
    let sd_se = sd / (2.0 * (n - 1.0)).sqrt();
    let spread = (var - noise2).max(0.0).sqrt();
    // d spread = sd d sd / spread, bounded near 0 by the spread that sits 1 SE above it.
    let spread_se = (sd * sd_se / spread)
        .min((2.0 * sd * sd_se).sqrt())
        .hypot(spread * k_rel);
    let judged = |value: f64, se: f64| {
        let mut q = Quantity::ok(value, se);
        // A NaN SE is imprecise too.
        if se.is_nan() || se > IMPRECISE_RELATIVE_SE * value.abs() {
            q.status = QuantityStatus::Imprecise;
        }
        q
    };
    (judged(mean, mean_se), judged(spread, spread_se))
}

/// The effective read noise as a datasheet number: `ok` and `imprecise` keep their value and
/// SE, every other status is unavailable with its meaning.
pub fn effective_quantity(e: &Effective) -> Quantity {
    match e.status {
        Status::Ok => Quantity::ok(e.sigma_eff_e, e.sigma_eff_se_e),
        Status::Imprecise => Quantity {
            status: QuantityStatus::Imprecise,
            ..Quantity::ok(e.sigma_eff_e, e.sigma_eff_se_e)
        },
        other => Quantity::unavailable(format!("{}: {}", other.label(), other.meaning())),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unit_keys_follow_the_sheets_spelling() {
        assert_eq!(unit_key("DN/e-"), "dn_per_e");
        assert_eq!(unit_key("e-/s"), "e_per_s");
        assert_eq!(unit_key("e-"), "e");
    }

    #[test]
    fn the_spread_removes_the_measurement_noise_and_the_mean_carries_k_and_clips_hot_pixels() {
        // Values 10 + 3 z with SE 2: the pixels' own spread is sqrt(9 - 4).
        use rand_distr::{Distribution, StandardNormal};
        let mut rng = crate::rng::stream(34, 0, 0);
        let z: Vec<f64> = (0..20_001)
            .map(|_| StandardNormal.sample(&mut rng))
            .collect();
        let v: Vec<f64> = z.iter().map(|z| 10.0 + 3.0 * z).collect();
        let se = vec![2.0; v.len()];
        let mut v = v;
        v[0] = 1e6; // a hot pixel, clipped
        let (mean, spread) = summarise(&v, &se, 0.01);
        assert!((mean.value - 10.0).abs() < 0.07, "{mean:?}");
        assert!(
            (mean.se - (3.0 / 20_000f64.sqrt()).hypot(0.1)).abs() < 1e-3,
            "{mean:?}"
        );
        assert!((spread.value - 5f64.sqrt()).abs() < 0.07, "{spread:?}");
        assert_eq!(spread.status, QuantityStatus::Ok);
        // All noise: no spread left, and not a result.
        let (_, none) = summarise(&v, &vec![4.0; v.len()], 0.0);
        assert_eq!((none.value, none.status), (0.0, QuantityStatus::Imprecise));
    }

    #[test]
    fn only_ok_and_imprecise_effective_values_are_kept() {
        for s in Status::ALL {
            let e = Effective {
                sigma_eff_e: 6.0,
                sigma_eff_se_e: 0.1,
                sigma_cog_equiv_e: 6.0,
                sigma_cog_equiv_se_e: 0.1,
                target_se_e: Some(0.15),
                iters: 10_000,
                r_px: 0.1,
                r_se_px: 0.001,
                b_opt_e: 2.0,
                param_name: None,
                param_opt: None,
                sigma_grid_e: vec![],
                r_const_px: vec![],
                status: s,
                parts: Default::default(),
            };
            let q = effective_quantity(&e);
            match s {
                Status::Ok | Status::Imprecise => {
                    assert_eq!((q.value, q.status.label()), (6.0, s.label()))
                }
                _ => assert!(q.value.is_nan() && q.status.rule().unwrap().contains(s.meaning())),
            }
        }
    }
}

//! The whole datasheet of a dataset: the photon-transfer series reduced and fitted
//! (`temporal`), the spatial stacks (`spatial`, DSNU in e- through the system gain just
//! measured), and both laid out as one [`Sheet`] of numbers and figures.

use serde::Serialize;

use super::dataset::EmvaDataset;
use super::pairs::{measure, PointStats};
use super::quantity::Quantity;
use super::sheet::{Curve, Figure, Row, Section, Sheet};
use super::spatial::{spatial_from_stacks, Parts, SpatialOptions, SpatialResult};
use super::temporal::{temporal, CurvePoint, TemporalResult};
use crate::error::Result;

/// Everything computed from one dataset.
#[derive(Clone, Debug, Serialize)]
pub struct Datasheet {
    /// Photon transfer, noise, saturation, SNR, linearity, dark current.
    pub temporal: TemporalResult,
    /// DSNU, PRNU, spectrograms, profiles, histograms, defects (None without spatial stacks).
    pub spatial: Option<SpatialResult>,
    /// The reduced photon-transfer points (for the per-pixel maps' second pass).
    #[serde(skip)]
    pub points: Vec<PointStats>,
}

/// Compute the datasheet of `dataset` (every frame read once; the spatial stacks after the
/// series, with its system gain and saturation).
pub fn compute(dataset: &EmvaDataset, options: &SpatialOptions) -> Result<Datasheet> {
    let points = measure(dataset)?;
    let temporal = temporal(&points);
    let spatial = match (&dataset.spatial_bright, &dataset.spatial_dark) {
        (Some(bright), Some(dark)) => {
            let saturation_dn = temporal
                .points
                .get(temporal.saturation_index)
                .map(|p| p.signal_dn);
            let options = SpatialOptions {
                saturation_dn: options.saturation_dn.or(saturation_dn),
                ..options.clone()
            };
            Some(spatial_from_stacks(
                bright,
                dark,
                &temporal.system_gain_dn_per_e,
                &options,
            )?)
        }
        _ => None,
    };
    Ok(Datasheet {
        temporal,
        spatial,
        points,
    })
}

impl Datasheet {
    /// The datasheet laid out as sections and figures, titled for `dataset`.
    pub fn sheet(&self, dataset: &EmvaDataset) -> Sheet {
        let t = &self.temporal;
        let mut sections = vec![
            Section {
                title: "Sensitivity".into(),
                rows: vec![
                    Row::new(
                        "system_gain_dn_per_e",
                        "System gain K",
                        "DN/e-",
                        t.system_gain_dn_per_e.clone(),
                    ),
                    Row::new(
                        "responsivity_dn_per_photon",
                        "Responsivity R",
                        "DN/photon",
                        t.responsivity_dn_per_photon.clone(),
                    ),
                    Row::new(
                        "quantum_efficiency_percent",
                        "Quantum efficiency",
                        "%",
                        t.quantum_efficiency_percent.clone(),
                    ),
                ],
            },
            Section {
                title: "Noise, saturation and dynamic range".into(),
                rows: vec![
                    Row::new(
                        "dark_noise_dn",
                        "Temporal dark noise σ_y.dark",
                        "DN",
                        t.dark_noise_dn.clone(),
                    ),
                    Row::new(
                        "dark_noise_e",
                        "Temporal dark noise σ_d",
                        "e-",
                        t.dark_noise_e.clone(),
                    ),
                    Row::new(
                        "saturation_capacity_e",
                        "Saturation capacity μ_e.sat",
                        "e-",
                        t.saturation_capacity_e.clone(),
                    ),
                    Row::new(
                        "saturation_photons_per_px",
                        "Saturation irradiation μ_p.sat",
                        "photons/px",
                        t.saturation_photons_per_px.clone(),
                    ),
                    Row::new("snr_max", "Maximum SNR", "", t.snr_max.clone()),
                    Row::new("snr_max_db", "Maximum SNR", "dB", t.snr_max_db.clone()),
                    Row::new(
                        "dynamic_range",
                        "Dynamic range",
                        "",
                        t.dynamic_range.clone(),
                    ),
                    Row::new(
                        "dynamic_range_db",
                        "Dynamic range",
                        "dB",
                        t.dynamic_range_db.clone(),
                    ),
                    Row::new(
                        "sensitivity_threshold_e",
                        "Absolute sensitivity threshold",
                        "e-",
                        t.sensitivity_threshold_e.clone(),
                    ),
                    Row::new(
                        "sensitivity_threshold_photons_per_px",
                        "Absolute sensitivity threshold",
                        "photons/px",
                        t.sensitivity_threshold_photons_per_px.clone(),
                    ),
                ],
            },
            Section {
                title: "Linearity".into(),
                rows: vec![
                    Row::new(
                        "linearity_error_min_percent",
                        "Linearity error LE_min",
                        "%",
                        t.linearity_error_min_percent.clone(),
                    ),
                    Row::new(
                        "linearity_error_max_percent",
                        "Linearity error LE_max",
                        "%",
                        t.linearity_error_max_percent.clone(),
                    ),
                ],
            },
            Section {
                title: "Dark current".into(),
                rows: vec![
                    Row::new(
                        "dark_current_mean_e_per_s",
                        "Dark current, from the mean",
                        "e-/s",
                        t.dark_current_mean_e_per_s.clone(),
                    ),
                    Row::new(
                        "dark_current_variance_e_per_s",
                        "Dark current, from the variance",
                        "e-/s",
                        t.dark_current_variance_e_per_s.clone(),
                    ),
                ],
            },
        ];
        if let Some(s) = &self.spatial {
            sections.push(spatial_section(s));
        }
        let mut figures = temporal_figures(t);
        if let Some(s) = &self.spatial {
            figures.extend(spatial_figures(s));
        }
        let mut notes: Vec<String> = t.rules_broken.clone();
        if dataset.spatial_bright.is_none() || dataset.spatial_dark.is_none() {
            notes.push("the dataset has no spatial stacks: DSNU, PRNU, spectrograms, histograms and defects are not computed".into());
        }
        if t.dark_noise_floored {
            notes.push("the temporal dark variance is below the standard's 0.24 DN² floor (quantisation dominates): σ_y.dark is floored and the numbers derived from it are upper bounds".into());
        }
        Sheet {
            title: format!("EMVA 1288 datasheet: {}", dataset_name(dataset)),
            source: dataset.source.clone(),
            sections,
            figures,
            notes,
        }
    }
}

/// The dataset's name: its descriptor's folder, or the file's stem.
fn dataset_name(dataset: &EmvaDataset) -> String {
    let stem = dataset
        .source
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned());
    let folder = dataset
        .source
        .parent()
        .and_then(|p| p.file_name())
        .map(|s| s.to_string_lossy().into_owned());
    folder.or(stem).unwrap_or_else(|| "dataset".into())
}

/// DSNU, PRNU (total and the release 4.0 split) and defect counts.
fn spatial_section(s: &SpatialResult) -> Section {
    let mut rows = Vec::new();
    // Keys name the part before the unit: dsnu_row_e, prnu_pixel_percent.
    let mut parts = |key: &str, unit_key: &str, label: &str, unit: &str, p: &Parts<Quantity>| {
        for (part, what, q) in [
            ("", "", &p.total),
            ("_row", ", row part", &p.row),
            ("_col", ", column part", &p.col),
            ("_pixel", ", pixel part", &p.pixel),
        ] {
            rows.push(Row::new(
                &format!("{key}{part}_{unit_key}"),
                &format!("{label}{what}"),
                unit,
                q.clone(),
            ));
        }
    };
    parts("dsnu", "dn", "DSNU_1288", "DN", &s.dsnu_dn);
    parts("dsnu", "e", "DSNU_1288", "e-", &s.dsnu_e);
    parts("prnu", "percent", "PRNU_1288", "%", &s.prnu_percent);
    rows.push(Row::new(
        "bright_stack_saturation_fraction",
        "Bright spatial stack, signal / saturation's",
        "",
        s.saturation_fraction.clone(),
    ));
    let count = |n: u64| Quantity::ok(n as f64, f64::NAN);
    let d = &s.defects_dark;
    let b = &s.defects_bright;
    rows.push(Row::new(
        "defects_hot_px",
        &format!(
            "Hot pixels (dark image, > {} robust SD above the median)",
            d.factor
        ),
        "px",
        count(d.above),
    ));
    rows.push(Row::new(
        "defects_cold_px",
        &format!("Cold pixels (dark image, > {} robust SD below)", d.factor),
        "px",
        count(d.below),
    ));
    rows.push(Row::new(
        "defects_bright_px",
        &format!(
            "Bright pixels (PRNU image, > {} robust SD above its 5x5 median)",
            b.factor
        ),
        "px",
        count(b.above),
    ));
    rows.push(Row::new(
        "defects_dim_px",
        &format!(
            "Dim or dead pixels (PRNU image, > {} robust SD below)",
            b.factor
        ),
        "px",
        count(b.below),
    ));
    Section {
        title: "Spatial non-uniformity and defects".into(),
        rows,
    }
}

fn curve(name: &str, x: Vec<f64>, y: Vec<f64>, markers: bool) -> Curve {
    Curve {
        name: name.into(),
        x,
        y,
        y_se: None,
        markers,
    }
}

fn figure(
    stem: &str,
    title: &str,
    x_label: &str,
    y_label: &str,
    log: (bool, bool),
    curves: Vec<Curve>,
    caption: &str,
) -> Figure {
    Figure {
        stem: stem.into(),
        title: title.into(),
        x_label: x_label.into(),
        y_label: y_label.into(),
        log_x: log.0,
        log_y: log.1,
        curves,
        caption: caption.into(),
    }
}

/// Photon transfer, SNR, linearity and its deviation.
fn temporal_figures(t: &TemporalResult) -> Vec<Figure> {
    // The photon transfer shows every point (saturation is where its variance falls); the
    // SNR and linearity curves end at saturation, as the standard draws them.
    let all = &t.points;
    let p = &all[..(t.saturation_index + 1).min(all.len())];
    let col = |f: fn(&CurvePoint) -> f64| p.iter().map(f).collect::<Vec<f64>>();
    let col_all = |f: fn(&CurvePoint) -> f64| all.iter().map(f).collect::<Vec<f64>>();
    let signal = col(|c| c.signal_dn);
    let fit = |range: [usize; 2]| range[0].min(p.len())..(range[1] + 1).min(p.len());
    let k = t.system_gain_dn_per_e.value;
    let in_fit = fit(t.sensitivity_fit);
    let ptc = Curve {
        name: "measured".into(),
        x: col_all(|c| c.signal_dn),
        y: col_all(|c| c.variance_dn2),
        y_se: Some(col_all(|c| c.variance_se_dn2)),
        markers: true,
    };
    let fit_x: Vec<f64> = signal[in_fit.clone()].to_vec();
    let mut ptc_curves = vec![ptc];
    if k.is_finite() && !fit_x.is_empty() {
        ptc_curves.push(curve(
            &format!("fit, K = {k:.4} DN/e-"),
            fit_x.clone(),
            fit_x.iter().map(|x| k * x).collect(),
            false,
        ));
    }
    let photons: Option<Vec<f64>> = p.iter().map(|c| c.photons_per_px).collect();
    let (x_light, x_label) = match &photons {
        Some(ph) => (ph.clone(), "mean photons per pixel μ_p"),
        None => (col(|c| c.exposure_s), "exposure time (s)"),
    };
    let mut figures = vec![
        figure(
            "photon_transfer",
            "Photon transfer",
            "signal μ_y − μ_y.dark (DN)",
            "variance σ²_y − σ²_y.dark (DN²)",
            (false, false),
            ptc_curves,
            "Temporal variance of each bright pair (drift corrected, dark pair's subtracted) against its mean signal; the line is the fit over the standard's range (up to 70 % of saturation) whose slope is the system gain K.",
        ),
        figure(
            "snr",
            "Signal-to-noise ratio",
            x_label,
            "SNR",
            (true, true),
            vec![
                curve("measured", x_light.clone(), col(|c| c.snr), true),
                curve("linear model (K, σ_d)", x_light.clone(), col(|c| c.snr_model), false),
            ],
            "Measured SNR of each point (signal over the bright pair's temporal standard deviation) and the linear camera model's.",
        ),
        figure(
            "linearity",
            "Linearity",
            x_label,
            "signal μ_y − μ_y.dark (DN)",
            (false, false),
            vec![curve("measured", x_light.clone(), signal.clone(), true)],
            "Mean signal above dark against the light given to the sensor.",
        ),
    ];
    if t.linearity_fit.is_some() {
        figures.push(figure(
            "linearity_deviation",
            "Deviation from linearity",
            x_label,
            "deviation (%)",
            (false, false),
            vec![curve("measured", x_light, col(|c| c.linearity_deviation_percent), true)],
            "Relative deviation of each point from the linear fit over 5–95 % of saturation; LE_min and LE_max are its extremes in that range.",
        ));
    }
    figures
}

/// Spectrograms, histograms and profiles of the spatial stacks.
fn spatial_figures(s: &SpatialResult) -> Vec<Figure> {
    let mut figures = Vec::new();
    for (stem, name, spec) in [
        (
            "spectrogram_horizontal",
            "Horizontal",
            &s.spectrogram_horizontal,
        ),
        ("spectrogram_vertical", "Vertical", &s.spectrogram_vertical),
    ] {
        let f = &spec.frequency_cycles_per_px;
        let flat = |v: f64| vec![v; f.len()];
        figures.push(figure(
            &format!("{stem}_dsnu"),
            &format!("{name} spectrogram, DSNU (dark image)"),
            "spatial frequency (cycles/px)",
            "standard deviation (DN)",
            (false, true),
            vec![
                curve("dark image", f.clone(), spec.dsnu_dn.clone(), false),
                curve("temporal noise of the averaged image", f.clone(), flat(spec.temporal_dark_dn), false),
            ],
            "Square root of the power spectrum of the averaged dark image; white non-uniformity is flat, periodic patterns are peaks.",
        ));
        figures.push(figure(
            &format!("{stem}_prnu"),
            &format!("{name} spectrogram, PRNU (bright − dark image)"),
            "spatial frequency (cycles/px)",
            "standard deviation (% of the mean signal)",
            (false, true),
            vec![
                curve("bright − dark image", f.clone(), spec.prnu_percent.clone(), false),
                curve("temporal noise of the averaged image", f.clone(), flat(spec.temporal_bright_percent), false),
            ],
            "Square root of the power spectrum of the averaged bright minus dark image, relative to its mean.",
        ));
    }
    for (stem, title, h, acc) in [
        (
            "histogram_dsnu",
            "Dark image",
            &s.histogram_dsnu,
            &s.histogram_dsnu_accumulated,
        ),
        (
            "histogram_prnu",
            "Bright − dark image (highpass filtered)",
            &s.histogram_prnu,
            &s.histogram_prnu_accumulated,
        ),
    ] {
        figures.push(figure(
            stem,
            &format!("Logarithmic histogram: {title}"),
            "deviation from the mean (DN)",
            "pixels per bin",
            (false, true),
            vec![
                curve("measured", h.bins_dn.clone(), h.counts.iter().map(|&c| c as f64).collect(), true),
                curve("normal distribution", h.bins_dn.clone(), h.model_counts.clone(), false),
            ],
            "Pixels per bin of the averaged image's deviation from its mean, against a normal distribution of the same mean and deviation; outliers stand above it.",
        ));
        figures.push(figure(
            &format!("{stem}_accumulated"),
            &format!("Accumulated histogram: {title}"),
            "absolute deviation from the mean (DN)",
            "pixels at or beyond (%)",
            (false, true),
            vec![curve(
                "measured",
                acc.bins_dn.clone(),
                acc.pixels_percent.clone(),
                false,
            )],
            "Share of pixels whose absolute deviation from the mean is at least each value.",
        ));
    }
    for (stem, title, x_label, dark, bright) in [
        (
            "profile_horizontal",
            "Horizontal profiles",
            "column",
            &s.profile_horizontal_dark,
            &s.profile_horizontal_bright,
        ),
        (
            "profile_vertical",
            "Vertical profiles",
            "row",
            &s.profile_vertical_dark,
            &s.profile_vertical_bright,
        ),
    ] {
        let x: Vec<f64> = (0..dark.mean_dn.len()).map(|i| i as f64).collect();
        figures.push(figure(
            stem,
            title,
            x_label,
            "value (DN)",
            (false, false),
            vec![
                curve("dark, mean", x.clone(), dark.mean_dn.clone(), false),
                curve("dark, middle line", x.clone(), dark.middle_dn.clone(), false),
                curve("bright − dark, mean", x.clone(), bright.mean_dn.clone(), false),
                curve("bright − dark, middle line", x, bright.middle_dn.clone(), false),
            ],
            "Mean over the image's other axis, and the middle line, of the averaged dark and bright minus dark images.",
        ));
    }
    figures
}

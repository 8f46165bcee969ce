//! The camera model of `camera` in the report (issue 31): the camera at the run's operating
//! point (frame rate, exposure, EM gain, temperature) term by term, its effective read noise
//! against frame rate at the operating gain with the campaign's exposures and the operating
//! point marked, and the `camera` readout simulated at the report's sub-aperture, spot and
//! signal. Present only when the report is given a camera model.

use std::fmt::Write as _;

use serde::Serialize;

use super::grid::Grid;
use super::html::{figure, fmt_effective, key, num};
use super::options::ReportOptions;
use super::point::OperatingPoint as SubapPoint;
use crate::camera::{CameraAt, CameraChoice, ExposureChoice, OperatingPoint, OperatingRange};
use crate::detector::ModelSpec;
use crate::effective::{effective_table, Status};
use crate::output::{html_escape as esc, write_csv_json, OutputDir};
use crate::plot::{LineChart, RefLine, Series, SeriesStyle};
use crate::progress::Observer;
use crate::Result;

/// Files of the section: the effective read noise against frame rate (table and chart).
pub(crate) const CAMERA_FILES: [&str; 4] = [
    "camera_noise.csv",
    "camera_noise.json",
    "camera_noise.png",
    "camera_noise.svg",
];

/// Frame rates the curve spans at least, Hz: from a slow wavefront sensor to a fast one (widened
/// to take in the campaign's exposures and the operating point).
pub const CURVE_RATES_HZ: (f64, f64) = (1.0, 3000.0);

/// Points of the curve per decade of frame rate.
const POINTS_PER_DECADE: f64 = 8.0;

/// The camera model at the operating point, as summary.json's `camera` records it. Noise and
/// charge are e- input-referred (the EM gain divided out); each is the median over the pixels,
/// so the effective read noise (the median of each pixel's total) is not the sum of the parts.
#[derive(Debug, Clone, Serialize)]
pub struct CameraSection {
    /// Frame rate, Hz (1 / exposure).
    pub frame_rate_hz: f64,
    /// Exposure of each frame, s.
    pub exposure_s: f64,
    /// How the exposure was chosen: `given`, `frame_rate` or `campaign_shortest`.
    pub exposure_choice: ExposureChoice,
    /// Commanded EM gain, e-/e-; null: no multiplication.
    pub em_gain_commanded: Option<f64>,
    /// Actual mean EM gain, e-/e- (1 without multiplication).
    pub em_gain: f64,
    /// Excess noise factor squared of the register at this gain (1 without multiplication).
    pub excess_noise_f2: f64,
    /// Sensor temperature, degrees C; null: the dark current's reference temperature.
    pub temperature_c: Option<f64>,
    /// The terms at the operating point (medians over the pixels).
    #[serde(flatten)]
    pub terms: Terms,
    /// The conditions the campaign measured the camera at; null when the model records none.
    pub campaign: Option<OperatingRange>,
    /// Where the operating point lies outside the campaign (empty: inside it).
    pub extrapolates: Vec<String>,
    /// The `camera` readout simulated at the report's sub-aperture, spot and signal; null when
    /// it could not run (`monte_carlo_note` says why).
    pub monte_carlo: Option<Simulated>,
    /// Why the readout was not simulated; null when it was.
    pub monte_carlo_note: Option<String>,
    /// The effective read noise against frame rate (camera_noise.csv/.json, not summary.json).
    #[serde(skip)]
    pub curve: Vec<CurveRow>,
    /// The EMVA 1288 datasheet of the campaign that measured the camera, when it has one
    /// (absent otherwise).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub datasheet: Option<super::datasheet::DatasheetLink>,
}

/// The camera's terms at one operating point: medians over the pixels, e- input-referred.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Terms {
    /// Read noise, e- rms.
    pub read_noise_e: f64,
    /// Dark current x exposure, e- per frame.
    pub dark_current_signal_e: f64,
    /// Clock-induced charge, e- per frame.
    pub cic_e: f64,
    /// Dark signal (dark current x exposure + CIC), e- per frame.
    pub dark_signal_e: f64,
    /// Shot noise of the dark signal (x the excess noise factor behind a register), e- rms.
    pub dark_shot_noise_e: f64,
    /// Row noise, e- rms.
    pub row_noise_e: f64,
    /// Column noise, e- rms.
    pub column_noise_e: f64,
    /// Frame-common noise, e- rms.
    pub frame_noise_e: f64,
    /// The effective read noise: the median of each pixel's total temporal noise, e- rms.
    pub effective_read_noise_e: f64,
}

impl Terms {
    /// The terms of the camera `at` an operating point; `cic_e` is the model's CIC per pixel
    /// (e-, None without CIC).
    pub fn of(at: &CameraAt, cic_e: Option<&[f64]>) -> Terms {
        let n = at.pixels();
        let median =
            |f: &dyn Fn(usize) -> f64| crate::stats::median(&(0..n).map(f).collect::<Vec<f64>>());
        let cic = |i: usize| cic_e.map_or(0.0, |c| c[i]);
        Terms {
            read_noise_e: median(&|i| at.read_noise_e[i]),
            dark_current_signal_e: median(&|i| at.dark_e[i] - cic(i)),
            cic_e: median(&cic),
            dark_signal_e: median(&|i| at.dark_e[i]),
            dark_shot_noise_e: median(&|i| (at.excess_noise_f2 * at.dark_e[i]).sqrt()),
            row_noise_e: at.row_noise_e,
            column_noise_e: at.column_noise_e,
            frame_noise_e: at.frame_noise_e,
            effective_read_noise_e: at.effective_read_noise_e(),
        }
    }
}

/// One frame rate of the curve (camera_noise.csv/.json).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CurveRow {
    /// Frame rate, Hz.
    pub frame_rate_hz: f64,
    /// Exposure, s (1 / frame rate).
    pub exposure_s: f64,
    /// `curve`, `campaign` (one of the campaign's dark exposures) or `operating_point`.
    pub point: &'static str,
    /// The terms there (medians over the pixels, e- input-referred).
    #[serde(flatten)]
    pub terms: Terms,
}

/// The `camera` readout simulated at the report's configuration.
#[derive(Debug, Clone, Serialize)]
pub struct Simulated {
    /// Sub-aperture size, px per side.
    pub subap_px: usize,
    /// Spot.
    pub spot: String,
    /// Signal, photons per sub-aperture.
    pub signal_photons: f64,
    /// Photo-electrons per photon (--qe-emccd behind an EM register that multiplies, else --qe).
    pub qe: f64,
    /// Mean radial centroid error R, px.
    pub r_px: f64,
    /// Its standard error, px.
    pub r_se_px: f64,
    /// Effective read noise (the constant Gaussian noise of the same R), e-; null when
    /// `status` gives no value.
    pub sigma_eff_e: Option<f64>,
    /// Its standard error, e-; null when `status` gives no value.
    pub sigma_eff_se_e: Option<f64>,
    /// How the value was settled (the effective-noise status words).
    pub status: Status,
}

/// The section when the report has a camera model: its terms, the curve (written with its
/// chart into `dir`) and the `camera` readout simulated at `op`; the names written.
pub(crate) fn section(
    o: &ReportOptions,
    grid: &Grid,
    op: &SubapPoint,
    dir: &OutputDir,
    observer: &dyn Observer,
) -> Result<Option<(CameraSection, Vec<&'static str>)>> {
    let Some(choice) = o.model_params.camera_choice.as_deref() else {
        return Ok(None);
    };
    let mut s = describe(choice)?;
    // The camera folder is the one whose camera.json the report reads.
    let camera_dir = o
        .model_input_paths
        .iter()
        .find(|p| {
            p.file_name()
                .is_some_and(|n| n == crate::camera::CAMERA_JSON)
        })
        .and_then(|p| p.parent());
    s.datasheet = camera_dir.and_then(|c| super::datasheet::find(c, &o.out_dir));
    match simulate(o, grid, op, &choice.at, observer)? {
        Ok(sim) => s.monte_carlo = Some(sim),
        Err(note) => s.monte_carlo_note = Some(note),
    }
    let [csv, json, png, svg] = CAMERA_FILES;
    write_csv_json(&s.curve, &dir.path(""), [csv, json])?;
    let chart = chart(&s)?;
    chart.save(dir.path(png))?;
    chart.save(dir.path(svg))?;
    Ok(Some((s, CAMERA_FILES.to_vec())))
}

/// The camera model of `choice` at its operating point and against frame rate (no
/// Monte-Carlo).
pub fn describe(choice: &CameraChoice) -> Result<CameraSection> {
    let at = &choice.at;
    let op = at.point;
    let cic = cic_per_pixel(choice);
    let terms = Terms::of(at, cic.as_deref());
    Ok(CameraSection {
        frame_rate_hz: 1.0 / op.exposure_s,
        exposure_s: op.exposure_s,
        exposure_choice: choice.exposure,
        em_gain_commanded: op.em_gain,
        em_gain: at.em_gain,
        excess_noise_f2: at.excess_noise_f2,
        temperature_c: op.temperature_c,
        terms,
        campaign: choice.model.campaign.clone(),
        extrapolates: choice.extrapolates.clone(),
        monte_carlo: None,
        monte_carlo_note: None,
        curve: curve(choice, cic.as_deref())?,
        datasheet: None,
    })
}

/// The model's CIC of each pixel (e-, a pixel without a value: the map's median), as the
/// camera at an operating point counts it; None without CIC.
fn cic_per_pixel(choice: &CameraChoice) -> Option<Vec<f64>> {
    let map = choice.model.cic_e.as_ref()?;
    let finite: Vec<f64> = map.data.iter().copied().filter(|v| v.is_finite()).collect();
    let fill = crate::stats::median(&finite);
    Some(
        map.data
            .iter()
            .map(|v| if v.is_finite() { *v } else { fill })
            .collect(),
    )
}

/// The frame rates of the curve, Hz, ascending, each with its kind: [`CURVE_RATES_HZ`]
/// (widened to the campaign's exposures and the operating point) at [`POINTS_PER_DECADE`], the
/// campaign's exposures and the operating point.
fn rates(choice: &CameraChoice) -> Vec<(f64, &'static str)> {
    let op_rate = 1.0 / choice.at.point.exposure_s;
    let campaign: Vec<f64> = choice.model.campaign.as_ref().map_or_else(Vec::new, |r| {
        r.exposures_s.iter().map(|t| 1.0 / t).collect()
    });
    let marked = campaign.iter().copied().chain([op_rate]);
    let (lo, hi) = marked.fold(CURVE_RATES_HZ, |(lo, hi), f| (lo.min(f), hi.max(f)));
    let steps = ((hi / lo).log10() * POINTS_PER_DECADE).ceil().max(1.0) as usize;
    let mut out: Vec<(f64, &str)> = (0..=steps)
        .map(|k| (lo * (hi / lo).powf(k as f64 / steps as f64), "curve"))
        .collect();
    out.extend(campaign.iter().map(|&f| (f, "campaign")));
    out.push((op_rate, "operating_point"));
    out.sort_by(|a, b| a.0.total_cmp(&b.0));
    out
}

/// The effective read noise and its terms at each rate of [`rates`], at the operating
/// point's EM gain and temperature.
fn curve(choice: &CameraChoice, cic: Option<&[f64]>) -> Result<Vec<CurveRow>> {
    let op = choice.at.point;
    rates(choice)
        .into_iter()
        .map(|(f, point)| {
            let exposure_s = 1.0 / f;
            let at = if point == "operating_point" {
                (*choice.at).clone()
            } else {
                choice.model.at(OperatingPoint { exposure_s, ..op })?
            };
            Ok(CurveRow {
                frame_rate_hz: f,
                exposure_s,
                point,
                terms: Terms::of(&at, cic),
            })
        })
        .collect()
}

/// The `camera` readout at the report's sub-aperture, spot and signal (the configuration of
/// the headline numbers, same seed); Err: why it cannot run (a camera smaller than the
/// sub-aperture).
fn simulate(
    o: &ReportOptions,
    grid: &Grid,
    op: &SubapPoint,
    at: &CameraAt,
    observer: &dyn Observer,
) -> Result<std::result::Result<Simulated, String>> {
    let (rows, cols) = at.shape;
    if rows < op.subap_px || cols < op.subap_px {
        return Ok(Err(format!(
            "not simulated: the camera model is {rows}x{cols} px, smaller than the {}x{} px \
             sub-aperture",
            op.subap_px, op.subap_px
        )));
    }
    let qe = if at.stages.is_some() {
        o.qe_emccd
    } else {
        o.qe
    };
    let cfg = grid.config(op.subap_px, op.spot, op.signal_photons, qe);
    let spec = ModelSpec::parse("camera")?;
    let records = effective_table(
        std::slice::from_ref(&cfg),
        &[spec],
        &o.model_params,
        &o.precision_in_use(),
        observer,
    )?;
    let e = &records[0].effective;
    let shown = matches!(
        e.status,
        Status::Ok | Status::Imprecise | Status::LowerBound
    ) && e.sigma_eff_e.is_finite();
    Ok(Ok(Simulated {
        subap_px: op.subap_px,
        spot: op.spot.label(),
        signal_photons: op.signal_photons,
        qe,
        r_px: e.r_px,
        r_se_px: e.r_se_px,
        sigma_eff_e: shown.then_some(e.sigma_eff_e),
        sigma_eff_se_e: shown.then_some(e.sigma_eff_se_e),
        status: e.status,
    }))
}

/// The operating point in words: rate, exposure, gain, temperature.
fn point_words(s: &CameraSection) -> String {
    let gain = match s.em_gain_commanded {
        Some(g) => format!("EM gain {g} commanded ({} actual)", num(s.em_gain, 1)),
        None => "no EM gain".into(),
    };
    let temperature = s.temperature_c.map_or_else(
        || "the dark current's reference temperature".to_string(),
        |t| format!("{t} °C"),
    );
    format!(
        "{} Hz ({} s exposure), {gain}, {temperature}",
        fmt_g(s.frame_rate_hz),
        fmt_g(s.exposure_s)
    )
}

/// A number in 3 significant digits (0 as 0), or a dash when it is not finite.
fn sig3(v: f64) -> String {
    if v == 0.0 {
        return "0".into();
    }
    let decimals = (2 - v.abs().log10().floor() as i32).max(0) as usize;
    num(v, decimals)
}

/// A number in at most 6 significant digits, without trailing zeros.
fn fmt_g(v: f64) -> String {
    if !v.is_finite() {
        return "–".into();
    }
    let digits = (5 - v.abs().log10().floor() as i32).max(0) as usize;
    let s = format!("{v:.digits$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// camera_noise.png/.svg: the effective read noise against frame rate (log axis) at the
/// operating gain, the campaign's exposures and the operating point marked, and the noise
/// without any dark signal as a reference line.
fn chart(s: &CameraSection) -> Result<LineChart> {
    let gain = s
        .em_gain_commanded
        .map_or("no EM gain".to_string(), |g| format!("EM gain {g}"));
    let mut chart = LineChart::new(
        format!("Camera model: effective read noise against frame rate, {gain}"),
        "frame rate (Hz)",
        "effective read noise (e- rms, input-referred)",
    );
    chart.log_x = true;
    let of = |kind: &'static str| -> Vec<(f64, f64)> {
        s.curve
            .iter()
            .filter(|r| kind.is_empty() || r.point == kind)
            .map(|r| (r.frame_rate_hz, r.terms.effective_read_noise_e))
            .collect()
    };
    chart
        .series
        .push(Series::new("camera model (median total noise)", of("")).styled(SeriesStyle::Line));
    if s.campaign.is_some() {
        chart.series.push(
            Series::new("campaign's dark exposures (measured)", of("campaign"))
                .styled(SeriesStyle::Markers),
        );
    }
    let extrapolated = if s.extrapolates.is_empty() {
        ""
    } else {
        ", extrapolated"
    };
    chart.series.push(
        Series::new(
            format!(
                "operating point: {} Hz{extrapolated}",
                fmt_g(s.frame_rate_hz)
            ),
            of("operating_point"),
        )
        .styled(SeriesStyle::Markers),
    );
    let t = &s.terms;
    let no_dark = (t.read_noise_e.powi(2)
        + t.row_noise_e.powi(2)
        + t.column_noise_e.powi(2)
        + t.frame_noise_e.powi(2))
    .sqrt();
    chart.reference.push(RefLine {
        y: no_dark,
        label: "no dark signal: read, row, column and frame noise".into(),
    });
    Ok(chart)
}

/// The section on the page.
pub(crate) fn section_html(h: &mut String, s: &CameraSection) {
    let t = &s.terms;
    h.push_str("<h2>The camera model at its operating point</h2>");
    let how = match s.exposure_choice {
        ExposureChoice::Given => "the one given (--exposure-s)",
        ExposureChoice::FrameRate => "1 / the frame rate given (--frame-rate-hz)",
        ExposureChoice::CampaignShortest => "by default the campaign's shortest dark exposure, the measured condition closest to AO operation (give --frame-rate-hz or --exposure-s for another)",
    };
    let _ = write!(
        h,
        "<p>The camera model of --camera at {}. The exposure is {}.</p>",
        esc(&point_words(s)),
        esc(how)
    );
    if !s.extrapolates.is_empty() {
        let _ = write!(h, "<p class=\"advice\">This operating point <b>extrapolates</b> beyond the campaign that measured the camera: {}. The model's terms scale there as they do inside it (dark current with exposure, CIC and noise with the gain curve), which the campaign has not checked.</p>", esc(&s.extrapolates.join("; ")));
    }
    h.push_str("<div class=\"keys\">");
    key(
        h,
        &format!("Effective read noise at {} Hz", fmt_g(s.frame_rate_hz)),
        &format!("{} e⁻", num(t.effective_read_noise_e, 3)),
    );
    if let Some(m) = &s.monte_carlo {
        key(
            h,
            &format!(
                "σ<sub>eff</sub> of the camera readout, {}×{} px, {}, {} photons",
                m.subap_px,
                m.subap_px,
                esc(&m.spot),
                m.signal_photons
            ),
            &fmt_effective(
                m.sigma_eff_e.unwrap_or(f64::NAN),
                m.sigma_eff_se_e.unwrap_or(f64::NAN),
                m.status,
            ),
        );
    }
    h.push_str("</div>");
    h.push_str("<p>Each term is the median over the pixels, in e⁻ input-referred (the EM gain divided out); the effective read noise is the median of each pixel's total temporal noise, so it is not the sum of the medians.</p><table><tr><th>term</th><th>value</th></tr>");
    let rows = [
        ("read noise (e⁻ rms)", t.read_noise_e),
        (
            "dark current × exposure (e⁻/frame)",
            t.dark_current_signal_e,
        ),
        ("clock-induced charge (e⁻/frame)", t.cic_e),
        ("dark signal (e⁻/frame)", t.dark_signal_e),
        ("its shot noise (e⁻ rms)", t.dark_shot_noise_e),
        ("row noise (e⁻ rms)", t.row_noise_e),
        ("column noise (e⁻ rms)", t.column_noise_e),
        ("frame-common noise (e⁻ rms)", t.frame_noise_e),
        ("effective read noise (e⁻ rms)", t.effective_read_noise_e),
        ("excess noise factor F² of the register", s.excess_noise_f2),
    ];
    for (name, v) in rows {
        let _ = write!(h, "<tr><td>{name}</td><td>{}</td></tr>", sig3(v));
    }
    h.push_str("</table>");
    match (&s.monte_carlo, &s.monte_carlo_note) {
        (Some(m), _) => {
            let _ = write!(h, "<p>The <code>camera</code> readout (random windows of the camera model at this operating point, the dark signal drawn and its mean taken off) at {}×{} px, {}, {} photons (QE {}): R = {} ± {} px, effective read noise σ<sub>eff</sub> {}. σ<sub>eff</sub> is the constant Gaussian read noise that gives the camera's centroid error, so it differs from the median total noise above: it also carries the spread of the pixels' noise, the dark signal's non-Gaussian shot noise{}.</p>", m.subap_px, m.subap_px, esc(&m.spot), m.signal_photons, m.qe, num(m.r_px, 4), num(m.r_se_px, 4), fmt_effective(m.sigma_eff_e.unwrap_or(f64::NAN), m.sigma_eff_se_e.unwrap_or(f64::NAN), m.status), if s.excess_noise_f2 > 1.0 { " and the register's excess noise, which multiplies the photons' shot-noise variance by F²" } else { "" });
        }
        (None, Some(note)) => {
            let _ = write!(
                h,
                "<p class=\"note\">The camera readout: {}.</p>",
                esc(note)
            );
        }
        _ => {}
    }
    let marks = if s.campaign.is_some() {
        "the campaign's dark exposures and the operating point are marked"
    } else {
        "the operating point is marked (the model records no campaign)"
    };
    figure(h, "camera_noise.png", "Effective read noise of the camera model against frame rate", &format!("Effective read noise (median over the pixels of the total temporal noise, e⁻ input-referred) of the camera model against frame rate (exposure = 1 / rate) at the operating point's EM gain and temperature; {marks}; the dashed line is the noise without any dark signal. Data in camera_noise.csv/.json (every term at every rate)."));
    if let Some(d) = &s.datasheet {
        super::datasheet::section_html(h, d);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calib::{Map, Unit};
    use crate::camera::{CameraModel, DarkCurrent, EmRegisterModel};

    /// A 2x2 EMCCD camera with a campaign at 0.01, 0.1 s and gains 100, 400.
    fn model() -> CameraModel {
        CameraModel::new(
            Map::filled(2, 2, 100.0, Unit::Adu),
            2.0,
            Map::new(2, 2, vec![40.0, 50.0, 60.0, 70.0], Unit::Electrons),
            16,
        )
        .unwrap()
        .with_common_noise(3.0, 4.0, 12.0)
        .unwrap()
        .with_dark_current(DarkCurrent {
            map_e_per_s: Map::new(2, 2, vec![1.0, 2.0, 3.0, 4.0], Unit::Flags),
            reference_temperature_c: None,
            doubling_temperature_c: None,
        })
        .unwrap()
        .with_cic(Map::new(
            2,
            2,
            vec![0.01, 0.02, f64::NAN, 0.04],
            Unit::Electrons,
        ))
        .unwrap()
        .with_register(EmRegisterModel {
            stages: 604,
            gain_curve: vec![],
            serial_cic_e: None,
        })
        .unwrap()
        .with_campaign(OperatingRange {
            exposures_s: vec![0.01, 0.1],
            em_gains: vec![100.0, 400.0],
            temperatures_c: vec![],
        })
        .unwrap()
    }

    #[test]
    fn the_section_states_the_camera_at_its_operating_point() {
        let choice = CameraChoice::new(model(), None, Some(200.0), None).unwrap();
        let s = describe(&choice).unwrap();
        let at = model()
            .at(OperatingPoint {
                exposure_s: 0.01,
                em_gain: Some(200.0),
                temperature_c: None,
            })
            .unwrap();
        assert_eq!(s.exposure_choice, ExposureChoice::CampaignShortest);
        assert_eq!((s.exposure_s, s.frame_rate_hz), (0.01, 100.0));
        assert!(s.extrapolates.is_empty());
        let t = s.terms;
        assert_eq!(t.effective_read_noise_e, at.effective_read_noise_e());
        // Read noise 40..70 e- output-referred over gain 200: median 55 / 200.
        assert!((t.read_noise_e - 55.0 / 200.0).abs() < 1e-12);
        // CIC: the pixel without a value takes the map's median (0.02).
        assert!((t.cic_e - 0.02).abs() < 1e-12);
        // Dark current x 0.01 s: median of 0.01..0.04.
        assert!((t.dark_current_signal_e - 0.025).abs() < 1e-12);
        let dark = crate::stats::median(&at.dark_e);
        assert!((t.dark_signal_e - dark).abs() < 1e-12);
        let shot: Vec<f64> = at
            .dark_e
            .iter()
            .map(|d| (at.excess_noise_f2 * d).sqrt())
            .collect();
        assert!((t.dark_shot_noise_e - crate::stats::median(&shot)).abs() < 1e-12);
        assert_eq!(
            (t.row_noise_e, t.column_noise_e, t.frame_noise_e),
            (3.0 / 200.0, 4.0 / 200.0, 12.0 / 200.0)
        );
        // The curve spans 1 Hz to 3 kHz, marks both campaign exposures and the point, and its
        // values are the camera's at each rate.
        let first = &s.curve[0];
        let last = &s.curve[s.curve.len() - 1];
        assert_eq!((first.frame_rate_hz, last.frame_rate_hz), (1.0, 3000.0));
        let marked: Vec<(f64, &str)> = s
            .curve
            .iter()
            .filter(|r| r.point != "curve")
            .map(|r| (r.frame_rate_hz, r.point))
            .collect();
        assert_eq!(
            marked,
            [
                (10.0, "campaign"),
                (100.0, "campaign"),
                (100.0, "operating_point")
            ]
        );
        for r in &s.curve {
            let at = model()
                .at(OperatingPoint {
                    exposure_s: r.exposure_s,
                    em_gain: Some(200.0),
                    temperature_c: None,
                })
                .unwrap();
            assert_eq!(r.terms.effective_read_noise_e, at.effective_read_noise_e());
        }
        // More dark signal at lower rates: the noise falls with the rate.
        assert!(first.terms.effective_read_noise_e > last.terms.effective_read_noise_e);
        let mut h = String::new();
        section_html(&mut h, &s);
        assert!(
            h.contains("100 Hz (0.01 s exposure), EM gain 200 commanded"),
            "{h}"
        );
        assert!(
            h.contains("The exposure is by default the campaign's shortest dark exposure"),
            "{h}"
        );
        assert!(
            h.contains("<td>0.0250</td>"),
            "dark current x exposure: {h}"
        );
        assert!(!h.contains("extrapolates"), "{h}");
    }

    #[test]
    fn a_point_beyond_the_campaign_says_it_extrapolates() {
        let exposure = Some((1.0 / 2000.0, ExposureChoice::FrameRate));
        let choice = CameraChoice::new(model(), exposure, Some(1000.0), None).unwrap();
        let notices = choice.notices();
        assert_eq!(notices.len(), 1, "{notices:?}");
        assert!(
            notices[0].contains(
                "extrapolates beyond the campaign that measured it: exposure \
                 0.0005 s (2000 Hz) outside the campaign's darks (0.01 to 0.1 s); EM gain 1000 \
                 outside"
            ),
            "{notices:?}"
        );
        let s = describe(&choice).unwrap();
        assert_eq!(s.extrapolates.len(), 2);
        let mut h = String::new();
        section_html(&mut h, &s);
        assert!(h.contains("<b>extrapolates</b> beyond the campaign"), "{h}");
        let chart = chart(&s).unwrap();
        assert!(
            chart
                .series
                .iter()
                .any(|x| x.name == "operating point: 2000 Hz, extrapolated"),
            "{:?}",
            chart.series
        );
        // The default exposure is told too, and a model without a campaign needs one.
        let choice = CameraChoice::new(model(), None, Some(200.0), None).unwrap();
        let notices = choice.notices();
        assert_eq!(notices.len(), 1, "{notices:?}");
        assert!(
            notices[0].contains("exposure 0.01 s (100 Hz), the campaign's shortest dark"),
            "{notices:?}"
        );
        let bare = CameraModel {
            campaign: None,
            ..model()
        };
        let e = CameraChoice::new(bare, None, Some(200.0), None).unwrap_err();
        assert!(e.to_string().contains("records no campaign"), "{e}");
    }
}

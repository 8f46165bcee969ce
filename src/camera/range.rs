//! [`OperatingRange`]: the conditions a campaign measured the camera at (camera.json's
//! `campaign`), the exposure a run takes from it when none is given, and whether an
//! operating point lies outside it (the model then extrapolates: allowed, and said).

use serde::{Deserialize, Serialize};

use super::point::OperatingPoint;
use crate::{Error, Result};

/// The dark conditions of the campaign that measured a camera model, each list ascending and
/// without repeats.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OperatingRange {
    /// Exposure times of the darks, s (at least one).
    pub exposures_s: Vec<f64>,
    /// Commanded EM gains of the darks, e-/e-; empty without an EM register.
    pub em_gains: Vec<f64>,
    /// Sensor temperatures of the darks, degrees C; empty when the campaign did not record them.
    pub temperatures_c: Vec<f64>,
}

/// How the exposure of a run's operating point was chosen.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ExposureChoice {
    /// `exposure_s` was given.
    Given,
    /// 1 / `frame_rate_hz`, the rate given.
    FrameRate,
    /// Neither was given: the campaign's shortest dark exposure ([`OperatingRange::default_exposure_s`]).
    CampaignShortest,
}

impl ExposureChoice {
    /// The choice in words, for a line of output.
    pub fn describe(self) -> &'static str {
        match self {
            ExposureChoice::Given => "the exposure given",
            ExposureChoice::FrameRate => "1 / the frame rate given",
            ExposureChoice::CampaignShortest => {
                "the campaign's shortest dark exposure (default: no --exposure-s or \
                 --frame-rate-hz given)"
            }
        }
    }
}

impl OperatingRange {
    /// The exposure a run takes when neither an exposure nor a frame rate is given, s: the
    /// shortest dark exposure of the campaign. An AO camera runs at the highest frame rate the
    /// campaign reached, and this is the closest measured condition to it (no extrapolation).
    pub fn default_exposure_s(&self) -> f64 {
        self.exposures_s[0]
    }

    /// Every check of the range: each list finite, ascending without repeats, exposures > 0
    /// (at least one), gains 1 or more, temperatures from -273.15 to 200 degrees C.
    pub fn check(&self) -> Result<()> {
        if self.exposures_s.is_empty() {
            return Err(bad("campaign.exposures_s", "empty: a campaign has darks"));
        }
        type Ok = fn(f64) -> bool;
        let lists: [(&str, &[f64], Ok, &str); 3] = [
            (
                "campaign.exposures_s",
                &self.exposures_s,
                |v| v > 0.0 && v <= super::MAX_EXPOSURE_S,
                "s",
            ),
            (
                "campaign.em_gains",
                &self.em_gains,
                |v| (1.0..=crate::detector::register::MAX_EM_GAIN).contains(&v),
                "e-/e-",
            ),
            (
                "campaign.temperatures_c",
                &self.temperatures_c,
                |v| (-273.15..=200.0).contains(&v),
                "degrees C",
            ),
        ];
        for (field, values, ok, unit) in lists {
            for (i, &v) in values.iter().enumerate() {
                if !(v.is_finite() && ok(v)) {
                    return Err(bad(
                        field,
                        format!("value {i} ({v} {unit}) is out of range"),
                    ));
                }
                if i > 0 && v <= values[i - 1] {
                    return Err(bad(
                        field,
                        format!("must ascend without repeats ({v} after {})", values[i - 1]),
                    ));
                }
            }
        }
        Ok(())
    }

    /// Where `op` lies outside this range, one phrase per quantity (empty: inside it). An EM
    /// gain of None is no multiplication (gain 1); a temperature of None is the dark current's
    /// reference, taken as measured.
    pub fn extrapolations(&self, op: &OperatingPoint) -> Vec<String> {
        let mut out = Vec::new();
        let outside =
            |v: f64, list: &[f64]| !list.is_empty() && (v < list[0] || v > list[list.len() - 1]);
        if outside(op.exposure_s, &self.exposures_s) {
            out.push(format!(
                "exposure {} s ({} Hz) outside the campaign's darks ({})",
                op.exposure_s,
                rate(op.exposure_s),
                span(&self.exposures_s, "s")
            ));
        }
        let gain = op.em_gain.unwrap_or(1.0);
        if outside(gain, &self.em_gains) {
            let what = op
                .em_gain
                .map_or("no EM gain".to_string(), |g| format!("EM gain {g}"));
            out.push(format!(
                "{what} outside the campaign's darks (commanded {})",
                span(&self.em_gains, "")
            ));
        }
        if let Some(t) = op.temperature_c {
            if outside(t, &self.temperatures_c) {
                out.push(format!(
                    "temperature {t} C outside the campaign's darks ({})",
                    span(&self.temperatures_c, "C")
                ));
            }
        }
        out
    }
}

/// "a to b unit" (or "a unit" for one value).
pub(super) fn span(values: &[f64], unit: &str) -> String {
    let unit = if unit.is_empty() {
        String::new()
    } else {
        format!(" {unit}")
    };
    match values {
        [one] => format!("{one}{unit}"),
        [first, .., last] => format!("{first} to {last}{unit}"),
        [] => "none".into(),
    }
}

/// The frame rate of an exposure, Hz, rounded for a message.
pub(super) fn rate(exposure_s: f64) -> String {
    let f = 1.0 / exposure_s;
    format!("{}", (f * 1e3).round() / 1e3)
}

fn bad(field: &str, message: impl Into<String>) -> Error {
    Error::invalid(field, message)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn range() -> OperatingRange {
        OperatingRange {
            exposures_s: vec![0.01, 0.1, 0.5],
            em_gains: vec![50.0, 200.0, 800.0],
            temperatures_c: vec![],
        }
    }

    fn at(exposure_s: f64, em_gain: Option<f64>, temperature_c: Option<f64>) -> OperatingPoint {
        OperatingPoint {
            exposure_s,
            em_gain,
            temperature_c,
        }
    }

    #[test]
    fn the_default_exposure_is_the_shortest_dark() {
        assert_eq!(range().default_exposure_s(), 0.01);
    }

    #[test]
    fn a_point_outside_the_campaign_is_named_by_quantity() {
        let r = range();
        assert!(r.extrapolations(&at(0.1, Some(400.0), None)).is_empty());
        assert!(r
            .extrapolations(&at(0.01, Some(50.0), Some(-60.0)))
            .is_empty());
        let out = r.extrapolations(&at(0.001, Some(1000.0), None));
        assert_eq!(
            out,
            [
                "exposure 0.001 s (1000 Hz) outside the campaign's darks (0.01 to 0.5 s)",
                "EM gain 1000 outside the campaign's darks (commanded 50 to 800)",
            ]
        );
        let out = r.extrapolations(&at(1.0, None, None));
        assert_eq!(out.len(), 2, "{out:?}");
        assert!(out[1].starts_with("no EM gain outside"), "{out:?}");
        let t = OperatingRange {
            temperatures_c: vec![-20.0],
            ..range()
        };
        let out = t.extrapolations(&at(0.1, Some(100.0), Some(-10.0)));
        assert_eq!(
            out,
            ["temperature -10 C outside the campaign's darks (-20 C)"]
        );
    }

    #[test]
    fn bad_ranges_are_refused_naming_the_list() {
        for (r, field) in [
            (
                OperatingRange {
                    exposures_s: vec![],
                    ..range()
                },
                "campaign.exposures_s",
            ),
            (
                OperatingRange {
                    exposures_s: vec![0.1, 0.01],
                    ..range()
                },
                "campaign.exposures_s",
            ),
            (
                OperatingRange {
                    em_gains: vec![0.5],
                    ..range()
                },
                "campaign.em_gains",
            ),
            (
                OperatingRange {
                    temperatures_c: vec![f64::NAN],
                    ..range()
                },
                "campaign.temperatures_c",
            ),
        ] {
            match r.check() {
                Err(Error::Usage { field: f, .. }) => assert_eq!(f, field),
                other => panic!("{r:?}: {other:?}"),
            }
        }
        assert!(range().check().is_ok());
    }
}

//! [`CameraChoice`]: a camera model read for a run at the operating point the run chose, the
//! exposure taken from the campaign's range when none is given, and what the run is told.

use std::sync::Arc;

use super::model::CameraModel;
use super::operating::CameraAt;
use super::point::OperatingPoint;
use super::range::{rate, ExposureChoice};
use crate::{Error, Result};

/// A camera model read for a run and the operating point the run chose for it.
#[derive(Debug, Clone)]
pub struct CameraChoice {
    /// The camera model.
    pub model: Arc<CameraModel>,
    /// The camera at the chosen operating point.
    pub at: Arc<CameraAt>,
    /// How the exposure was chosen.
    pub exposure: ExposureChoice,
    /// Where the point lies outside the campaign's range (empty: inside it, or no range
    /// recorded).
    pub extrapolates: Vec<String>,
}

impl CameraChoice {
    /// `model` at `exposure` (s, and how it was chosen; None: the campaign's default),
    /// commanded `em_gain` and `temperature_c`; refused when no exposure is given and the model
    /// records no campaign, or when the model refuses the point ([`CameraModel::at`]).
    pub fn new(
        model: CameraModel,
        exposure: Option<(f64, ExposureChoice)>,
        em_gain: Option<f64>,
        temperature_c: Option<f64>,
    ) -> Result<CameraChoice> {
        let (exposure_s, choice) = match (exposure, &model.campaign) {
            (Some(given), _) => given,
            (None, Some(range)) => (range.default_exposure_s(), ExposureChoice::CampaignShortest),
            (None, None) => {
                return Err(Error::invalid(
                    "exposure_s",
                    "the camera model is read at an operating point: give `exposure_s` (s) or \
                     `frame_rate_hz` (the exposure is then 1 / rate); this model records no \
                     campaign to take a default exposure from",
                ))
            }
        };
        let point = OperatingPoint {
            exposure_s,
            em_gain,
            temperature_c,
        };
        let at = model.at(point)?;
        let extrapolates = model
            .campaign
            .as_ref()
            .map_or_else(Vec::new, |r| r.extrapolations(&point));
        Ok(CameraChoice {
            model: Arc::new(model),
            at: Arc::new(at),
            exposure: choice,
            extrapolates,
        })
    }

    /// What a run should be told of the choice, one message each: the default exposure taken
    /// from the campaign, and an operating point beyond the campaign's range.
    pub fn notices(&self) -> Vec<String> {
        let op = self.at.point;
        let mut out = Vec::new();
        if self.exposure == ExposureChoice::CampaignShortest {
            out.push(format!(
                "camera model: no `exposure_s` or `frame_rate_hz` given: exposure {} s ({} Hz), \
                 the campaign's shortest dark exposure",
                op.exposure_s,
                rate(op.exposure_s)
            ));
        }
        if !self.extrapolates.is_empty() {
            out.push(format!(
                "camera model: the operating point extrapolates beyond the campaign that \
                 measured it: {}",
                self.extrapolates.join("; ")
            ));
        }
        out
    }
}

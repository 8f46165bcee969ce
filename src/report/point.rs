//! The operating point of a report's headline numbers: one sub-aperture size, spot and signal,
//! given by the caller (`8,airy:2,50`) or the default, simulated whether or not it is in the grid.

use crate::spot::Spot;
use crate::{Error, Result};

/// The configuration of a report's headline numbers.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OperatingPoint {
    /// Sub-aperture size (px per side).
    pub subap_px: usize,
    /// Spot.
    pub spot: Spot,
    /// Signal (photons per sub-aperture).
    pub signal_photons: f64,
}

impl Default for OperatingPoint {
    /// 8x8 px, an Airy spot of first-minimum diameter 2 px, 50 photons.
    fn default() -> Self {
        OperatingPoint {
            subap_px: 8,
            spot: Spot::Airy { diameter_px: 2.0 },
            signal_photons: 50.0,
        }
    }
}

impl OperatingPoint {
    /// The default as typed: `8,airy:2,50`.
    pub const DEFAULT_TEXT: &'static str = "8,airy:2,50";

    /// Parse `SUBAP,SPOT,SIGNAL`: px per side, `airy:D` or `gauss:SX,SY` (px), photons per
    /// sub-aperture (e.g. `8,airy:2,50`, `12,gauss:1.5,1.5,200`). Errors name `operating_point`.
    pub fn parse(text: &str) -> Result<OperatingPoint> {
        let bad = |why: String| {
            Error::invalid(
                "operating_point",
                format!("{text:?}: {why}; expected SUBAP,SPOT,SIGNAL, e.g. 8,airy:2,50"),
            )
        };
        let (subap, rest) = text
            .trim()
            .split_once(',')
            .ok_or_else(|| bad("no comma".into()))?;
        let (spot, signal) = rest
            .rsplit_once(',')
            .ok_or_else(|| bad("three parts are needed".into()))?;
        let subap_px: usize = subap
            .trim()
            .parse()
            .map_err(|_| bad(format!("{subap:?} is not a whole number of px")))?;
        let signal_photons: f64 = signal
            .trim()
            .parse()
            .map_err(|_| bad(format!("{signal:?} is not a number of photons")))?;
        let spot = Spot::parse(spot.trim()).map_err(|e| bad(usage_message(e)))?;
        Ok(OperatingPoint {
            subap_px,
            spot,
            signal_photons,
        })
    }

    /// The point as typed (`8,airy:2,50`): [`OperatingPoint::parse`] reads it back.
    pub fn text(&self) -> String {
        format!(
            "{},{},{}",
            self.subap_px,
            self.spot.label(),
            self.signal_photons
        )
    }

    /// The point in words: "8x8 px, airy:2, 50 photons".
    pub fn describe(&self) -> String {
        format!(
            "{}x{} px, {}, {} photons",
            self.subap_px,
            self.subap_px,
            self.spot.label(),
            self.signal_photons
        )
    }

    /// An error of this point's configuration (a sub-aperture, spot or signal out of range),
    /// named as an error of `operating_point`.
    pub(crate) fn blame(&self, e: Error) -> Error {
        match e {
            Error::Usage { .. } => Error::invalid(
                "operating_point",
                format!("{}: {}", self.text(), usage_message(e)),
            ),
            other => other,
        }
    }
}

/// The message of a usage error without its field (other errors as they print).
fn usage_message(e: Error) -> String {
    match e {
        Error::Usage { message, .. } => message,
        other => other.to_string(),
    }
}

/// The operating point of a report as `summary.json` records it.
#[derive(Debug, Clone, serde::Serialize)]
pub struct ChosenPoint {
    /// Sub-aperture (px per side).
    pub subap_px: usize,
    /// Spot (`airy:D` or `gauss:SX,SY`, px).
    pub spot: String,
    /// Signal (photons per sub-aperture).
    pub signal_photons: f64,
    /// `default` or `given`.
    pub chosen: String,
    /// Whether the point is one of the grid's configurations (else it was simulated beside it).
    pub in_grid: bool,
}

impl ChosenPoint {
    /// The record of `point`, `given` by the caller or the default, in the grid or not.
    pub fn new(point: &OperatingPoint, given: bool, in_grid: bool) -> ChosenPoint {
        ChosenPoint {
            subap_px: point.subap_px,
            spot: point.spot.label(),
            signal_photons: point.signal_photons,
            chosen: if given { "given" } else { "default" }.into(),
            in_grid,
        }
    }

    /// In words: "8x8 px, airy:2, 50 photons (default)", and where it is not in the grid,
    /// "..., simulated beside the grid".
    pub fn describe(&self) -> String {
        format!(
            "{}x{} px, {}, {} photons ({}{})",
            self.subap_px,
            self.subap_px,
            self.spot,
            self.signal_photons,
            self.chosen,
            if self.in_grid {
                ""
            } else {
                "; not in the grid, simulated beside it"
            }
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn field(e: Error) -> String {
        match e {
            Error::Usage { field, .. } => field,
            other => panic!("expected a usage error, got {other:?}"),
        }
    }

    #[test]
    fn points_parse_with_either_spot_and_print_back() {
        let p = OperatingPoint::parse(OperatingPoint::DEFAULT_TEXT).unwrap();
        assert_eq!(p, OperatingPoint::default());
        assert_eq!(p.describe(), "8x8 px, airy:2, 50 photons");
        let g = OperatingPoint::parse(" 12, gauss:1.5,2 ,200").unwrap();
        assert_eq!(g.subap_px, 12);
        assert_eq!(
            g.spot,
            Spot::Gauss {
                sigma_x_px: 1.5,
                sigma_y_px: 2.0
            }
        );
        assert_eq!(g.signal_photons, 200.0);
        assert_eq!(OperatingPoint::parse(&g.text()).unwrap(), g);
    }

    #[test]
    fn malformed_points_are_errors_of_operating_point() {
        for text in [
            "",
            "8",
            "8,airy:2",
            "x,airy:2,50",
            "8,airy:2,lots",
            "8,disc:2,50",
            "8,airy:0.01,50",
            "-8,airy:2,50",
        ] {
            let e = OperatingPoint::parse(text).unwrap_err();
            let msg = e.to_string();
            assert_eq!(field(e), "operating_point", "{text:?}");
            assert!(msg.contains("SUBAP,SPOT,SIGNAL"), "{msg}");
        }
    }

    #[test]
    fn the_record_says_whether_the_point_was_given_and_in_the_grid() {
        let p = OperatingPoint::default();
        assert_eq!(
            ChosenPoint::new(&p, false, true).describe(),
            "8x8 px, airy:2, 50 photons (default)"
        );
        assert_eq!(
            ChosenPoint::new(&p, true, false).describe(),
            "8x8 px, airy:2, 50 photons (given; not in the grid, simulated beside it)"
        );
        let blamed = p.blame(Error::invalid("subap_px", "too small"));
        assert_eq!(field(blamed), "operating_point");
    }
}

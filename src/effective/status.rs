//! How the effective read noise of a configuration was settled: its status word and meaning.

/// How the effective read noise was settled. Only `Ok` values are results; the others are
/// printed as their status word (and, for `Imprecise`, the value with its SE beside it).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Status {
    /// Bracketed and interpolated, and its standard error meets the precision target.
    Ok,
    /// Bracketed and interpolated, but the iteration cap was reached before the standard error
    /// met the target: R is too flat in sigma here for the value to be used.
    Imprecise,
    /// The detector's R is at or below that of a noiseless readout: sigma_eff is 0.
    LowerBound,
    /// The detector's R exceeds R of every constant sigma (up to 16x its noise scale): a few very
    /// noisy pixels pull the centroid more than any uniform noise does, so no Gaussian read
    /// noise reproduces it. sigma_eff is NaN (empty in CSV, null in JSON).
    Unreachable,
    /// No background level left at most `max_empty_frac` of the detector's frames empty, so its
    /// R is not a valid optimum and no sigma_eff is given.
    NoEligibleLevel,
}

impl Status {
    /// Every status, in the order the README and the page explain them.
    pub const ALL: [Status; 5] = [
        Status::Ok,
        Status::Imprecise,
        Status::LowerBound,
        Status::Unreachable,
        Status::NoEligibleLevel,
    ];

    /// The status word of tables and pages (`ok`, `imprecise`, `lower_bound`, ...).
    pub fn label(self) -> &'static str {
        match self {
            Status::Ok => "ok",
            Status::Imprecise => "imprecise",
            Status::LowerBound => "lower_bound",
            Status::Unreachable => "unreachable",
            Status::NoEligibleLevel => "no_eligible_level",
        }
    }

    /// What the status means, in one sentence (for `--help`, the README and the page).
    pub fn meaning(self) -> &'static str {
        match self {
            Status::Ok => "the standard error meets the precision target: a result",
            Status::Imprecise => {
                "the iteration cap was reached before the standard error met the target: \
                 value and SE shown for information, not a result"
            }
            Status::LowerBound => {
                "the camera does at least as well as a noiseless readout: sigma_eff is 0"
            }
            Status::Unreachable => {
                "no constant sigma gives an error as large as this camera's (a few very noisy \
                 pixels dominate): simulate the measured map or the fitted pdf instead"
            }
            Status::NoEligibleLevel => {
                "every background level leaves more frames empty than the empty-frame limit \
                 allows: no valid optimum, so no value"
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::Status;

    #[test]
    fn labels_are_the_serialised_words() {
        for s in Status::ALL {
            assert_eq!(serde_json::to_value(s).unwrap(), s.label());
            assert!(!s.meaning().is_empty());
        }
    }
}

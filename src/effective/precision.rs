//! The precision an effective read noise must reach, and how many iterations it may spend.
//!
//! A value is `ok` when its standard error meets either target: `sigma_eff_se_e` <=
//! `target_se_e`, or `sigma_eff_se_e` <= `target_rel` x `sigma_eff_e` (a target of 0 is off;
//! with both off every bracketed value is `ok` at the starting iterations). Until then the
//! solver adds iterations to the configuration, up to `max_iters`; a value still short of its
//! target there is `imprecise`.

use crate::montecarlo::{SimConfig, CHUNK};
use crate::{Error, Result};

/// How precise each effective read noise must be, and the iteration cap per configuration.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Precision {
    /// Absolute target for the standard error of sigma_eff (e-); 0 turns it off.
    pub target_se_e: f64,
    /// Relative target: the standard error at most this fraction of sigma_eff; 0 turns it off.
    pub target_rel: f64,
    /// Most iterations (frames) the final runs of one configuration may use; the
    /// configuration's own `iters` is where they start.
    pub max_iters: u64,
}

impl Default for Precision {
    fn default() -> Self {
        Precision {
            target_se_e: Self::DEFAULT_TARGET_SE_E,
            target_rel: Self::DEFAULT_TARGET_REL,
            max_iters: Self::DEFAULT_MAX_ITERS,
        }
    }
}

impl Precision {
    /// Default absolute target (e-).
    pub const DEFAULT_TARGET_SE_E: f64 = 0.05;
    /// Default relative target (fraction of sigma_eff).
    pub const DEFAULT_TARGET_REL: f64 = 0.025;
    /// Default iteration cap per configuration (frames).
    pub const DEFAULT_MAX_ITERS: u64 = 80_000;
    /// Iteration cap of the quick previews (`report --quick`, `paper --quick`; frames): it keeps
    /// them to seconds where a value is hard to pin down.
    pub const QUICK_MAX_ITERS: u64 = 24_000;
    /// Iterations grow at least to this factor of the current count per extension...
    const MIN_GROWTH: f64 = 2.0;
    /// ...and to the count the SE's 1/sqrt(N) law asks for, with this margin.
    const MARGIN: f64 = 1.2;

    /// No target: every configuration runs exactly `iters` iterations (the fixed-count solve).
    pub fn fixed(iters: u64) -> Self {
        Precision {
            target_se_e: 0.0,
            target_rel: 0.0,
            max_iters: iters,
        }
    }

    /// Check the targets and the cap against the starting iterations `iters`; the error names
    /// the field.
    pub fn validate(&self, iters: u64) -> Result<()> {
        if !(self.target_se_e.is_finite() && self.target_se_e >= 0.0) {
            return Err(Error::invalid(
                "target_se_e",
                format!(
                    "{}: must be a number >= 0 e- (0 turns the absolute target off)",
                    self.target_se_e
                ),
            ));
        }
        if !(self.target_rel.is_finite() && (0.0..=1.0).contains(&self.target_rel)) {
            return Err(Error::invalid(
                "target_rel",
                format!(
                    "{}: must be in [0, 1], a fraction of sigma_eff (0 turns the relative target off)",
                    self.target_rel
                ),
            ));
        }
        if !(iters..=SimConfig::MAX_ITERS).contains(&self.max_iters) {
            return Err(Error::invalid(
                "max_iters",
                format!(
                    "{}: the iteration cap must be at least the starting `iters` ({iters}) and at \
                     most {:e}",
                    self.max_iters,
                    SimConfig::MAX_ITERS as f64
                ),
            ));
        }
        Ok(())
    }

    /// Whether any target is set.
    pub fn has_target(&self) -> bool {
        self.target_se_e > 0.0 || self.target_rel > 0.0
    }

    /// The standard error (e-) a value `sigma_e` must reach: the larger of the absolute target
    /// and `target_rel` x sigma (the targets are alternatives); None with no target.
    pub fn target_for(&self, sigma_e: f64) -> Option<f64> {
        let rel = if sigma_e.is_finite() {
            self.target_rel * sigma_e.abs()
        } else {
            0.0
        };
        self.has_target().then(|| self.target_se_e.max(rel))
    }

    /// Whether a value `sigma_e` with standard error `se_e` meets the target.
    pub fn met(&self, sigma_e: f64, se_e: f64) -> bool {
        self.target_for(sigma_e).is_none_or(|t| se_e <= t)
    }

    /// Iterations to extend to after `done` gave standard error `se_e` for target `target_e`:
    /// max(2 N, N (se / target)^2 x 1.2), rounded up to whole chunks, at most the cap.
    pub fn next_iters(&self, done: u64, se_e: f64, target_e: f64) -> u64 {
        let ratio = se_e / target_e;
        let want = if ratio.is_finite() {
            (done as f64 * ratio * ratio * Self::MARGIN).max(done as f64 * Self::MIN_GROWTH)
        } else {
            f64::INFINITY
        };
        let want = want.min(self.max_iters as f64).ceil() as u64;
        want.div_ceil(CHUNK)
            .saturating_mul(CHUNK)
            .clamp(done, self.max_iters)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn either_target_suffices_and_zero_turns_a_target_off() {
        let p = Precision {
            target_se_e: 0.05,
            target_rel: 0.02,
            max_iters: 1000,
        };
        assert_eq!(p.target_for(1.0), Some(0.05));
        assert_eq!(p.target_for(5.0), Some(0.1));
        assert_eq!(p.target_for(-5.0), Some(0.1));
        assert_eq!(p.target_for(f64::NAN), Some(0.05));
        assert!(p.met(5.0, 0.09) && !p.met(1.0, 0.09));
        let rel_only = Precision {
            target_se_e: 0.0,
            ..p
        };
        assert_eq!(rel_only.target_for(0.0), Some(0.0));
        assert!(!rel_only.met(0.0, 1e-9));
        let none = Precision::fixed(1000);
        assert_eq!(none.target_for(1.0), None);
        assert!(none.met(1.0, f64::INFINITY));
    }

    #[test]
    fn extensions_follow_the_square_law_in_whole_chunks_up_to_the_cap() {
        let p = Precision {
            target_se_e: 0.05,
            target_rel: 0.0,
            max_iters: 100_000,
        };
        // SE twice the target: 4 x 1.2 = 4.8 times the iterations, rounded up to chunks.
        assert_eq!(p.next_iters(10_000, 0.1, 0.05), 48_128);
        // Nearly met: at least doubled.
        assert_eq!(p.next_iters(10_000, 0.051, 0.05), 20_224);
        // Far off or undefined: the cap.
        assert_eq!(p.next_iters(10_000, 1.0, 0.05), 100_000);
        assert_eq!(p.next_iters(10_000, f64::INFINITY, 0.05), 100_000);
        assert_eq!(p.next_iters(100_000, 1.0, 0.05), 100_000);
    }

    #[test]
    fn bad_targets_and_caps_are_refused_naming_the_field() {
        let ok = Precision::default();
        ok.validate(10_000).unwrap();
        let cases = [
            (
                Precision {
                    target_se_e: -1.0,
                    ..ok
                },
                "target_se_e",
            ),
            (
                Precision {
                    target_rel: f64::NAN,
                    ..ok
                },
                "target_rel",
            ),
            (
                Precision {
                    target_rel: 1.5,
                    ..ok
                },
                "target_rel",
            ),
            (
                Precision {
                    max_iters: 5_000,
                    ..ok
                },
                "max_iters",
            ),
        ];
        for (p, field) in cases {
            let e = p.validate(10_000).unwrap_err();
            assert!(e.to_string().contains(&format!("`{field}`")), "{e}");
        }
        let e = Precision { max_iters: 5, ..ok }.validate(10).unwrap_err();
        assert!(e.to_string().contains("`iters` (10)"), "{e}");
    }
}

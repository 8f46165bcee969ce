//! One number of the datasheet: its value, standard error and a status word saying whether it
//! is a result and, if not, which rule of the standard it breaks.

/// Whether a datasheet number is a result.
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case", tag = "status", content = "rule")]
pub enum QuantityStatus {
    /// Computed as the standard says, within its rules: a result.
    Ok,
    /// Computed, but its standard error is too large for the value to be used.
    Imprecise,
    /// Computed from a dataset that breaks a rule of the standard (the rule, in words, e.g.
    /// "fewer than 50 photon-transfer points"): for information, not a certified value.
    OutOfRules(String),
    /// Not computable from this dataset (why, e.g. "no photons per pixel given").
    Unavailable(String),
}

impl QuantityStatus {
    /// The status word of tables and pages (`ok`, `imprecise`, `out_of_rules`,
    /// `unavailable`).
    pub fn label(&self) -> &'static str {
        match self {
            QuantityStatus::Ok => "ok",
            QuantityStatus::Imprecise => "imprecise",
            QuantityStatus::OutOfRules(_) => "out_of_rules",
            QuantityStatus::Unavailable(_) => "unavailable",
        }
    }

    /// The rule broken or the reason a number is unavailable, if any.
    pub fn rule(&self) -> Option<&str> {
        match self {
            QuantityStatus::OutOfRules(r) | QuantityStatus::Unavailable(r) => Some(r),
            _ => None,
        }
    }
}

/// A datasheet number in the unit its name states, with its standard error (same unit; NaN
/// when not known) and status.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Quantity {
    /// The value (NaN when `Unavailable`).
    pub value: f64,
    /// Its standard error, same unit.
    pub se: f64,
    /// Whether it is a result.
    #[serde(flatten)]
    pub status: QuantityStatus,
}

impl Quantity {
    /// A result: `value` +- `se`.
    pub fn ok(value: f64, se: f64) -> Self {
        Quantity {
            value,
            se,
            status: QuantityStatus::Ok,
        }
    }

    /// A number this dataset cannot give, and why.
    pub fn unavailable(why: impl Into<String>) -> Self {
        Quantity {
            value: f64::NAN,
            se: f64::NAN,
            status: QuantityStatus::Unavailable(why.into()),
        }
    }

    /// The same number marked as breaking `rule` (an unavailable number stays unavailable).
    pub fn out_of_rules(self, rule: impl Into<String>) -> Self {
        match self.status {
            QuantityStatus::Unavailable(_) => self,
            _ => Quantity {
                status: QuantityStatus::OutOfRules(rule.into()),
                ..self
            },
        }
    }
}

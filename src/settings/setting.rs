//! One setting: what it takes ([`Kind`]), its names, unit, default and help, and the parsing
//! and checks both front ends apply.

use super::Value;
use std::ops::Bound::{self, Excluded, Included, Unbounded};
use std::ops::RangeBounds;

/// What values a setting takes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Kind {
    /// A finite real number between the bounds.
    Real(Bound<f64>, Bound<f64>),
    /// A whole number from the first to the second, inclusive (also written like `1e6`).
    Whole(u64, u64),
    /// One of these words.
    Choice(&'static [&'static str]),
    /// Text the library parses itself (a list, a spot shape, a grid, `paper` or a file).
    Text,
    /// Text given once per spot family; the option may be repeated.
    TextList,
    /// A file's path.
    Path,
    /// One or more paths (files, directories or globs).
    Paths,
}

/// One setting of a run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Setting {
    /// The library field it fills (errors name it), e.g. `emccd_read_noise_e`.
    pub field: &'static str,
    /// Its Python keyword (most often the field).
    pub key: &'static str,
    /// Its command-line flag, e.g. `--emccd-read-noise`.
    pub flag: &'static str,
    /// Unit of the value, as messages state it ("" when unitless).
    pub unit: &'static str,
    /// The values it takes.
    pub kind: Kind,
    /// Its default as typed on the command line; None: not set unless given.
    pub default: Option<&'static str>,
    /// One-line help, shared by `--help`, the Python stubs and the manual.
    pub help: &'static str,
    /// What a readout model that reads this setting lacks when it is not given, for "the X
    /// model needs ..." (None: the setting always has a value).
    pub needs: Option<&'static str>,
}

impl Setting {
    /// A setting with no unit, no default and nothing a model needs; fill in the rest.
    pub const fn new(
        field: &'static str,
        flag: &'static str,
        kind: Kind,
        help: &'static str,
    ) -> Setting {
        Setting {
            field,
            key: field,
            flag,
            unit: "",
            kind,
            default: None,
            help,
            needs: None,
        }
    }

    /// The same setting with unit `unit`.
    pub const fn unit(self, unit: &'static str) -> Setting {
        Setting { unit, ..self }
    }

    /// The same setting with default `default` (as typed on the command line).
    pub const fn default(self, default: &'static str) -> Setting {
        Setting {
            default: Some(default),
            ..self
        }
    }

    /// The same setting with Python keyword `key`.
    pub const fn key(self, key: &'static str) -> Setting {
        Setting { key, ..self }
    }

    /// The same setting, needed by the models that read it: `what` says what it is.
    pub const fn needed_as(self, what: &'static str) -> Setting {
        Setting {
            needs: Some(what),
            ..self
        }
    }

    /// The value of `text` as typed on the command line, or the message of why it is refused
    /// (clap puts the option before it).
    pub fn parse(&self, text: &str) -> std::result::Result<Value, String> {
        match self.kind {
            Kind::Real(lo, hi) => parse_real(text, lo, hi, self.unit).map(Value::Real),
            Kind::Whole(lo, hi) => parse_whole(text, lo, hi, self.unit).map(Value::Whole),
            Kind::Choice(words) => match words.iter().find(|w| **w == text.trim()) {
                Some(w) => Ok(Value::Text(w.to_string())),
                None => Err(format!("must be one of {}", words.join(", "))),
            },
            Kind::Text | Kind::TextList => Ok(Value::Text(text.to_string())),
            Kind::Path | Kind::Paths => Ok(Value::Path(text.into())),
        }
    }

    /// `value` if this setting takes it (a number within the range, a word among the
    /// choices), or the message of why not: the one check of the command line and Python.
    pub fn check(&self, value: Value) -> std::result::Result<Value, String> {
        let refused = |shown: String| Err(format!("{shown}: {}", self.expected()));
        match (&self.kind, &value) {
            (Kind::Real(lo, hi), Value::Real(v)) => {
                if v.is_finite() && (*lo, *hi).contains(v) {
                    Ok(value)
                } else {
                    refused(v.to_string())
                }
            }
            (Kind::Whole(lo, hi), Value::Whole(v)) => {
                if (lo..=hi).contains(&v) {
                    Ok(value)
                } else {
                    refused(v.to_string())
                }
            }
            (Kind::Choice(words), Value::Text(t)) => {
                if words.contains(&t.as_str()) {
                    Ok(value)
                } else {
                    refused(format!("{t:?}"))
                }
            }
            (Kind::Text | Kind::TextList, Value::Text(_))
            | (Kind::TextList, Value::Texts(_))
            | (Kind::Path, Value::Path(_))
            | (Kind::Paths, Value::Paths(_) | Value::Path(_)) => Ok(value),
            // Objects that only Python passes (a fitted pdf, a map array) are checked by the
            // library when they are used.
            (Kind::Text, Value::Pdf(_)) | (Kind::Path, Value::Map(_)) => Ok(value),
            _ => refused(format!("{value:?}")),
        }
    }

    /// What the setting takes, as messages state it: `a number in (0, 1]`, `one of a, b`.
    pub fn expected(&self) -> String {
        match self.kind {
            Kind::Real(lo, hi) => format!("must be a number {}", describe(lo, hi, self.unit)),
            Kind::Whole(lo, hi) => whole_message(lo, hi, self.unit),
            Kind::Choice(words) => format!("must be one of {}", words.join(", ")),
            Kind::Text | Kind::TextList => "must be text".into(),
            Kind::Path | Kind::Paths => "must be a path".into(),
        }
    }

    /// The default as a value, None when the setting has none.
    pub fn default_value(&self) -> Option<Value> {
        let text = self.default?;
        Some(
            self.parse(text)
                .unwrap_or_else(|e| panic!("{}: default {text:?} {e}", self.field)),
        )
    }
}

/// A comma-separated list of numbers for `option` (a field or a flag, as errors name it).
pub fn parse_list<T: std::str::FromStr>(text: &str, option: &str) -> crate::Result<Vec<T>> {
    let items: Vec<T> = text
        .split(',')
        .map(|s| {
            s.trim().parse::<T>().map_err(|_| {
                crate::Error::invalid(option, format!("'{s}' in '{text}' is not a valid number"))
            })
        })
        .collect::<crate::Result<_>>()?;
    if items.is_empty() {
        return Err(crate::Error::invalid(option, "empty list"));
    }
    Ok(items)
}

/// A finite real number between `lo` and `hi` from `text`, or the message of why not.
pub fn parse_real(
    text: &str,
    lo: Bound<f64>,
    hi: Bound<f64>,
    unit: &str,
) -> std::result::Result<f64, String> {
    match text.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && (lo, hi).contains(&v) => Ok(v),
        _ => Err(format!("must be a number {}", describe(lo, hi, unit))),
    }
}

/// A whole number from `lo` to `hi` from `text` (also written like `1e6`), or the message of
/// why not.
pub fn parse_whole(text: &str, lo: u64, hi: u64, unit: &str) -> std::result::Result<u64, String> {
    let text = text.trim();
    let value = text.parse::<i128>().ok().or_else(|| {
        let v = text.parse::<f64>().ok()?;
        (v.is_finite() && v.fract() == 0.0 && v.abs() < 1e30).then_some(v as i128)
    });
    value
        .filter(|v| (lo as i128..=hi as i128).contains(v))
        .map(|v| v as u64)
        .ok_or_else(|| whole_message(lo, hi, unit))
}

/// `must be a whole number from lo to hi unit`.
fn whole_message(lo: u64, hi: u64, unit: &str) -> String {
    let sep = if unit.is_empty() { "" } else { " " };
    format!("must be a whole number from {lo} to {hi}{sep}{unit}")
}

/// `in (0, 1] unit`, `>= 0 unit`, ...: a range as the messages state it.
pub fn describe(lo: Bound<f64>, hi: Bound<f64>, unit: &str) -> String {
    let unit = if unit.is_empty() {
        String::new()
    } else {
        format!(" {unit}")
    };
    let num = |v: f64| {
        if v.abs() >= 1e6 {
            format!("{v:e}")
        } else {
            format!("{v}")
        }
    };
    match (lo, hi) {
        (Included(a), Unbounded) => format!(">= {}{unit}", num(a)),
        (Excluded(a), Unbounded) => format!("> {}{unit}", num(a)),
        (Unbounded, Unbounded) => format!("(finite){unit}"),
        (lo, hi) => {
            let (open, a) = match lo {
                Included(a) => ('[', num(a)),
                Excluded(a) => ('(', num(a)),
                Unbounded => ('(', "-inf".into()),
            };
            let (close, b) = match hi {
                Included(b) => (']', num(b)),
                Excluded(b) => (')', num(b)),
                Unbounded => (')', "inf".into()),
            };
            format!("in {open}{a}, {b}{close}{unit}")
        }
    }
}

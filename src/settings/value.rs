//! The value of a setting, and the settings a user gave (the others take their defaults).

use super::Setting;
use crate::calib::Map;
use crate::pdf::RmsPdf;
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::Arc;

/// The value of one setting.
#[derive(Debug, Clone)]
pub enum Value {
    /// A real number (in the setting's unit).
    Real(f64),
    /// A whole number.
    Whole(u64),
    /// Text: a word among the choices, or text the library parses.
    Text(String),
    /// A path.
    Path(PathBuf),
    /// Several paths.
    Paths(Vec<PathBuf>),
    /// The texts of a repeated option.
    Texts(Vec<String>),
    /// A fitted per-pixel rms distribution (Python passes a `PdfFit` object as `pdf`).
    Pdf(Arc<dyn RmsPdf>),
    /// A read-noise map in e- (Python passes an array as `map_e`).
    Map(Arc<Map>),
}

impl Value {
    /// The one value of a setting of `kind` given as `parts` (each as [`Setting::parse`] gave
    /// it): a repeated option's texts or paths gathered, otherwise the last one given.
    pub fn gathered(kind: super::Kind, parts: impl Iterator<Item = Value>) -> Value {
        use super::Kind;
        match kind {
            Kind::TextList => Value::Texts(
                parts
                    .filter_map(|v| match v {
                        Value::Text(t) => Some(t),
                        _ => None,
                    })
                    .collect(),
            ),
            Kind::Paths => Value::Paths(
                parts
                    .filter_map(|v| match v {
                        Value::Path(p) => Some(p),
                        _ => None,
                    })
                    .collect(),
            ),
            _ => parts.last().expect("a given option has a value"),
        }
    }
}

/// The settings given by the user, by field; a setting not given takes its default.
#[derive(Debug, Clone, Default)]
pub struct Values {
    given: BTreeMap<&'static str, Value>,
}

impl Values {
    /// Record `value` as given for `setting` (already checked by [`Setting::check`]).
    pub fn set(&mut self, setting: &'static Setting, value: Value) {
        self.given.insert(setting.field, value);
    }

    /// Whether the user gave `setting`.
    pub fn is_given(&self, setting: &Setting) -> bool {
        self.given.contains_key(setting.field)
    }

    /// The value given for `setting`, else its default, else None.
    pub fn get(&self, setting: &Setting) -> Option<Value> {
        self.given
            .get(setting.field)
            .cloned()
            .or_else(|| setting.default_value())
    }

    /// A real setting's value.
    pub fn real(&self, setting: &Setting) -> Option<f64> {
        match self.get(setting)? {
            Value::Real(v) => Some(v),
            other => wrong_kind(setting, &other),
        }
    }

    /// A whole-number setting's value.
    pub fn whole(&self, setting: &Setting) -> Option<u64> {
        match self.get(setting)? {
            Value::Whole(v) => Some(v),
            other => wrong_kind(setting, &other),
        }
    }

    /// A text or choice setting's value (a path given as text is its text).
    pub fn text(&self, setting: &Setting) -> Option<String> {
        match self.get(setting)? {
            Value::Text(t) => Some(t),
            Value::Path(p) => Some(p.to_string_lossy().into_owned()),
            other => wrong_kind(setting, &other),
        }
    }

    /// A repeated text setting's values (none given: its default alone).
    pub fn texts(&self, setting: &Setting) -> Vec<String> {
        match self.get(setting) {
            None => Vec::new(),
            Some(Value::Text(t)) => vec![t],
            Some(Value::Texts(t)) => t,
            Some(other) => wrong_kind(setting, &other),
        }
    }

    /// A path setting's value.
    pub fn path(&self, setting: &Setting) -> Option<PathBuf> {
        match self.get(setting)? {
            Value::Path(p) => Some(p),
            Value::Text(t) => Some(t.into()),
            Value::Map(_) => None,
            other => wrong_kind(setting, &other),
        }
    }

    /// A several-paths setting's values (none when not given).
    pub fn paths(&self, setting: &Setting) -> Vec<PathBuf> {
        match self.get(setting) {
            None => Vec::new(),
            Some(Value::Paths(p)) => p,
            Some(Value::Path(p)) => vec![p],
            Some(other) => wrong_kind(setting, &other),
        }
    }
}

/// A value of the wrong kind can only come from a front end that skipped
/// [`Setting::check`]: a programming error.
fn wrong_kind<T>(setting: &Setting, value: &Value) -> T {
    panic!(
        "setting {} holds {value:?}, not a {:?} value",
        setting.field, setting.kind
    )
}

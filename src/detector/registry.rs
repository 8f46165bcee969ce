//! The registry's machinery over a table of [`ModelEntry`]s: the joined names (built at compile
//! time), the help text, lookup by name and parsing of `name[:ARG]`. The table itself is
//! `detector::MODELS`.

use super::spec::{ModelEntry, ModelSpec};
use crate::{Error, Result};

/// Separator of the joined names.
const SEP: &[u8] = b", ";

/// Length in bytes of [`names`]' output.
pub(super) const fn names_len(models: &[ModelEntry]) -> usize {
    let mut len = 0;
    let mut i = 0;
    while i < models.len() {
        len += models[i].syntax_len() + if i > 0 { SEP.len() } else { 0 };
        i += 1;
    }
    len
}

/// Every entry's syntax (`scmos-fixed[:PATTERN]`) joined by ", "; `N` must be
/// [`names_len`]`(models)`.
pub(super) const fn names<const N: usize>(models: &[ModelEntry]) -> [u8; N] {
    let mut out = [0u8; N];
    let mut at = 0;
    let mut i = 0;
    while i < models.len() {
        if i > 0 {
            out[at] = SEP[0];
            out[at + 1] = SEP[1];
            at += SEP.len();
        }
        at = models[i].write_syntax(&mut out, at);
        i += 1;
    }
    out
}

/// `bytes` as text (const; the names are ASCII).
pub(super) const fn as_str(bytes: &'static [u8]) -> &'static str {
    match std::str::from_utf8(bytes) {
        Ok(s) => s,
        Err(_) => panic!("model names are UTF-8"),
    }
}

/// The entry named `name`.
pub(super) fn find(models: &'static [ModelEntry], name: &str) -> Option<&'static ModelEntry> {
    models.iter().find(|m| m.name == name)
}

/// Parse `name[:ARG]` against `models`; errors name the `model` field and list `known`.
pub(super) fn parse(models: &'static [ModelEntry], known: &str, text: &str) -> Result<ModelSpec> {
    let (head, arg) = match text.split_once(':') {
        Some((h, a)) => (h, Some(a)),
        None => (text, None),
    };
    let bad = |hint: String| {
        Error::invalid(
            "model",
            format!("unknown model '{text}'{hint} (known: {known})"),
        )
    };
    let Some(entry) = find(models, head.trim()) else {
        return Err(bad(suggestion(models, head.trim())));
    };
    if entry.arg.is_none() && arg.is_some() {
        return Err(bad(format!("; {} takes no :ARG", entry.name)));
    }
    (entry.parse)(entry, arg).map_err(|why| Error::invalid("model", format!("'{text}': {why}")))
}

/// `; did you mean 'NAME'?` for the registry name nearest to a mistyped `name` (as clap
/// suggests for option values), or nothing when none is near.
fn suggestion(models: &[ModelEntry], name: &str) -> String {
    let nearest = models
        .iter()
        .map(|m| (strsim::jaro(name, m.name), m.name))
        .max_by(|a, b| a.0.total_cmp(&b.0));
    match nearest {
        // clap's threshold for its "a similar value exists" tips.
        Some((score, near)) if score > 0.7 => format!("; did you mean '{near}'?"),
        _ => String::new(),
    }
}

/// One line per entry: its syntax, its help, and the parameters it reads as `` `field` ``.
pub(super) fn help(models: &[ModelEntry]) -> String {
    let width = models.iter().map(ModelEntry::syntax_len).max().unwrap_or(0);
    let lines: Vec<String> = models
        .iter()
        .map(|m| {
            let fields: Vec<String> = m.params.iter().map(|p| format!("`{p}`")).collect();
            let uses = if fields.is_empty() {
                String::new()
            } else {
                format!(" (uses {})", fields.join(", "))
            };
            format!("{:<width$}  {}{uses}", m.syntax(), m.help)
        })
        .collect();
    lines.join("\n")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::detector::params::ModelParams;
    use crate::detector::readout::Readout;
    use crate::detector::scmos_constant::ScmosConstant;
    use crate::detector::spec::Sensor;

    /// A model added through the registry alone: a constant sigma given as `test-constant:S`.
    const ADDED: ModelEntry = ModelEntry {
        name: "test-constant",
        arg: Some("SIGMA_E"),
        help: "one sigma for every pixel",
        sensor: Sensor::Scmos,
        params: &[],
        parse: ModelSpec::registered,
        build: |spec, _, _| {
            let ModelSpec::Registered(r) = spec else {
                unreachable!("test-constant builds only its own spec")
            };
            let sigma: f64 = r.arg().unwrap_or("1").parse().expect("a number");
            Ok(Box::new(ScmosConstant::new(
                sigma,
                format!("test-constant:{sigma}"),
            )))
        },
    };
    const TABLE: &[ModelEntry] = &[ADDED];
    const NAMES: [u8; names_len(TABLE)] = names(TABLE);

    #[test]
    fn a_model_without_a_variant_parses_builds_and_names_itself() {
        assert_eq!(as_str(&NAMES), "test-constant[:SIGMA_E]");
        let spec = parse(TABLE, "", "test-constant:2.5").unwrap();
        assert_eq!(spec.name(), "test-constant");
        let ModelSpec::Registered(r) = &spec else {
            panic!("{spec:?}")
        };
        assert_eq!((r.entry().name, r.arg()), ("test-constant", Some("2.5")));
        // `ModelSpec::build` finds the entry through the spec, not through the table.
        let built: Box<dyn Readout> = spec.build(&ModelParams::default(), 4).unwrap();
        assert_eq!(built.name(), "test-constant:2.5");
        assert_eq!(built.noise_scale_e(), 2.5);
        assert_eq!(spec, parse(TABLE, "", "test-constant:2.5").unwrap());
        assert_ne!(spec, parse(TABLE, "", "test-constant").unwrap());
        let err = parse(TABLE, "test-constant[:SIGMA_E]", "other").unwrap_err();
        assert_eq!(
            err.to_string(),
            "invalid `model`: unknown model 'other' (known: test-constant[:SIGMA_E])"
        );
        assert!(help(TABLE).starts_with("test-constant[:SIGMA_E]  one sigma for every pixel"));
    }
}

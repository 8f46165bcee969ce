//! The Python stubs (`python/detnoise/__init__.pyi`) against the settings registry: the
//! `ModelParams` keywords are generated from `detnoise::settings::READOUT` (run
//! `DETNOISE_BLESS=1 cargo test --test python_stubs` to rewrite them after changing the
//! registry), and the run settings of `simulate`, `effective` and `report` state the registry's
//! defaults (or the command's own, `settings::COMMAND_DEFAULTS`).

use detnoise::settings::{self, Kind, Setting};
use std::path::PathBuf;

const BEGIN: &str =
    "    # BEGIN settings: generated from detnoise::settings::READOUT by tests/python_stubs.rs";
const END: &str = "    # END settings";

fn stub_path() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("python/detnoise/__init__.pyi")
}

/// The Python type of a setting's keyword.
fn py_type(s: &Setting) -> String {
    let base = match (s.key, s.kind) {
        ("pdf", _) => "Union[str, \"PdfFit\", _Path]".to_string(),
        ("map_e", _) => "Union[_Array, _Path]".to_string(),
        (_, Kind::Real(..)) => "float".into(),
        (_, Kind::Whole(..)) => "int".into(),
        (_, Kind::Choice(words)) => {
            let quoted: Vec<String> = words.iter().map(|w| format!("{w:?}")).collect();
            format!("Literal[{}]", quoted.join(", "))
        }
        (_, Kind::Text | Kind::TextList) => "str".into(),
        (_, Kind::Path) => "_Path".into(),
        (_, Kind::Paths) => "_Paths".into(),
    };
    match s.default {
        Some(_) => base,
        None => format!("Optional[{base}]"),
    }
}

/// The range and default of a setting, as the stub's comment states them.
fn range_and_default(s: &Setting) -> String {
    let range = match s.kind {
        Kind::Real(..) | Kind::Whole(..) => {
            let e = s.expected();
            let e = e.trim_start_matches("must be a number ");
            format!("; {}", e.trim_start_matches("must be a "))
        }
        _ => String::new(),
    };
    if s.help.contains("default:") {
        return range;
    }
    let default = s.default.map_or("none".to_string(), |d| d.to_string());
    format!("{range}; default: {default}")
}

/// `text` as `    #: ` comment lines of at most 100 characters.
fn wrapped(text: &str) -> Vec<String> {
    let mut lines = vec![String::from("    #:")];
    for word in text.split(' ') {
        if lines.last().unwrap().len() + 1 + word.len() > 100 {
            lines.push(String::from("    #:"));
        }
        let line = lines.last_mut().unwrap();
        line.push(' ');
        line.push_str(word);
    }
    lines
}

/// The generated `ModelParams` keywords, between the markers.
fn generated() -> String {
    let mut out = vec![BEGIN.to_string()];
    for s in settings::READOUT {
        // `--flag` mentions in the help read as keywords in Python (longest flags first, so
        // that `--pdf-model` is not read as `--pdf`).
        let mut flags: Vec<&Setting> = settings::READOUT.to_vec();
        flags.sort_by_key(|o| std::cmp::Reverse(o.flag.len()));
        let help = flags
            .iter()
            .fold(s.help.to_string(), |h, o| {
                h.replace(o.flag, &format!("`{}`", o.key))
            })
            .replace("``", "`");
        out.extend(wrapped(&format!("{help}{}.", range_and_default(s))));
        out.push(format!("    {}: {}", s.key, py_type(s)));
    }
    out.push(END.to_string());
    out.join("\n")
}

#[test]
fn model_params_stub_is_generated_from_the_registry() {
    let path = stub_path();
    let text = std::fs::read_to_string(&path).unwrap();
    let (Some(b), Some(e)) = (text.find(BEGIN), text.find(END)) else {
        panic!("{}: no `{BEGIN}` ... `{END}` block", path.display());
    };
    let current = &text[b..e + END.len()];
    let want = generated();
    if current != want {
        if std::env::var_os("DETNOISE_BLESS").is_some() {
            let new = format!("{}{want}{}", &text[..b], &text[e + END.len()..]);
            std::fs::write(&path, new).unwrap();
            return;
        }
        panic!(
            "{} differs from the registry; rerun with DETNOISE_BLESS=1 to rewrite it:\n{want}",
            path.display()
        );
    }
}

/// The parameter `name = default` of function `function` in the stubs.
fn stub_default(text: &str, function: &str, name: &str) -> Option<String> {
    let start = text.find(&format!("def {function}("))?;
    let body = &text[start..start + text[start..].find(") ->")?];
    let line = body
        .lines()
        .find(|l| l.trim_start().starts_with(&format!("{name}:")))?;
    let default = line.split_once(" = ")?.1.trim_end_matches(',').trim();
    Some(default.trim_matches('"').replace('_', ""))
}

/// Whether stub default `stub` is the registry default `registry` (numbers compared as
/// numbers).
fn same_default(stub: &str, registry: &str) -> bool {
    match (stub.parse::<f64>(), registry.parse::<f64>()) {
        (Ok(a), Ok(b)) => a == b,
        _ => stub == registry,
    }
}

#[test]
fn the_run_settings_of_the_python_functions_state_the_registry_defaults() {
    let text = std::fs::read_to_string(stub_path()).unwrap();
    let mut checked = 0;
    for function in ["simulate", "effective", "report"] {
        // Every setting but the readout's, which the generated block above holds.
        let others = settings::GROUPS.iter().filter(|(g, _)| *g != "readout");
        for s in others.flat_map(|(_, group)| group.iter()) {
            let Some(stub) = stub_default(&text, function, s.key) else {
                continue;
            };
            checked += 1;
            // The lists (None) take the command's grid; every other default is stated.
            if stub == "None" {
                continue;
            }
            let registry = settings::default_in(function, s).unwrap_or("None");
            assert!(
                same_default(&stub, registry),
                "{function}({}={stub}) but the registry's default is {registry}",
                s.key
            );
        }
    }
    assert!(
        checked >= 20,
        "only {checked} parameters found in the stubs"
    );
}

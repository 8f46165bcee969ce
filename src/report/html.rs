//! The HTML pieces every part of the report page uses: the head and style sheet, figures, key
//! numbers, and numbers as the page prints them (never "NaN").

use crate::effective::Status;
use crate::output::html_escape as esc;
use std::fmt::Write as _;

/// "a" or "an" before the number `n` as it is read aloud (an 8, an 11, an 18, an 80, a 16).
pub(crate) fn article(n: u64) -> &'static str {
    let digits = n.to_string();
    // Numbers read with a leading vowel sound: eight..., eleven..., eighteen... (the last two
    // only when they lead a group of three digits: 11, 18, 11,000, 18,000,000).
    let eleven_or_eighteen =
        digits.len() % 3 == 2 && (digits.starts_with("11") || digits.starts_with("18"));
    if digits.starts_with('8') || eleven_or_eighteen {
        "an"
    } else {
        "a"
    }
}

/// A number with `decimals`, or a dash when it is not finite (never "NaN").
pub(crate) fn num(v: f64, decimals: usize) -> String {
    if v.is_finite() {
        format!("{v:.decimals$}")
    } else {
        "–".into()
    }
}

/// An effective read noise as the page shows it: `ok` as value ± SE, `imprecise` greyed with
/// its word, any other status as its word alone.
pub(crate) fn fmt_effective(sigma_e: f64, se_e: f64, status: Status) -> String {
    let word = |s: Status| format!("<span class=\"status\">{}</span>", s.label());
    match status {
        Status::Ok => format!("{} ± {} e⁻", num(sigma_e, 2), num(se_e, 2)),
        Status::Imprecise => format!(
            "<span class=\"muted\">{} ± {} e⁻ {}</span>",
            num(sigma_e, 2),
            num(se_e, 2),
            word(status)
        ),
        s => word(s),
    }
}

/// The page's head and style sheet, shared by both kinds of report.
pub(crate) fn page_head() -> String {
    page_head_titled("detnoise report")
}

/// The head and style sheet of a detnoise page titled `title` (plain text).
pub(crate) fn page_head_titled(title: &str) -> String {
    let mut h = String::new();
    let _ = write!(
        h,
        "<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\"><meta name=\"viewport\" content=\"width=device-width\"><title>{}</title><style>\
body{{font-family:'DejaVu Sans',Helvetica,Arial,sans-serif;max-width:1100px;margin:1.5em auto;padding:0 1em;color:#1d1d1d;line-height:1.45}}\
h1{{font-size:1.6em;margin-bottom:.2em}}h2{{margin-top:1.8em;border-bottom:2px solid #ddd;padding-bottom:.2em}}\
.keys{{display:grid;grid-template-columns:repeat(auto-fill,minmax(230px,1fr));gap:.8em;margin:1em 0}}\
.key{{background:#f3f6fa;border:1px solid #d5dde8;border-radius:6px;padding:.7em .9em}}.key b{{display:block;font-size:1.45em;color:#0b4f8a}}\
figure{{margin:1.5em 0}}figure img{{max-width:100%;border:1px solid #e3e3e3}}figcaption{{color:#444;font-size:.93em}}\
table{{border-collapse:collapse;font-size:.88em;margin:.8em 0}}td,th{{border:1px solid #ccc;padding:.25em .55em;text-align:right}}th{{background:#f0f0f0}}\
.note{{color:#555;font-size:.9em}}.muted{{color:#888}}.status{{font-family:monospace;color:#6a3d00}}\
dl.legend{{display:grid;grid-template-columns:max-content 1fr;gap:.2em 1em;font-size:.92em}}dl.legend dd{{margin:0}}\
.advice{{background:#fff6e5;border:1px solid #e8c98a;border-radius:6px;padding:.6em .9em}}\
details{{margin:.8em 0}}summary{{cursor:pointer;color:#0b4f8a}}</style></head><body>",
        esc(title)
    );
    h
}

/// A figure: the image `src` with plain-text `alt`, and its `caption` (HTML).
pub(crate) fn figure(h: &mut String, src: &str, alt: &str, caption: &str) {
    let _ = write!(
        h,
        "<figure><img src=\"{}\" alt=\"{}\"><figcaption>{caption}</figcaption></figure>",
        esc(src),
        esc(alt).replace('"', "&quot;")
    );
}

/// A key number: its label and value (both HTML).
pub(crate) fn key(h: &mut String, label: &str, value: &str) {
    let _ = write!(h, "<div class=\"key\">{label}<b>{value}</b></div>");
}

/// A value ± SE (e-) with `decimals`, or a dash when there is none.
pub(crate) fn pm(v: Option<f64>, se: Option<f64>, decimals: usize) -> String {
    match (v, se) {
        (Some(v), Some(se)) => format!("{} ± {}", num(v, decimals), num(se, decimals)),
        (Some(v), None) => num(v, decimals),
        _ => "–".into(),
    }
}

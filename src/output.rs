//! Writing results: output directories and files under the `out` rule, atomic files, and
//! records as text tables, CSV or JSON.

mod atomic;
mod dir;
mod file;
pub mod manifest;
mod paths;
mod table;
pub mod temps;

pub use atomic::{write_atomic, write_atomic_with, write_json};
pub use dir::{DirPlan, OutputDir};
pub use file::{check_file, FileOut, StagedFiles};
pub use table::{render, write_csv_json, TableFormat};

/// Escape `&`, `<` and `>` for HTML (and XML element) text.
pub fn html_escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn html_escape_escapes_markup_and_keeps_the_rest() {
        assert_eq!(
            html_escape("a < b && c > d"),
            "a &lt; b &amp;&amp; c &gt; d"
        );
        assert_eq!(html_escape("&lt;"), "&amp;lt;");
        assert_eq!(html_escape("σ \"q\" 'x'"), "σ \"q\" 'x'");
    }
}

//! The datasheet page: one self-contained HTML file beside its figures, each number shown as
//! value ± SE with its unit, or greyed with its status word when it is not a result.

use std::fmt::Write as _;

use super::quantity::{Quantity, QuantityStatus};
use super::sheet::Sheet;
use crate::output::html_escape as esc;
use crate::report::html::{figure, page_head_titled};

/// `value ± se` rounded to the SE's second significant digit (the value alone when the SE is
/// unknown; a dash when there is no value).
pub fn value_pm(q: &Quantity) -> String {
    if !q.value.is_finite() {
        return "–".into();
    }
    if !(q.se.is_finite() && q.se > 0.0) {
        return significant(q.value, 4);
    }
    let decimals = (1 - q.se.log10().floor() as i32).clamp(0, 12) as usize;
    format!("{:.decimals$} ± {:.decimals$}", q.value, q.se)
}

/// `v` with `digits` significant digits, without exponent for everyday magnitudes.
fn significant(v: f64, digits: i32) -> String {
    if v == 0.0 {
        return "0".into();
    }
    let magnitude = v.abs().log10().floor() as i32;
    if !(-4..=8).contains(&magnitude) {
        return format!("{v:.*e}", (digits - 1) as usize);
    }
    let decimals = (digits - 1 - magnitude).clamp(0, 12) as usize;
    format!("{v:.decimals$}")
}

/// The cell of a number: a result as value ± SE, anything else greyed with its status word
/// and the rule it breaks.
fn cell(q: &Quantity) -> String {
    match &q.status {
        QuantityStatus::Ok => esc(&value_pm(q)),
        status => format!(
            "<span class=\"muted\">{}</span> <span class=\"status\" title=\"{}\">{}</span>",
            esc(&value_pm(q)),
            esc(status.rule().unwrap_or("")).replace('"', "&quot;"),
            status.label()
        ),
    }
}

/// The page's HTML.
pub fn html(sheet: &Sheet) -> String {
    let mut h = page_head_titled(&sheet.title);
    let _ = write!(
        h,
        "<h1>{}</h1><p class=\"note\">Dataset: <code>{}</code>. Every number is value ± its \
         standard error; a number that is not a result is greyed, with its status word \
         (<span class=\"status\">imprecise</span>: too uncertain to use; \
         <span class=\"status\">out_of_rules</span>: the dataset breaks a rule of EMVA 1288 \
         release 4.0, named on hover and in datasheet.csv; \
         <span class=\"status\">unavailable</span>: this dataset cannot give it).</p>",
        esc(&sheet.title),
        esc(&sheet.source.display().to_string())
    );
    if !sheet.notes.is_empty() {
        h.push_str("<div class=\"advice\"><ul>");
        for n in &sheet.notes {
            let _ = write!(h, "<li>{}</li>", esc(n));
        }
        h.push_str("</ul></div>");
    }
    for s in &sheet.sections {
        let _ = write!(
            h,
            "<h2>{}</h2><table><tr><th style=\"text-align:left\">quantity</th><th>value</th>\
             <th>unit</th><th style=\"text-align:left\">key</th></tr>",
            esc(&s.title)
        );
        for r in &s.rows {
            let _ = write!(
                h,
                "<tr><td style=\"text-align:left\">{}</td><td>{}</td><td>{}</td>\
                 <td style=\"text-align:left\"><code>{}</code></td></tr>",
                esc(&r.label),
                cell(&r.quantity),
                esc(&r.unit),
                esc(&r.key)
            );
        }
        h.push_str("</table>");
    }
    if !sheet.figures.is_empty() {
        h.push_str("<h2>Figures</h2>");
    }
    for f in &sheet.figures {
        figure(
            &mut h,
            &format!("{}.svg", f.stem),
            &f.title,
            &esc(&f.caption),
        );
    }
    h.push_str("</body></html>\n");
    h
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::emva::sheet::{Curve, Figure, Row, Section};

    fn sheet() -> Sheet {
        Sheet {
            title: "EMVA 1288 datasheet: test <camera>".into(),
            source: "d/descriptor.txt".into(),
            sections: vec![Section {
                title: "Photon transfer".into(),
                rows: vec![
                    Row::new(
                        "system_gain_dn_per_e",
                        "System gain K",
                        "DN/e-",
                        Quantity::ok(0.12345, 0.00067),
                    ),
                    Row::new(
                        "quantum_efficiency",
                        "Quantum efficiency",
                        "",
                        Quantity::unavailable("no photons per pixel given"),
                    ),
                    Row::new(
                        "saturation_capacity_e",
                        "Saturation capacity",
                        "e-",
                        Quantity::ok(9000.0, 40.0).out_of_rules("no point near saturation"),
                    ),
                ],
            }],
            figures: vec![Figure {
                stem: "photon_transfer".into(),
                title: "Photon transfer".into(),
                x_label: "mean - dark (DN)".into(),
                y_label: "variance - dark variance (DN²)".into(),
                log_x: false,
                log_y: false,
                curves: vec![Curve {
                    name: "measured".into(),
                    x: vec![1.0, 2.0, f64::NAN],
                    y: vec![0.5, 1.0, 2.0],
                    y_se: None,
                    markers: true,
                }],
                caption: "The photon transfer.".into(),
            }],
            notes: vec!["fewer than 50 points".into()],
        }
    }

    #[test]
    fn values_are_rounded_to_their_standard_error() {
        assert_eq!(
            value_pm(&Quantity::ok(0.12345, 0.00067)),
            "0.12345 ± 0.00067"
        );
        assert_eq!(value_pm(&Quantity::ok(9012.3, 41.0)), "9012 ± 41");
        assert_eq!(value_pm(&Quantity::ok(4.56789, f64::NAN)), "4.568");
        assert_eq!(value_pm(&Quantity::unavailable("x")), "–");
    }

    #[test]
    fn the_page_escapes_text_and_marks_what_is_not_a_result() {
        let h = html(&sheet());
        assert!(h.contains("test &lt;camera&gt;"));
        assert!(h.contains("0.12345 ± 0.00067"));
        assert!(h.contains("title=\"no photons per pixel given\">unavailable"));
        assert!(h.contains("title=\"no point near saturation\">out_of_rules"));
        assert!(h.contains("src=\"photon_transfer.svg\""));
        assert!(!h.contains("NaN"));
    }

    #[test]
    fn csv_and_json_carry_status_rule_and_units_in_keys() {
        let s = sheet();
        let csv = s.csv().unwrap();
        let mut lines = csv.lines();
        assert_eq!(
            lines.next().unwrap(),
            "section,key,label,unit,value,se,status,rule"
        );
        assert!(csv.contains("system_gain_dn_per_e,System gain K,DN/e-,0.12345,0.00067,ok,"));
        assert!(csv.contains(
            "quantum_efficiency,Quantum efficiency,,,,unavailable,no photons per pixel given"
        ));
        let json = serde_json::to_value(&s).unwrap();
        let row = &json["sections"][0]["rows"][2];
        assert_eq!(row["status"], "out_of_rules");
        assert_eq!(row["rule"], "no point near saturation");
        assert_eq!(row["key"], "saturation_capacity_e");
        assert!(json["sections"][0]["rows"][1]["value"].is_null());
    }

    #[test]
    fn writes_every_file_it_names() {
        let d = tempfile::tempdir().unwrap();
        let s = sheet();
        let written = s.write(d.path()).unwrap();
        let names: Vec<String> = written
            .iter()
            .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
            .collect();
        let mut want = s.file_names();
        want.sort();
        let mut got = names.clone();
        got.sort();
        assert_eq!(got, want);
        for p in &written {
            assert!(std::fs::metadata(p).unwrap().len() > 0, "{}", p.display());
        }
    }
}

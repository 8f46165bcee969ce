//! The datasheet as the EMVA 1288 reference implementation's XML result file (`emva1288` 1.x,
//! `Results1288.xml()`, written by `process/routines.py` `dict_to_xml`): a `results` root, one
//! element per section (`dark_current`, `defect_pixel`, `info`, `linearity`, `sensitivity`,
//! `spatial`, sorted), in each one element per result (sorted by name), holding `section`,
//! `short`, `symbol`, `unit` and `latexname` where the reference tags them, then `value` or,
//! for a histogram, `data` with `bins`, `values` and `model` as space-separated numbers.
//!
//! Numbers are written as the reference writes them (Python's `str` of a float: shortest
//! round-trip digits, `nan` for a number it could not compute); `None` where the reference
//! lacks the input (the `_area` results need a pixel area, which a descriptor does not give;
//! the spatial results without spatial stacks). Units are the reference's LaTeX strings.
//!
//! Where it differs: the accumulated histograms have no `model` (the reference writes the
//! normal model of the absolute deviations, a curve its plots do not use); standard errors and
//! statuses are in datasheet.json and datasheet.csv, not here (the schema has no place for
//! them).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use super::datasheet::Datasheet;
use super::quantity::Quantity;
use super::spatial::{AccumulatedHistogram, Histogram, SpatialResult};
use crate::error::Result;

/// The file [`write_xml`] writes.
pub const XML_FILE: &str = "datasheet.xml";

/// One result's tags as the reference's docstrings give them: name, section, short, symbol,
/// unit, latexname ("" where the reference has no such tag).
type Meta = (
    &'static str,
    &'static str,
    &'static str,
    &'static str,
    &'static str,
    &'static str,
);

/// Every result of the reference's file, in its order (sections sorted, names sorted within).
#[rustfmt::skip]
const RESULTS: &[Meta] = &[
    ("u_I_mean", "dark_current", "Dark Current from mean", "$\\mu_{I.mean}$", "$e^-/s$", ""),
    ("u_I_mean_DN", "dark_current", "Dark Current from mean", "$\\mu_{I.mean.DN}$", "$DN/s$", ""),
    ("u_I_var", "dark_current", "Dark Current from variance", "$\\mu_{I.var}$", "$e^-/s$", "UIVar"),
    ("u_I_var_DN", "dark_current", "Dark Current from variance", "$\\mu_{I.var.DN}$", "$DN/s$", "UIVar"),
    ("histogram_DSNU", "defect_pixel", "DSNU histogram", "", "", ""),
    ("histogram_DSNU_accumulated", "defect_pixel", "accumulated DSNU histogram", "", "", ""),
    ("histogram_PRNU", "defect_pixel", "PRNU histogram", "", "", ""),
    ("histogram_PRNU_accumulated", "defect_pixel", "accumulated PRNU histogram", "", "", ""),
    ("index_start", "info", "Start array index", "", "", ""),
    ("LE_max", "linearity", "Max Linearity error", "$LE_{max}$", "\\%", "LEMax"),
    ("LE_min", "linearity", "Min Linearity error", "$LE_{min}$", "\\%", "LEMin"),
    ("index_linearity_max", "linearity", "Linearity fit maximum index", "", "", ""),
    ("index_linearity_min", "linearity", "Linearity fit minimun index", "", "", ""),
    ("DR", "sensitivity", "Dynamic Range", "DR", "", "DR"),
    ("DR_dB", "sensitivity", "Dynamic Range", "$DR_{dB}$", "dB", "DRDB"),
    ("K", "sensitivity", "System gain", "K", "$DN/e^-$", "K"),
    ("QE", "sensitivity", "Quantum efficiency", "$\\eta$", "\\%", "QE"),
    ("R", "sensitivity", "Responsivity", "R", "DN/p", ""),
    ("SNR_max", "sensitivity", "Signal-to-Noise Ratio", "$SNR_{max}$", "", "SNRMax"),
    ("SNR_max_bit", "sensitivity", "Maximum Signal to Noise Ratio in Bits", "$SNR_{max.bit}$", "bit", "SNRMaxBit"),
    ("SNR_max_dB", "sensitivity", "Maximum Signal to Noise Ratio in Db", "$SNR_{max.dB}$", "dB", "SNRMaxDB"),
    ("index_sensitivity_max", "sensitivity", "Sensitivity fit maximum index", "", "", ""),
    ("index_sensitivity_min", "sensitivity", "Sensitivity fit minimum index", "", "", ""),
    ("index_u_ysat", "sensitivity", "Saturation index", "", "", ""),
    ("inverse_K", "sensitivity", "Inverse of overall system gain", "1/K", "$e^-/DN$", "InvK"),
    ("inverse_SNR_max", "sensitivity", "Inverse Maximum Signal to Noise Ratio", "$SNR_{max}^{-1}$", "\\%", "InvSNRMax"),
    ("sigma_d", "sensitivity", "Temporal Dark Noise", "$\\sigma_d$", "$e^-$", "SigmaDark"),
    ("sigma_y_dark", "sensitivity", "Temporal Dark Noise", "$\\sigma_{y.dark}$", "DN", "SigmaYDark"),
    ("u_e_min", "sensitivity", "Sensitivity threshold", "$\\mu_{e.min}$", "$e^-$", "UEMin"),
    ("u_e_min_area", "sensitivity", "Sensitivity threshold", "$\\mu_{e.min.area}$", "$e^-/\\mu m^2$", "UEMin"),
    ("u_e_sat", "sensitivity", "Saturation Capacity", "$\\mu_{e.sat}$", "$e^-$", "UESat"),
    ("u_e_sat_area", "sensitivity", "Saturation Capacity", "$\\mu_{e.sat.area}$", "$e^-/\\mu m^2$", "UESat"),
    ("u_p_min", "sensitivity", "Absolute sensitivity threshold", "$\\mu_{p.min}$", "$p$", "UPMin"),
    ("u_p_min_area", "sensitivity", "Sensitivity threshold", "$\\mu_{p.min.area}$", "$p/\\mu m^2$", "UPMin"),
    ("u_p_sat", "sensitivity", "Saturation Capacity", "$\\mu_{p.sat}$", "$p$", "UPSat"),
    ("u_p_sat_area", "sensitivity", "Saturation Capacity", "$\\mu_{p.sat.area}$", "$p/\\mu m^2$", "UPSat"),
    ("DSNU1288", "spatial", "DSNU", "$DSNU_{1288}$", "$e^-$", "DSNU"),
    ("DSNU1288_DN", "spatial", "DSNU in DN", "$DSNU_{1288.DN}$", "DN", "DSNUDN"),
    ("DSNU1288_col", "spatial", "DSNUcol", "$DSNU_{1288.col}$", "$e^-$", "DSNUcol"),
    ("DSNU1288_pixel", "spatial", "DSNUpixel", "$DSNU_{1288.pixel}$", "$e^-$", "DSNUpixel"),
    ("DSNU1288_row", "spatial", "DSNUrow", "$DSNU_{1288.row}$", "$e^-$", "DSNUrow"),
    ("PRNU1288", "spatial", "PRNU", "$PRNU_{1288}$", "\\%", "PRNU"),
    ("PRNU1288_col", "spatial", "PRNUcol", "$PRNU_{1288.col}$", "\\%", "PRNUcol"),
    ("PRNU1288_pixel", "spatial", "PRNUpixel", "$PRNU_{1288.pixel}$", "\\%", "PRNUpixel"),
    ("PRNU1288_row", "spatial", "PRNUrow", "$PRNU_{1288.row}$", "\\%", "PRNUrow"),
    ("s_2_y", "spatial", "Spatial variance from image", "$s^2_{y}$", "DN2", ""),
    ("s_2_y_cav", "spatial", "Spatial variance from image", "$s^2_{y.cav}$", "DN2", ""),
    ("s_2_y_cav_dark", "spatial", "Spatial variance from image", "$s^2_{y.cav.dark}$", "DN2", ""),
    ("s_2_y_col", "spatial", "Spatial variance from image", "$s^2_{y.col}$", "DN2", ""),
    ("s_2_y_col_dark", "spatial", "Spatial variance from image", "$s^2_{y.col.dark}$", "DN2", ""),
    // The reference gives the dark one the bright one's symbol.
    ("s_2_y_dark", "spatial", "Spatial variance from image", "$s^2_{y}$", "DN2", ""),
    ("s_2_y_measured", "spatial", "Spatial variance measure", "$s^2_{y.measured}$", "DN2", ""),
    ("s_2_y_measured_dark", "spatial", "Spatial variance measured dark", "$s^2_{y.measured.dark}$", "DN2", ""),
    ("s_2_y_pixel", "spatial", "Spatial variance from image", "$s^2_{y.pixel}$", "DN2", ""),
    ("s_2_y_pixel_dark", "spatial", "Spatial variance from image", "$s^2_{y.pixel.dark}$", "DN2", ""),
    ("s_2_y_rav", "spatial", "Spatial variance from image", "$s^2_{y.rav}$", "DN2", ""),
    ("s_2_y_rav_dark", "spatial", "Spatial variance from image", "$s^2_{y.rav.dark}$", "DN2", ""),
    ("s_2_y_row", "spatial", "Spatial variance from image", "$s^2_{y.row}$", "DN2", ""),
    ("s_2_y_row_dark", "spatial", "Spatial variance from image", "$s^2_{y.row.dark}$", "DN2", ""),
    ("sigma_2_y_stack", "spatial", "Temporal variance stack", "$\\sigma^2_{y.stack}$", "DN2", ""),
    ("sigma_2_y_stack_dark", "spatial", "Temporal variance stack dark", "$\\sigma^2_{y.stack.dark}$", "DN2", ""),
];

/// What one result holds.
enum Content {
    /// A number or index, as written (`None` when the input for it is missing).
    Value(String),
    /// A histogram: (name, numbers as written) of `bins`, `values` and `model`.
    Data(Vec<(&'static str, String)>),
}

/// The reference's XML result file for `d` (the text, ending in a newline).
pub fn xml(d: &Datasheet) -> String {
    let mut out = String::from("<results>\n");
    let mut open: Option<&str> = None;
    for &(name, section, short, symbol, unit, latex) in RESULTS {
        if open != Some(section) {
            if let Some(s) = open {
                let _ = writeln!(out, "  </{s}>");
            }
            let _ = writeln!(out, "  <{section}>");
            open = Some(section);
        }
        let _ = writeln!(out, "    <{name}>");
        for (tag, text) in [
            ("section", section),
            ("short", short),
            ("symbol", symbol),
            ("unit", unit),
            ("latexname", latex),
        ] {
            if !text.is_empty() {
                let _ = writeln!(out, "      <{tag}>{}</{tag}>", escape(text));
            }
        }
        match content(d, name) {
            Content::Value(v) => {
                let _ = writeln!(out, "      <value>{}</value>", escape(&v));
            }
            Content::Data(arrays) => {
                out.push_str("      <data>\n");
                for (tag, text) in arrays {
                    let _ = writeln!(out, "        <{tag}>{}</{tag}>", escape(&text));
                }
                out.push_str("      </data>\n");
            }
        }
        let _ = writeln!(out, "    </{name}>");
    }
    if let Some(s) = open {
        let _ = writeln!(out, "  </{s}>");
    }
    out.push_str("</results>\n");
    out
}

/// Write [`xml`] of `d` into `dir` as [`XML_FILE`] (atomically); its path.
pub fn write_xml(d: &Datasheet, dir: &Path) -> Result<PathBuf> {
    let path = dir.join(XML_FILE);
    crate::output::write_atomic(&path, xml(d).as_bytes())?;
    Ok(path)
}

/// The content of result `name`.
fn content(d: &Datasheet, name: &str) -> Content {
    let t = &d.temporal;
    let k = t.system_gain_dn_per_e.value;
    let q = |q: &Quantity| Content::Value(py_float(q.value));
    let num = |v: f64| Content::Value(py_float(v));
    let index = |i: Option<usize>| Content::Value(i.map_or("None".into(), |i| i.to_string()));
    let none = || Content::Value("None".into());
    let lin = t.linearity_fit;
    match name {
        "u_I_mean" => q(&t.dark_current_mean_e_per_s),
        "u_I_mean_DN" => num(t.dark_current_mean_e_per_s.value * k),
        "u_I_var" => q(&t.dark_current_variance_e_per_s),
        "u_I_var_DN" => num(t.dark_current_variance_e_per_s.value * k),
        "index_start" => index(Some(0)),
        "LE_max" => q(&t.linearity_error_max_percent),
        "LE_min" => q(&t.linearity_error_min_percent),
        "index_linearity_max" => index(lin.map(|l| l[1])),
        "index_linearity_min" => index(lin.map(|l| l[0])),
        "DR" => q(&t.dynamic_range),
        "DR_dB" => q(&t.dynamic_range_db),
        "K" => q(&t.system_gain_dn_per_e),
        "QE" => q(&t.quantum_efficiency_percent),
        "R" => q(&t.responsivity_dn_per_photon),
        "SNR_max" => q(&t.snr_max),
        "SNR_max_bit" => num(t.snr_max.value.log2()),
        "SNR_max_dB" => q(&t.snr_max_db),
        "index_sensitivity_max" => index(Some(t.sensitivity_fit[1])),
        "index_sensitivity_min" => index(Some(t.sensitivity_fit[0])),
        "index_u_ysat" => index(Some(t.saturation_index)),
        "inverse_K" => num(1.0 / k),
        "inverse_SNR_max" => num(100.0 / t.snr_max.value),
        "sigma_d" => q(&t.dark_noise_e),
        "sigma_y_dark" => q(&t.dark_noise_dn),
        "u_e_min" => q(&t.sensitivity_threshold_e),
        "u_e_sat" => q(&t.saturation_capacity_e),
        "u_p_min" => q(&t.sensitivity_threshold_photons_per_px),
        "u_p_sat" => q(&t.saturation_photons_per_px),
        n if n.ends_with("_area") => none(),
        n => match &d.spatial {
            Some(s) => spatial(s, n),
            None => none(),
        },
    }
}

/// The content of a spatial or histogram result `name`.
fn spatial(s: &SpatialResult, name: &str) -> Content {
    let q = |q: &Quantity| Content::Value(py_float(q.value));
    let num = |v: f64| Content::Value(py_float(v));
    let (b, dk) = (&s.bright, &s.dark);
    match name {
        "histogram_DSNU" => histogram(&s.histogram_dsnu),
        "histogram_DSNU_accumulated" => accumulated(&s.histogram_dsnu_accumulated),
        "histogram_PRNU" => histogram(&s.histogram_prnu),
        "histogram_PRNU_accumulated" => accumulated(&s.histogram_prnu_accumulated),
        "DSNU1288" => q(&s.dsnu_e.total),
        "DSNU1288_DN" => q(&s.dsnu_dn.total),
        "DSNU1288_col" => q(&s.dsnu_e.col),
        "DSNU1288_pixel" => q(&s.dsnu_e.pixel),
        "DSNU1288_row" => q(&s.dsnu_e.row),
        "PRNU1288" => q(&s.prnu_percent.total),
        "PRNU1288_col" => q(&s.prnu_percent.col),
        "PRNU1288_pixel" => q(&s.prnu_percent.pixel),
        "PRNU1288_row" => q(&s.prnu_percent.row),
        "s_2_y" => q(&b.parts_dn2.total),
        "s_2_y_cav" => num(b.cav_dn2),
        "s_2_y_cav_dark" => num(dk.cav_dn2),
        "s_2_y_col" => q(&b.parts_dn2.col),
        "s_2_y_col_dark" => q(&dk.parts_dn2.col),
        "s_2_y_dark" => q(&dk.parts_dn2.total),
        "s_2_y_measured" => num(b.measured_dn2),
        "s_2_y_measured_dark" => num(dk.measured_dn2),
        "s_2_y_pixel" => q(&b.parts_dn2.pixel),
        "s_2_y_pixel_dark" => q(&dk.parts_dn2.pixel),
        "s_2_y_rav" => num(b.rav_dn2),
        "s_2_y_rav_dark" => num(dk.rav_dn2),
        "s_2_y_row" => q(&b.parts_dn2.row),
        "s_2_y_row_dark" => q(&dk.parts_dn2.row),
        "sigma_2_y_stack" => q(&b.temporal_var_dn2),
        "sigma_2_y_stack_dark" => q(&dk.temporal_var_dn2),
        other => unreachable!("{other} is not a result of the reference's file"),
    }
}

fn histogram(h: &Histogram) -> Content {
    let counts: Vec<String> = h.counts.iter().map(|c| c.to_string()).collect();
    Content::Data(vec![
        ("bins", floats(&h.bins_dn)),
        ("values", counts.join(" ")),
        ("model", floats(&h.model_counts)),
    ])
}

fn accumulated(h: &AccumulatedHistogram) -> Content {
    Content::Data(vec![
        ("bins", floats(&h.bins_dn)),
        ("values", floats(&h.pixels_percent)),
    ])
}

fn floats(v: &[f64]) -> String {
    v.iter().map(|x| py_float(*x)).collect::<Vec<_>>().join(" ")
}

/// `v` as Python's `str` writes a float: the shortest digits that read back as `v`, in
/// positional notation for decimal exponents -4 to 15 (with `.0` when whole), else as
/// `1.5e-05` / `1e+16`; `nan`, `inf`, `-inf`.
pub fn py_float(v: f64) -> String {
    if v.is_nan() {
        return "nan".into();
    }
    if v.is_infinite() {
        return if v > 0.0 { "inf" } else { "-inf" }.into();
    }
    if v == 0.0 {
        return if v.is_sign_negative() { "-0.0" } else { "0.0" }.into();
    }
    // Rust's `{:e}` gives the same shortest digits: "-1.2345e-7".
    let sci = format!("{v:e}");
    let (mantissa, exp) = sci.split_once('e').expect("`{:e}` has an exponent");
    let exp: i32 = exp.parse().expect("`{:e}` has an integer exponent");
    let (sign, mantissa) = match mantissa.strip_prefix('-') {
        Some(m) => ("-", m),
        None => ("", mantissa),
    };
    let digits: String = mantissa.chars().filter(|c| *c != '.').collect();
    if (-4..16).contains(&exp) {
        let n = digits.len() as i32;
        let text = if exp < 0 {
            format!("0.{}{digits}", "0".repeat((-exp - 1) as usize))
        } else if exp + 1 >= n {
            format!("{digits}{}.0", "0".repeat((exp + 1 - n) as usize))
        } else {
            let (a, b) = digits.split_at((exp + 1) as usize);
            format!("{a}.{b}")
        };
        format!("{sign}{text}")
    } else {
        let esign = if exp < 0 { '-' } else { '+' };
        format!("{sign}{mantissa}e{esign}{:02}", exp.abs())
    }
}

/// Text with XML's special characters in element content escaped (the same three as HTML).
fn escape(s: &str) -> String {
    crate::output::html_escape(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_read_as_python_writes_them() {
        for (v, s) in [
            (15.034566912963331, "15.034566912963331"),
            (100.0, "100.0"),
            (-0.012057536686551152, "-0.012057536686551152"),
            (0.0001, "0.0001"),
            (0.00001, "1e-05"),
            (-1.5e-7, "-1.5e-07"),
            (1e16, "1e+16"),
            (1.2345e20, "1.2345e+20"),
            (9999999999999998.0, "9999999999999998.0"),
            (79635.673, "79635.673"),
            (0.0, "0.0"),
            (f64::NAN, "nan"),
            (f64::NEG_INFINITY, "-inf"),
        ] {
            assert_eq!(py_float(v), s, "{v:?}");
        }
    }

    #[test]
    fn text_is_escaped() {
        assert_eq!(escape("a<b & c>d"), "a&lt;b &amp; c&gt;d");
    }
}

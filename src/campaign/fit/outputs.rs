//! The files of a decomposition: the maps as FITS with BUNIT and the fit's keywords,
//! decomposition.json, and em_gain_curve.csv; everything is rendered before the first file is
//! written, and each file is written beside its name and renamed into place.

use std::path::Path;

use serde::Serialize;

use super::classes::HotClass;
use super::result::{Decomposition, DecompositionSummary};
use crate::error::{Error, Result};
use crate::io::fits::{key, write_image, ImageData, KeyValue, Keyword};
use crate::output::{render, write_atomic, write_json, TableFormat};

/// Every file a decomposition can write (the CIC maps only with a register and CIC fitted,
/// em_gain_curve.csv only with fitted EM gains).
pub const OUTPUT_NAMES: [&str; 10] = [
    "offset_adu.fits",
    "offset_se_adu.fits",
    "dark_current_e_per_s.fits",
    "dark_current_se_e_per_s.fits",
    "cic_e_per_frame.fits",
    "cic_se_e_per_frame.fits",
    "fit_reduced_chi2.fits",
    "hot_class.fits",
    "decomposition.json",
    "em_gain_curve.csv",
];

/// decomposition.json: the summary and the files written.
#[derive(Serialize)]
struct Json<'a> {
    #[serde(flatten)]
    summary: &'a DecompositionSummary,
    outputs: Vec<&'static str>,
}

/// Keywords every map carries.
fn common_keys(s: &DecompositionSummary) -> Vec<Keyword> {
    let mut k = vec![
        key(
            "DNMODEL",
            KeyValue::Str(s.model.clone()),
            "model fitted per pixel",
        ),
        key(
            "NCOND",
            KeyValue::I64(s.conditions.len() as i64),
            "dark conditions fitted (see decomposition.json)",
        ),
        key(
            "FITDOF",
            KeyValue::I64(s.fit_quality.dof as i64),
            "degrees of freedom of each pixel's fit",
        ),
    ];
    if let Some(g) = s.conversion_gain_e_per_adu {
        k.push(key(
            "KGAIN",
            KeyValue::F64(g),
            "conversion gain used (e/adu)",
        ));
    }
    if let Some(t) = &s.temperature {
        k.push(key(
            "TREF",
            KeyValue::F64(t.reference_c),
            "D is at this temperature (C)",
        ));
        k.push(key(
            "TDOUBLE",
            KeyValue::F64(t.doubling_c),
            "D doubling temperature (C)",
        ));
    }
    k
}

/// The FITS maps: (name, data, BUNIT, what).
fn maps(d: &Decomposition) -> Vec<(&'static str, &[f64], &'static str, &'static str)> {
    let mut m: Vec<(&'static str, &[f64], &'static str, &'static str)> = vec![
        ("offset_adu.fits", &d.offset_adu, "adu", "offset F"),
        (
            "offset_se_adu.fits",
            &d.offset_se_adu,
            "adu",
            "standard error of F",
        ),
        (
            "dark_current_e_per_s.fits",
            &d.dark_current_e_per_s,
            "electron/s",
            "dark current D at TREF",
        ),
        (
            "dark_current_se_e_per_s.fits",
            &d.dark_current_se_e_per_s,
            "electron/s",
            "standard error of D",
        ),
    ];
    if let (Some(c), Some(se)) = (&d.cic_e_per_frame, &d.cic_se_e_per_frame) {
        m.push(("cic_e_per_frame.fits", c, "electron", "CIC per frame"));
        m.push((
            "cic_se_e_per_frame.fits",
            se,
            "electron",
            "standard error of CIC",
        ));
    }
    m
}

/// Write the decomposition into `out` (created if missing); `keys` are added to every FITS
/// header (e.g. the campaign's provenance). Returns the names written.
pub fn write_outputs(d: &Decomposition, out: &Path, keys: &[Keyword]) -> Result<Vec<String>> {
    let s = &d.summary;
    let maps = maps(d);
    let mut names: Vec<&'static str> = maps.iter().map(|m| m.0).collect();
    names.extend([
        "fit_reduced_chi2.fits",
        "hot_class.fits",
        "decomposition.json",
    ]);
    let csv = match &s.em_gain_curve {
        Some(c) => {
            names.push("em_gain_curve.csv");
            Some(render(&c.rows, TableFormat::Csv)?)
        }
        None => None,
    };
    let json = Json {
        summary: s,
        outputs: names.clone(),
    };
    // Encode before writing anything: a failure leaves no partial output.
    serde_json::to_string(&json)
        .map_err(|e| Error::Numeric(format!("cannot encode decomposition.json: {e}")))?;
    std::fs::create_dir_all(out).map_err(|e| Error::io(out, e))?;
    let mut common = common_keys(s);
    common.extend_from_slice(keys);
    let shape = (d.rows, d.cols);
    let with = |what: &str, extra: Vec<Keyword>| {
        let mut k = common.clone();
        k.push(key(
            "DNWHAT",
            KeyValue::Str(what.into()),
            "what the pixels hold",
        ));
        k.extend(extra);
        k
    };
    for (name, data, bunit, what) in &maps {
        write_image(
            &out.join(name),
            shape,
            ImageData::F64(data),
            bunit,
            &with(what, vec![]),
        )?;
    }
    let dimensionless = || key("BUNIT", KeyValue::Str(String::new()), "dimensionless");
    let q = &s.fit_quality;
    write_image(
        &out.join("fit_reduced_chi2.fits"),
        shape,
        ImageData::F64(&d.reduced_chi2),
        "",
        &with(
            "reduced chi2 of the pixel's fit",
            vec![
                dimensionless(),
                key(
                    "CHI2FLAG",
                    KeyValue::F64(q.flag_reduced_chi2_above),
                    "bad fit above",
                ),
                key(
                    "CHI2P",
                    KeyValue::F64(q.flag_p_value),
                    "p-value of the bad-fit flag",
                ),
            ],
        ),
    )?;
    let h = &s.hot_pixels;
    let classes: Vec<i32> = d.hot_class.iter().map(|c| *c as i32).collect();
    let mut ck = vec![
        dimensionless(),
        key(
            "WARMABV",
            KeyValue::F64(h.warm_above_e_per_s),
            "warm above (e/s)",
        ),
        key(
            "HOTABV",
            KeyValue::F64(h.hot_above_e_per_s),
            "hot above (e/s)",
        ),
    ];
    for c in [
        HotClass::Normal,
        HotClass::Warm,
        HotClass::Hot,
        HotClass::NotFitted,
    ] {
        let word = serde_json::to_value(c)
            .ok()
            .and_then(|v| v.as_str().map(str::to_string))
            .unwrap_or_default();
        ck.push(key(
            &format!("CLASS{}", c as i32),
            KeyValue::Str(word),
            "pixel class",
        ));
    }
    write_image(
        &out.join("hot_class.fits"),
        shape,
        ImageData::I32(&classes),
        "",
        &with("pixel class by dark current", ck),
    )?;
    if let Some(csv) = csv {
        write_atomic(&out.join("em_gain_curve.csv"), csv.as_bytes())?;
    }
    write_json(&out.join("decomposition.json"), &json)?;
    Ok(names.iter().map(|n| n.to_string()).collect())
}

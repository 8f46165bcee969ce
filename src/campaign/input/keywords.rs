//! Conditions from FITS header keywords: one stack per file, its exposure time (s), EM gain,
//! temperature (deg C), kind and light level read from keywords whose names are options. A
//! keyword is looked up in the primary header, then in the extensions in order (a
//! tile-compressed image keeps its keywords in its extension).

use std::path::{Path, PathBuf};

use super::stack::{check_condition, number, parse_kind, CampaignStack, Listed};
use crate::campaign::condition::{Condition, StackKind};
use crate::error::{Error, Result};
use crate::io::StackFormat;

/// Which keywords hold each file's condition.
#[derive(Clone, Debug, PartialEq)]
pub struct KeywordOptions {
    /// Exposure time keyword (its value in s; default `EXPTIME`).
    pub exposure_key: String,
    /// EM gain keyword (e-/e-); None: no EM register.
    pub em_gain_key: Option<String>,
    /// Sensor temperature keyword (deg C); None: not recorded.
    pub temperature_key: Option<String>,
    /// Keyword whose value says `dark` or `flat` (any case; `IMAGETYP` values such as
    /// `Dark Frame` and `Flat Field` too); None: every file is `kind`.
    pub kind_key: Option<String>,
    /// The kind of every file, when no keyword says it (or to check the keyword against).
    pub kind: Option<StackKind>,
    /// Light level keyword of flats (the input's own unit); None: not recorded.
    pub light_key: Option<String>,
}

impl Default for KeywordOptions {
    fn default() -> Self {
        KeywordOptions {
            exposure_key: "EXPTIME".into(),
            em_gain_key: None,
            temperature_key: None,
            kind_key: None,
            kind: None,
            light_key: None,
        }
    }
}

/// One [`CampaignStack`] per file of `files`, its condition from its header keywords.
pub fn read_keywords(files: &[PathBuf], options: &KeywordOptions) -> Result<Vec<CampaignStack>> {
    if options.kind_key.is_none() && options.kind.is_none() {
        return Err(Error::invalid(
            "kind",
            "say what the stacks are: `kind` (dark or flat) for all of them, or `kind_key`, the keyword that says it per file",
        ));
    }
    if files.is_empty() {
        return Err(Error::invalid("files", "no stack files given"));
    }
    files.iter().map(|f| stack_of(f, options)).collect()
}

/// The stack of the FITS file `path`.
fn stack_of(path: &Path, o: &KeywordOptions) -> Result<CampaignStack> {
    let bad = |what: String| Error::input(path, what);
    if StackFormat::detect(path)? != StackFormat::Fits {
        return Err(bad(
            "not a FITS file: conditions from header keywords need FITS headers (give TIFF or EXR stacks in a manifest)".into(),
        ));
    }
    // The header checks in Rust run before CFITSIO reads the file.
    crate::io::fits::scan(path)?;
    let mut file = fitsio::FitsFile::open(path)
        .map_err(|e| bad(format!("cannot open to read its keywords: {e}")))?;
    let mut text = |key: &str| keyword(&mut file, key).map_err(&bad);
    let Some(exposure) = text(&o.exposure_key)? else {
        return Err(bad(format!(
            "no keyword {}: its exposure time (s) is missing (name the keyword with the exposure key option, or use a manifest)",
            o.exposure_key
        )));
    };
    let mut optional = |key: &Option<String>| -> Result<Option<String>> {
        match key {
            Some(k) => text(k),
            None => Ok(None),
        }
    };
    let em_gain = optional(&o.em_gain_key)?;
    let temperature = optional(&o.temperature_key)?;
    let light = optional(&o.light_key)?;
    let kind_text = optional(&o.kind_key)?;
    let kind = kind_of(kind_text.as_deref(), o).map_err(bad)?;
    let num = |t: Option<String>, key: &Option<String>| -> Result<Option<f64>> {
        t.map(|t| number(&t, key.as_deref().unwrap_or("")).map_err(|w| bad(format!("keyword {w}"))))
            .transpose()
    };
    let condition = Condition {
        exposure_s: number(&exposure, &o.exposure_key).map_err(|w| bad(format!("keyword {w}")))?,
        em_gain: num(em_gain, &o.em_gain_key)?,
        temperature_c: num(temperature, &o.temperature_key)?,
        kind,
        light_level: num(light, &o.light_key)?.filter(|_| kind == StackKind::Flat),
    };
    check_condition(&condition).map_err(bad)?;
    Ok(CampaignStack {
        files: vec![path.to_path_buf()],
        condition,
        listed_in: Listed {
            source: path.to_path_buf(),
            line: None,
        },
    })
}

/// The kind a file's keyword says (`text`), checked against the option's; or why not.
fn kind_of(text: Option<&str>, o: &KeywordOptions) -> std::result::Result<StackKind, String> {
    let key = o.kind_key.as_deref().unwrap_or("");
    let from_key = match text {
        None if o.kind_key.is_some() && o.kind.is_none() => {
            return Err(format!(
                "no keyword {key}: whether it is a dark or a flat is missing"
            ))
        }
        None => None,
        Some(t) => {
            let lower = t.to_ascii_lowercase();
            let kind = match (lower.contains("dark"), lower.contains("flat")) {
                (true, false) => StackKind::Dark,
                (false, true) => StackKind::Flat,
                _ => parse_kind(t)
                    .map_err(|_| format!("keyword {key} = {t:?} says neither dark nor flat"))?,
            };
            Some(kind)
        }
    };
    match (from_key, o.kind) {
        (Some(k), Some(given)) if k != given => Err(format!(
            "conflicting kind: keyword {key} says {k:?}, the option says {given:?}"
        )),
        (Some(k), _) => Ok(k),
        (None, Some(given)) => Ok(given),
        (None, None) => unreachable!("refused above"),
    }
}

/// The value of `key` as written (a string unquoted) in the first HDU that has it, None when
/// none has; Err for a read failure.
fn keyword(file: &mut fitsio::FitsFile, key: &str) -> std::result::Result<Option<String>, String> {
    const KEY_NO_EXIST: i32 = 202;
    let hdus = file.num_hdus().map_err(|e| e.to_string())?;
    for i in 0..hdus {
        let hdu = file.hdu(i).map_err(|e| e.to_string())?;
        match hdu.read_key::<String>(file, key) {
            Ok(v) => return Ok(Some(v.trim().trim_matches('\'').trim().to_string())),
            Err(fitsio::errors::Error::Fits(e)) if e.status == KEY_NO_EXIST => continue,
            Err(e) => return Err(format!("keyword {key}: {e}")),
        }
    }
    Ok(None)
}

//! An EMVA 1288 descriptor file, read as the EMVA reference implementation (`emva1288` on
//! PyPI, `process/parser.py`) reads it, so that datasets made for it run unchanged:
//!
//! - `v VERSION` and `l NAME VALUE` (report values; ignored), `n BITS WIDTH HEIGHT` (once; the frames' shape is checked
//!   against it), `b TEXP_NS PHOTONS` (a bright point) and `d TEXP_NS` (a dark point), each
//!   followed by at least two `i PATH` lines, its images;
//! - blank lines and lines starting with `#` skipped; numbers may use a decimal comma;
//!   exposure times in ns; photons are the mean photons per pixel of the point;
//! - image paths relative to the descriptor's folder, with `\` read as a folder separator as
//!   written (datasets made on Windows), every component kept as written.
//!
//! Each point's images (two for the temporal points, more for the spatial ones) are one
//! stack: a `d` point is a dark at its exposure, a `b` point a flat with `light_level` = its
//! photons per pixel.

use std::collections::HashSet;
use std::path::{Path, PathBuf};

use super::stack::{beside, check_condition, number, CampaignStack, Listed};
use crate::campaign::condition::{Condition, StackKind};
use crate::detector::rts_table::read_csv_text;
use crate::error::{Error, Result};

/// The frame format an `n` line declares: bits per sample and the frame's width and height
/// (px).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EmvaFormat {
    /// Bits per sample.
    pub bits: u32,
    /// Frame width (columns, px).
    pub width: usize,
    /// Frame height (rows, px).
    pub height: usize,
}

/// Read the descriptor at `path`: its declared format (if it has an `n` line) and one
/// [`CampaignStack`] per measurement point, in order.
pub fn read_emva_descriptor(path: &Path) -> Result<(Option<EmvaFormat>, Vec<CampaignStack>)> {
    let text = read_csv_text(path, "an EMVA 1288 descriptor file")?;
    parse_emva(&text, path)
}

/// Parse the text of a descriptor; `source` names it in errors and places the images.
pub fn parse_emva(text: &str, source: &Path) -> Result<(Option<EmvaFormat>, Vec<CampaignStack>)> {
    let bad = |line: usize, what: String| Error::input(source, format!("line {line}: {what}"));
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let lines: Vec<(usize, Vec<&str>)> = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim()))
        .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'))
        .map(|(i, l)| (i, l.split_whitespace().collect()))
        .collect();
    let mut format = None;
    let mut stacks = Vec::new();
    let mut points = HashSet::new();
    let mut k = 0;
    while k < lines.len() {
        let (line, words) = &lines[k];
        let (line, words) = (*line, words.as_slice());
        k += 1;
        if words.len() < 2 {
            return Err(bad(
                line,
                format!(
                    "{:?}: every line is a letter and its values",
                    words.join(" ")
                ),
            ));
        }
        let (exposure_ns, kind, photons) = match words[0] {
            // `v` the version; `l NAME VALUE` a value for the reference's LaTeX report.
            "v" | "l" => continue,
            "n" => {
                if format.is_some() {
                    return Err(bad(
                        line,
                        "a second `n bits width height` line (one per file)".into(),
                    ));
                }
                format = Some(parse_format(words).map_err(|w| bad(line, w))?);
                continue;
            }
            "b" if words.len() == 3 => (
                value(words[1], "exposure time (ns)").map_err(|w| bad(line, w))?,
                StackKind::Flat,
                value(words[2], "photon count").map_err(|w| bad(line, w))?,
            ),
            "d" if words.len() == 2 => (
                value(words[1], "exposure time (ns)").map_err(|w| bad(line, w))?,
                StackKind::Dark,
                0.0,
            ),
            "b" => return Err(bad(line, "should be `b exposure_ns photons`".into())),
            "d" => return Err(bad(line, "should be `d exposure_ns`".into())),
            other => {
                return Err(bad(
                    line,
                    format!("unknown line kind {other:?} (v, l, n, b, d or i)"),
                ))
            }
        };
        let mut files = Vec::new();
        while let Some((l, w)) = lines.get(k).filter(|(_, w)| w[0] == "i") {
            if w.len() != 2 {
                return Err(bad(*l, "should be `i path` (a path without spaces)".into()));
            }
            files.push(image_path(source, w[1]));
            k += 1;
        }
        if files.len() < 2 {
            return Err(bad(
                line,
                format!(
                    "{} image line(s) follow: each point needs at least two `i path` lines",
                    files.len()
                ),
            ));
        }
        // The reference parser keeps one set per exposure, photon count and kind (temporal:
        // two images, spatial: more).
        let key = (exposure_ns.to_bits(), photons.to_bits(), files.len() == 2);
        if !points.insert(key) {
            return Err(bad(
                line,
                format!(
                    "a second set of images at exposure {exposure_ns} ns and {photons} photons"
                ),
            ));
        }
        let condition = Condition {
            exposure_s: exposure_ns * 1e-9,
            em_gain: None,
            temperature_c: None,
            kind,
            light_level: (kind == StackKind::Flat).then_some(photons),
        };
        check_condition(&condition).map_err(|w| bad(line, w))?;
        stacks.push(CampaignStack {
            files,
            condition,
            listed_in: Listed {
                source: source.to_path_buf(),
                line: Some(line),
            },
        });
    }
    if stacks.is_empty() {
        return Err(Error::input(
            source,
            "the descriptor lists no `b` or `d` points",
        ));
    }
    Ok((format, stacks))
}

/// A number as the reference reads it (a decimal comma allowed), or why not.
fn value(text: &str, what: &str) -> std::result::Result<f64, String> {
    number(&text.replace(',', "."), what)
}

/// The format of an `n bits width height` line, or why not.
fn parse_format(words: &[&str]) -> std::result::Result<EmvaFormat, String> {
    let [_, bits, width, height] = words else {
        return Err("should be `n bits width height`".into());
    };
    let whole = |t: &str, what: &str| {
        t.parse::<usize>()
            .ok()
            .filter(|v| *v > 0)
            .ok_or_else(|| format!("{what} {t:?} is not a positive whole number"))
    };
    Ok(EmvaFormat {
        bits: whole(bits, "bits")? as u32,
        width: whole(width, "width")?,
        height: whole(height, "height")?,
    })
}

/// An image path as written (`\` and `/` both separate folders), beside the descriptor.
fn image_path(descriptor: &Path, written: &str) -> PathBuf {
    let relative: PathBuf = written
        .split(['\\', '/'])
        .filter(|c| !c.is_empty())
        .collect();
    let path = if written.starts_with('/') {
        Path::new("/").join(relative)
    } else {
        relative
    };
    beside(descriptor, &path)
}

#[cfg(test)]
mod tests {
    use super::*;

    const EXAMPLE: &str = "# EMVA 1288 test\nv 3.0\nl camera_name Test camera\nn 12 640 480\nb 100000 0,5\ni images\\b1.tif\ni images\\b2.tif\n\nd 100000\ni images/d1.tif\ni images/d2.tif\nd 2000000\ni d3.tif\ni d4.tif\ni d5.tif\n";

    #[test]
    fn points_become_stacks_with_ns_exposures_and_windows_paths() {
        let (format, s) = parse_emva(EXAMPLE, Path::new("/data/desc.txt")).unwrap();
        assert_eq!(
            format,
            Some(EmvaFormat {
                bits: 12,
                width: 640,
                height: 480
            })
        );
        assert_eq!(s.len(), 3);
        assert_eq!(s[0].condition.kind, StackKind::Flat);
        assert_eq!(s[0].condition.light_level, Some(0.5));
        assert!((s[0].condition.exposure_s - 1e-4).abs() < 1e-18);
        assert_eq!(
            s[0].files,
            vec![
                PathBuf::from("/data/images/b1.tif"),
                PathBuf::from("/data/images/b2.tif")
            ]
        );
        assert_eq!(s[1].condition.kind, StackKind::Dark);
        assert_eq!(s[1].condition.light_level, None);
        assert_eq!(s[2].files.len(), 3);
        assert_eq!(s[2].listed_in.line, Some(12));
    }

    #[test]
    fn bad_descriptors_refused_naming_the_line() {
        let cases = [
            ("d 100\ni a.tif\n", "line 1: 1 image line(s) follow"),
            ("n 8 4\n", "line 1: should be `n bits width height`"),
            ("n 8 4 4\nn 8 4 4\n", "line 2: a second `n"),
            ("x 1\n", "unknown line kind \"x\""),
            ("l\n", "every line is a letter and its values"),
            ("d 1 2\ni a\ni b\n", "should be `d exposure_ns`"),
            ("d abc\ni a\ni b\n", "exposure time (ns) \"abc\""),
            (
                "d 1\ni a\ni b\nd 1\ni c\ni d\n",
                "line 4: a second set of images",
            ),
            ("v 1\n", "lists no `b` or `d` points"),
        ];
        for (text, want) in cases {
            let e = parse_emva(text, Path::new("d.txt"))
                .unwrap_err()
                .to_string();
            assert!(e.contains("d.txt") && e.contains(want), "{text:?}: {e}");
        }
    }
}

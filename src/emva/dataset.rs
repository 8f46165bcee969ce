//! An EMVA 1288 dataset: what the standard's measurement consists of, as paths to frames.
//!
//! A temporal point is a pair of bright frames and a pair of dark frames at one exposure time
//! (with the mean photons per pixel of the bright pair, when the input gives it); the spatial
//! stacks are many frames at one bright point (about 50 % of saturation) and dark at the same
//! exposure.
//!
//! The dataset is read from an EMVA descriptor file or a campaign manifest, both through the
//! campaign's input readers, and grouped the way the reference implementation (`emva1288`,
//! `process/parser.py`, `loader.py`, `data.py`) groups a descriptor's points:
//!
//! - a set of exactly two images is temporal, a set of more is spatial;
//! - every exposure of a bright pair needs a dark pair at the same exposure (several bright
//!   pairs at one exposure, an irradiance series, share it); a dark pair at an exposure
//!   without a bright pair is refused, as the reference refuses it;
//! - the spatial stacks are one bright and one dark stack at one exposure (or a dark stack
//!   alone: DSNU without PRNU; or none: no spatial numbers).
//!
//! In a campaign manifest each row names one single-frame image file (as a descriptor's `i`
//! lines do), `kind` `flat` or `dark`, `exposure_s`, and `light_level` the mean photons per
//! pixel of a flat (empty: not known, no QE); consecutive rows with one condition form one
//! set, so two rows are a pair and more rows a spatial stack, as in a descriptor.
//!
//! Everything that can be checked without reading a frame is checked when the dataset is
//! read (missing files, a bright pair without its dark pair, fewer than [`MIN_POINTS`]
//! points); [`EmvaDataset::check_frames`] reads a handful of frames to check what needs them
//! (frame shape against the `n` line, a saturated spatial stack). What breaks a rule of the
//! standard without making the numbers meaningless is listed by
//! [`EmvaDataset::rule_breaks`] and [`FrameCheck::rule_breaks`], for the calculators to
//! attach to the numbers it affects ([`crate::emva::Quantity::out_of_rules`]).

use std::path::{Path, PathBuf};

use crate::campaign::input::{
    read_emva_descriptor, read_manifest, CampaignStack, EmvaFormat, Listed,
};
use crate::campaign::StackKind;
use crate::error::{Error, Result};
use crate::io::FrameStack;

/// Fewest photon-transfer points detnoise computes with: fewer cannot place points below
/// 70 % of saturation for the gain fit, between 5 and 95 % for the linearity fit, and one at
/// saturation.
pub const MIN_POINTS: usize = 5;

/// Photon-transfer points the standard asks for (at least 50 irradiation steps from dark to
/// saturation); fewer is computed, out of the rules. The reference implementation itself
/// takes any number (its examples and sample report use 50).
pub const STANDARD_POINTS: usize = 50;

/// Fraction of a frame's pixels at the largest sample value above which the frame is
/// saturated (clipped by the converter).
pub const SATURATED_FRACTION: f64 = 0.01;

/// One point of the photon-transfer series: two bright and two dark frames at one exposure.
#[derive(Clone, Debug, PartialEq)]
pub struct PairPoint {
    /// Exposure time (s).
    pub exposure_s: f64,
    /// Mean photons per pixel of the bright pair (None: the input does not give it; QE then
    /// cannot be computed).
    pub photons_per_px: Option<f64>,
    /// The two bright frames.
    pub bright: [PathBuf; 2],
    /// The two dark frames at the same exposure.
    pub dark: [PathBuf; 2],
}

/// A spatial stack: many frames at one condition, for DSNU / PRNU.
#[derive(Clone, Debug, PartialEq)]
pub struct SpatialStack {
    /// Exposure time (s).
    pub exposure_s: f64,
    /// Mean photons per pixel (None for the dark stack, or when the input does not give it).
    pub photons_per_px: Option<f64>,
    /// The stack's frames, in order.
    pub files: Vec<PathBuf>,
}

/// A whole EMVA 1288 dataset, as paths (frames are streamed when computed).
#[derive(Clone, Debug, PartialEq)]
pub struct EmvaDataset {
    /// Where it was described (descriptor file or manifest), for messages.
    pub source: PathBuf,
    /// Declared bits per sample and frame size, when the input gives them.
    pub format: Option<EmvaFormat>,
    /// The photon-transfer series, by increasing photons (or exposure).
    pub points: Vec<PairPoint>,
    /// The bright spatial stack (None: the input has none).
    pub spatial_bright: Option<SpatialStack>,
    /// The dark spatial stack (None: the input has none).
    pub spatial_dark: Option<SpatialStack>,
}

/// Which numbers of the datasheet a broken rule concerns.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum DatasheetPart {
    /// The photon-transfer numbers: K, QE, temporal dark noise, saturation, SNR, DR,
    /// sensitivity threshold, linearity.
    Temporal,
    /// Dark current (from the mean and the variance of the dark pairs).
    DarkCurrent,
    /// DSNU, PRNU, spectrograms, profiles, histograms and defect pixels.
    Spatial,
}

/// A rule of the standard the dataset breaks, and the numbers it concerns.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct RuleBreak {
    /// The numbers it concerns.
    pub part: DatasheetPart,
    /// The rule, in words, with the dataset's figure (e.g. "12 photon-transfer points, the
    /// standard asks for at least 50").
    pub rule: String,
}

impl EmvaDataset {
    /// Read the EMVA descriptor file at `path` (as the reference implementation reads it:
    /// Windows paths, decimal commas) and check it before any frame is read.
    pub fn from_descriptor(path: &Path) -> Result<EmvaDataset> {
        let (format, stacks) = read_emva_descriptor(path)?;
        EmvaDataset::from_stacks(path, format, stacks)
    }

    /// Read the campaign manifest at `path` as an EMVA dataset (each row one single-frame
    /// image; consecutive rows with one condition form a pair or a spatial stack) and check it
    /// before any frame is read.
    pub fn from_manifest(path: &Path) -> Result<EmvaDataset> {
        let rows = read_manifest(path)?;
        EmvaDataset::from_stacks(path, None, consecutive_sets(rows))
    }

    /// Group the sets of images an input lists (each a pair or a spatial stack, with the line
    /// that listed it) into a dataset, refusing what cannot be computed.
    pub fn from_stacks(
        source: &Path,
        format: Option<EmvaFormat>,
        sets: Vec<CampaignStack>,
    ) -> Result<EmvaDataset> {
        require_files(source, &sets)?;
        let (temporal, spatial): (Vec<_>, Vec<_>) =
            sets.into_iter().partition(|s| s.files.len() == 2);
        let points = pair_points(source, temporal)?;
        let (spatial_bright, spatial_dark) = spatial_stacks(source, spatial)?;
        Ok(EmvaDataset {
            source: source.to_path_buf(),
            format,
            points,
            spatial_bright,
            spatial_dark,
        })
    }

    /// The distinct exposure times (s) of the photon-transfer series, increasing (dark
    /// current needs at least three).
    pub fn exposures_s(&self) -> Vec<f64> {
        let mut t: Vec<f64> = self.points.iter().map(|p| p.exposure_s).collect();
        t.sort_by(f64::total_cmp);
        t.dedup_by(|a, b| same_exposure(*a, *b));
        t
    }

    /// The rules of the standard the dataset's listing breaks (no frame read): each with the
    /// numbers it concerns, for [`crate::emva::Quantity::out_of_rules`].
    pub fn rule_breaks(&self) -> Vec<RuleBreak> {
        let mut breaks = Vec::new();
        let n = self.points.len();
        if n < STANDARD_POINTS {
            breaks.push(RuleBreak {
                part: DatasheetPart::Temporal,
                rule: format!(
                    "{n} photon-transfer points: the standard asks for at least {STANDARD_POINTS} steps from dark to saturation"
                ),
            });
        }
        let exposures = self.exposures_s().len();
        if exposures > 2 && exposures < STANDARD_POINTS.min(n) {
            // An irradiance series with a few exposure times: the dark current fit has few
            // points even when the photon-transfer series is complete.
            breaks.push(RuleBreak {
                part: DatasheetPart::DarkCurrent,
                rule: format!(
                    "dark pairs at {exposures} exposure times: the dark current is fitted from few points"
                ),
            });
        }
        breaks
    }

    /// The rules broken that concern `part`, as the text a
    /// [`crate::emva::Quantity::out_of_rules`] status carries (None: no rule broken).
    pub fn rule_text(breaks: &[RuleBreak], part: DatasheetPart) -> Option<String> {
        let rules: Vec<&str> = breaks
            .iter()
            .filter(|b| b.part == part)
            .map(|b| b.rule.as_str())
            .collect();
        (!rules.is_empty()).then(|| rules.join("; "))
    }
}

/// Consecutive manifest rows with one condition, merged into one set (a pair or a stack).
fn consecutive_sets(rows: Vec<CampaignStack>) -> Vec<CampaignStack> {
    let mut sets: Vec<CampaignStack> = Vec::new();
    for row in rows {
        match sets.last_mut() {
            Some(last) if last.condition == row.condition => last.files.extend(row.files),
            _ => sets.push(row),
        }
    }
    sets
}

/// Two exposure times read from the same number (a descriptor's ns times times 1e-9 may
/// differ in the last bit only).
fn same_exposure(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-9 * a.abs().max(b.abs())
}

/// `t` rounded to 12 significant digits, for messages (a descriptor's 2000 ns is 2e-6 s, not
/// 2.0000000000000003e-6).
fn shown(t: f64) -> f64 {
    format!("{t:.11e}").parse().unwrap_or(t)
}

/// Refuse a listing naming files that do not exist: the first few, with their lines.
fn require_files(source: &Path, sets: &[CampaignStack]) -> Result<()> {
    let missing: Vec<String> = sets
        .iter()
        .flat_map(|s| {
            s.files
                .iter()
                .filter(|f| !f.is_file())
                .map(move |f| match s.listed_in.line {
                    Some(l) => format!("{} (line {l})", f.display()),
                    None => f.display().to_string(),
                })
        })
        .collect();
    match missing.as_slice() {
        [] => Ok(()),
        some => {
            let shown = some.iter().take(5).cloned().collect::<Vec<_>>().join(", ");
            let more = if some.len() > 5 {
                format!(" and {} more", some.len() - 5)
            } else {
                String::new()
            };
            Err(Error::input(
                source,
                format!(
                    "{} image file(s) it names do not exist: {shown}{more}",
                    some.len()
                ),
            ))
        }
    }
}

/// Where a set was listed, for messages: "line 12" (or the list itself).
fn at(listed: &Listed) -> String {
    listed
        .line
        .map_or_else(String::new, |l| format!("line {l}: "))
}

/// The photon-transfer points: each bright pair with the dark pair at its exposure, sorted by
/// photons (exposure when photons are not given).
fn pair_points(source: &Path, sets: Vec<CampaignStack>) -> Result<Vec<PairPoint>> {
    let (bright, dark): (Vec<_>, Vec<_>) = sets
        .into_iter()
        .partition(|s| s.condition.kind == StackKind::Flat);
    if let Some(lonely) = dark.iter().find(|d| {
        !bright
            .iter()
            .any(|b| same_exposure(b.condition.exposure_s, d.condition.exposure_s))
    }) {
        return Err(Error::input(
            source,
            format!(
                "{}a dark pair at exposure {} s with no bright pair at that exposure (the reference implementation refuses it too: every exposure has one dark and at least one bright pair)",
                at(&lonely.listed_in),
                shown(lonely.condition.exposure_s)
            ),
        ));
    }
    if bright.len() < MIN_POINTS {
        return Err(Error::input(
            source,
            format!(
                "{} photon-transfer point(s) (bright pairs): at least {MIN_POINTS} are needed to compute (the standard asks for {STANDARD_POINTS})",
                bright.len()
            ),
        ));
    }
    let given = bright
        .iter()
        .filter(|b| b.condition.light_level.is_some())
        .count();
    if given != 0 && given != bright.len() {
        let without = bright
            .iter()
            .find(|b| b.condition.light_level.is_none())
            .expect("some have none");
        return Err(Error::input(
            source,
            format!(
                "{}a bright pair without its photons per pixel while {given} others give theirs (give every flat's light_level, or none)",
                at(&without.listed_in)
            ),
        ));
    }
    let mut points = bright
        .iter()
        .map(|b| {
            let t = b.condition.exposure_s;
            let d = dark
                .iter()
                .find(|d| same_exposure(t, d.condition.exposure_s))
                .ok_or_else(|| {
                    Error::input(
                        source,
                        format!(
                            "{}a bright pair at exposure {} s has no dark pair at that exposure (each exposure needs two dark images)",
                            at(&b.listed_in),
                            shown(t)
                        ),
                    )
                })?;
            Ok(PairPoint {
                exposure_s: t,
                photons_per_px: b.condition.light_level,
                bright: [b.files[0].clone(), b.files[1].clone()],
                dark: [d.files[0].clone(), d.files[1].clone()],
            })
        })
        .collect::<Result<Vec<_>>>()?;
    points.sort_by(|a, b| {
        let key = |p: &PairPoint| (p.photons_per_px.unwrap_or(0.0), p.exposure_s);
        let (ka, kb) = (key(a), key(b));
        ka.0.total_cmp(&kb.0).then(ka.1.total_cmp(&kb.1))
    });
    Ok(points)
}

/// The spatial stacks: one bright and one dark at one exposure, a dark alone, or none.
fn spatial_stacks(
    source: &Path,
    sets: Vec<CampaignStack>,
) -> Result<(Option<SpatialStack>, Option<SpatialStack>)> {
    let mut bright: Option<CampaignStack> = None;
    let mut dark: Option<CampaignStack> = None;
    for s in sets {
        let slot = match s.condition.kind {
            StackKind::Flat => &mut bright,
            StackKind::Dark => &mut dark,
        };
        if let Some(first) = slot {
            return Err(Error::input(
                source,
                format!(
                    "{}a second {} spatial stack (the first{}): the standard takes one bright and one dark stack",
                    at(&s.listed_in),
                    if s.condition.kind == StackKind::Flat { "bright" } else { "dark" },
                    first.listed_in.line.map_or_else(String::new, |l| format!(" at line {l}"))
                ),
            ));
        }
        *slot = Some(s);
    }
    match (&bright, &dark) {
        (Some(b), None) => {
            return Err(Error::input(
                source,
                format!(
                    "{}a bright spatial stack ({} images) without a dark spatial stack at its exposure (PRNU needs both)",
                    at(&b.listed_in),
                    b.files.len()
                ),
            ))
        }
        (Some(b), Some(d))
            if !same_exposure(b.condition.exposure_s, d.condition.exposure_s) =>
        {
            return Err(Error::input(
                source,
                format!(
                    "{}the bright spatial stack is at exposure {} s, the dark one ({}) at {} s: both must be at one exposure",
                    at(&b.listed_in),
                    shown(b.condition.exposure_s),
                    d.listed_in.line.map_or_else(|| "its list".into(), |l| format!("line {l}")),
                    shown(d.condition.exposure_s)
                ),
            ))
        }
        _ => {}
    }
    let stack = |s: CampaignStack| SpatialStack {
        exposure_s: s.condition.exposure_s,
        photons_per_px: s.condition.light_level,
        files: s.files,
    };
    Ok((bright.map(stack), dark.map(stack)))
}

/// What the few frames [`EmvaDataset::check_frames`] reads show.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct FrameCheck {
    /// Frame shape (rows, cols).
    pub shape: (usize, usize),
    /// Largest value the camera gives (DN): 2^bits - 1 when the input declares its bits, else
    /// the largest of the stored integer type (None: float samples).
    pub saturation_dn: Option<f64>,
    /// Temporal variance of the brightest point above dark, as a fraction of the linear
    /// prediction from the point at a quarter of the series (below 0.5: past saturation;
    /// None: not computable).
    pub brightest_variance_ratio: Option<f64>,
    /// Signal above dark of the bright spatial stack's first frame, as a fraction of the
    /// brightest point's (None: no spatial stack, or not computable).
    pub spatial_signal_ratio: Option<f64>,
    /// Rules of the standard the frames show broken.
    pub rule_breaks: Vec<RuleBreak>,
}

/// Mean and (for a pair) temporal variance of frames, from first frames only.
struct FrameReader {
    shape: Option<(usize, usize)>,
    declared: Option<EmvaFormat>,
    saturation_dn: Option<f64>,
}

impl FrameReader {
    /// Frame 0 of `path`, refused unless the file holds one frame of the dataset's shape.
    fn frame(&mut self, path: &Path) -> Result<Vec<f64>> {
        let stack = FrameStack::open(&[path.to_path_buf()])?;
        if stack.frames != 1 {
            return Err(Error::input(
                path,
                format!(
                    "holds {} frames: each image of an EMVA dataset is one single-frame file",
                    stack.frames
                ),
            ));
        }
        let (rows, cols) = stack.shape;
        if let Some(f) = self.declared.filter(|f| (f.height, f.width) != stack.shape) {
            return Err(Error::input(
                path,
                format!(
                    "frame 0: {rows} rows x {cols} columns, but the descriptor's `n` line declares width {} and height {} ({} rows x {} columns)",
                    f.width, f.height, f.height, f.width
                ),
            ));
        }
        match self.shape {
            Some(s) if s != stack.shape => {
                return Err(Error::input(
                    path,
                    format!(
                        "frame 0: {rows} rows x {cols} columns, the dataset's other images {} x {}",
                        s.0, s.1
                    ),
                ))
            }
            _ => self.shape = Some(stack.shape),
        }
        if self.saturation_dn.is_none() {
            self.saturation_dn = match self.declared {
                Some(f) => Some(2f64.powi(f.bits as i32) - 1.0),
                None => stack.saturation_value(),
            };
        }
        let mut values = vec![0.0; stack.pixels()];
        stack.reader().next_frame(&mut values)?;
        if let (Some(top), Some(f)) = (self.saturation_dn, self.declared) {
            if let Some(v) = values.iter().copied().find(|v| *v > top) {
                return Err(Error::input(
                    path,
                    format!(
                        "frame 0: value {v} above {top}, the largest of the {} bits the descriptor's `n` line declares",
                        f.bits
                    ),
                ));
            }
        }
        Ok(values)
    }

    /// Mean (DN) of frame 0 of `path`.
    fn mean(&mut self, path: &Path) -> Result<f64> {
        Ok(mean(&self.frame(path)?))
    }

    /// Mean (DN) and temporal variance (DN^2, from the difference, so free of the drift of the
    /// mean between the two frames) of a pair.
    fn pair(&mut self, pair: &[PathBuf; 2]) -> Result<(f64, f64)> {
        self.pair_and_first(pair).map(|(m, v, _)| (m, v))
    }

    /// [`FrameReader::pair`] and the pair's first frame.
    fn pair_and_first(&mut self, pair: &[PathBuf; 2]) -> Result<(f64, f64, Vec<f64>)> {
        let a = self.frame(&pair[0])?;
        let b = self.frame(&pair[1])?;
        let diff: Vec<f64> = a.iter().zip(&b).map(|(x, y)| x - y).collect();
        let m = mean(&diff);
        let var = diff.iter().map(|d| (d - m) * (d - m)).sum::<f64>() / (diff.len() as f64 - 1.0);
        Ok(((mean(&a) + mean(&b)) / 2.0, var / 2.0, a))
    }

    /// Fraction of `values` at the largest value the camera gives.
    fn saturated_fraction(&self, values: &[f64]) -> f64 {
        self.saturation_dn.map_or(0.0, |top| {
            values.iter().filter(|v| **v >= top).count() as f64 / values.len() as f64
        })
    }
}

fn mean(values: &[f64]) -> f64 {
    values.iter().sum::<f64>() / values.len() as f64
}

impl EmvaDataset {
    /// Check what needs frames, reading a few first frames only (of the brightest point, of
    /// the point a quarter up the series and of the spatial stacks): every file read holds
    /// one frame of one shape, the shape and values the `n` line declares; the bright spatial
    /// stack is refused when saturated (1 % of its pixels at the largest value, or its signal
    /// 95 % of the saturated brightest point's). Returns the rules of the standard the frames
    /// show broken (no point past saturation, a spatial stack far from 50 % of saturation).
    pub fn check_frames(&self) -> Result<FrameCheck> {
        let mut reader = FrameReader {
            shape: None,
            declared: self.format,
            saturation_dn: None,
        };
        let Some(brightest) = self.points.last() else {
            return Err(Error::input(
                &self.source,
                "no photon-transfer points to check",
            ));
        };
        let reference = &self.points[(self.points.len() - 1) / 4];
        let (b_mean, b_var, brightest_frame) = reader.pair_and_first(&brightest.bright)?;
        let (d_mean, d_var) = reader.pair(&brightest.dark)?;
        let (r_mean, r_var) = reader.pair(&reference.bright)?;
        let (rd_mean, rd_var) = reader.pair(&reference.dark)?;
        let k_ref = (r_var - rd_var) / (r_mean - rd_mean);
        let clipped = reader.saturated_fraction(&brightest_frame) >= SATURATED_FRACTION;
        let brightest_variance_ratio = (k_ref.is_finite() && k_ref > 0.0 && b_mean > d_mean)
            .then(|| (b_var - d_var) / (k_ref * (b_mean - d_mean)));
        let saturated = clipped || brightest_variance_ratio.is_some_and(|r| r < 0.5);
        let mut rule_breaks = Vec::new();
        if !saturated {
            rule_breaks.push(RuleBreak {
                part: DatasheetPart::Temporal,
                rule: match brightest_variance_ratio {
                    Some(r) => format!(
                        "no photon-transfer point past saturation (the brightest point's temporal variance is {:.0} % of the linear prediction): the standard's series goes up to saturation",
                        100.0 * r
                    ),
                    None => "no photon-transfer point shown past saturation: the standard's series goes up to saturation".into(),
                },
            });
        }
        let mut spatial_signal_ratio = None;
        if let (Some(sb), Some(sd)) = (&self.spatial_bright, &self.spatial_dark) {
            let frame = reader.frame(&sb.files[0])?;
            let fraction = reader.saturated_fraction(&frame);
            if fraction >= SATURATED_FRACTION {
                return Err(Error::input(
                    &sb.files[0],
                    format!(
                        "frame 0 of the bright spatial stack is saturated: {:.1} % of its pixels at {} DN (DSNU and PRNU need it at about 50 % of saturation)",
                        100.0 * fraction,
                        reader.saturation_dn.unwrap_or(f64::NAN)
                    ),
                ));
            }
            let ratio = (mean(&frame) - reader.mean(&sd.files[0])?) / (b_mean - d_mean);
            spatial_signal_ratio = ratio.is_finite().then_some(ratio);
            if saturated && ratio >= 0.95 {
                return Err(Error::input(
                    &sb.files[0],
                    format!(
                        "the bright spatial stack is saturated: its signal above dark is {:.0} % of the saturated brightest point's (DSNU and PRNU need it at about 50 % of saturation)",
                        100.0 * ratio
                    ),
                ));
            }
            if saturated && !(0.2..=0.8).contains(&ratio) {
                rule_breaks.push(RuleBreak {
                    part: DatasheetPart::Spatial,
                    rule: format!(
                        "the bright spatial stack's signal is {:.0} % of the saturated brightest point's: the standard takes it at about 50 % of saturation",
                        100.0 * ratio
                    ),
                });
            }
        }
        Ok(FrameCheck {
            shape: reader.shape.expect("frames were read"),
            saturation_dn: reader.saturation_dn,
            brightest_variance_ratio,
            spatial_signal_ratio,
            rule_breaks,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A folder with empty files for every `i` line of `text`, and the descriptor itself.
    fn descriptor(text: &str) -> (tempfile::TempDir, PathBuf) {
        let dir = tempfile::tempdir().unwrap();
        for line in text.lines().filter(|l| l.starts_with("i ")) {
            let path = dir.path().join(line[2..].replace('\\', "/"));
            std::fs::create_dir_all(path.parent().unwrap()).unwrap();
            std::fs::write(path, b"").unwrap();
        }
        let path = dir.path().join("EMVA1288descriptor.txt");
        std::fs::write(&path, text).unwrap();
        (dir, path)
    }

    /// A descriptor of `n` exposure-time points (bright and dark pairs, ns) and, when
    /// `spatial`, 4-image spatial stacks at the third exposure.
    fn series(n: usize, spatial: bool) -> String {
        let mut text = String::from("v 4.0\nn 12 8 6\n");
        let mut k = 0;
        let mut images = |count: usize, text: &mut String| {
            for _ in 0..count {
                text.push_str(&format!("i images\\img{k}.tif\n"));
                k += 1;
            }
        };
        // Listed from the brightest down, to check the sort.
        for p in (1..=n).rev() {
            text.push_str(&format!("b {}.0 {},5\n", p * 1000, p * 100));
            images(2, &mut text);
            text.push_str(&format!("d {}.0\n", p * 1000));
            images(2, &mut text);
        }
        if spatial {
            text.push_str("b 3000.0 300,5\n");
            images(4, &mut text);
            text.push_str("d 3000.0\n");
            images(4, &mut text);
        }
        text
    }

    fn refused(text: &str) -> String {
        let (_dir, path) = descriptor(text);
        EmvaDataset::from_descriptor(&path).unwrap_err().to_string()
    }

    #[test]
    fn a_descriptor_groups_pairs_by_exposure_and_spatial_stacks() {
        let (dir, path) = descriptor(&series(6, true));
        let d = EmvaDataset::from_descriptor(&path).unwrap();
        assert_eq!(d.source, path);
        assert_eq!(
            d.format.map(|f| (f.bits, f.width, f.height)),
            Some((12, 8, 6))
        );
        assert_eq!(d.points.len(), 6);
        let photons: Vec<f64> = d.points.iter().filter_map(|p| p.photons_per_px).collect();
        assert_eq!(photons, vec![100.5, 200.5, 300.5, 400.5, 500.5, 600.5]);
        let first = &d.points[0];
        assert!((first.exposure_s - 1e-6).abs() < 1e-18);
        // Listed last: the bright pair of 1000 ns is img20, img21, its dark img22, img23.
        let images = dir.path().join("images");
        assert_eq!(
            first.bright,
            [images.join("img20.tif"), images.join("img21.tif")]
        );
        assert_eq!(
            first.dark,
            [images.join("img22.tif"), images.join("img23.tif")]
        );
        let sb = d.spatial_bright.as_ref().unwrap();
        let sd = d.spatial_dark.as_ref().unwrap();
        assert_eq!((sb.files.len(), sb.photons_per_px), (4, Some(300.5)));
        assert_eq!((sd.files.len(), sd.photons_per_px), (4, None));
        assert_eq!(sd.files[0], images.join("img28.tif"));
        assert_eq!(d.exposures_s().len(), 6);
    }

    #[test]
    fn an_irradiance_series_shares_the_dark_pair_of_its_exposure() {
        let mut text = String::from("n 8 4 4\n");
        for p in 1..=5 {
            text.push_str(&format!("b 5000 {p}00\ni b{p}a.tif\ni b{p}b.tif\n"));
        }
        text.push_str("d 5000\ni da.tif\ni db.tif\n");
        let (dir, path) = descriptor(&text);
        let d = EmvaDataset::from_descriptor(&path).unwrap();
        assert_eq!(d.points.len(), 5);
        assert!(d
            .points
            .iter()
            .all(|p| p.dark[0] == dir.path().join("da.tif")));
        assert_eq!(d.spatial_bright, None);
        assert_eq!(d.spatial_dark, None);
        assert_eq!(d.exposures_s(), vec![5e-6]);
    }

    #[test]
    fn missing_files_are_refused_naming_them_and_their_lines() {
        let text = series(6, false);
        let (dir, path) = descriptor(&text);
        std::fs::remove_file(dir.path().join("images/img2.tif")).unwrap();
        std::fs::remove_file(dir.path().join("images/img3.tif")).unwrap();
        let e = EmvaDataset::from_descriptor(&path).unwrap_err().to_string();
        assert!(e.contains("EMVA1288descriptor.txt"), "{e}");
        assert!(e.contains("2 image file(s) it names do not exist"), "{e}");
        assert!(e.contains("img2.tif") && e.contains("img3.tif"), "{e}");
        assert!(e.contains("line 6)"), "{e}");
    }

    #[test]
    fn a_bright_pair_without_its_dark_pair_is_refused() {
        let text = series(6, false).replace("d 4000.0\n", "d 4500.0\n");
        let e = refused(&text);
        assert!(
            e.contains("line 18: a dark pair at exposure 0.0000045 s with no bright pair"),
            "{e}"
        );
        // Without the lonely dark: the bright pair's own message.
        let text =
            series(6, false).replace("d 4000.0\ni images\\img10.tif\ni images\\img11.tif\n", "");
        let e = refused(&text);
        assert!(
            e.contains("line 15: a bright pair at exposure 0.000004 s has no dark pair"),
            "{e}"
        );
    }

    #[test]
    fn too_few_points_refused_and_fewer_than_fifty_out_of_the_rules() {
        let e = refused(&series(MIN_POINTS - 1, false));
        assert!(e.contains("4 photon-transfer point(s)"), "{e}");
        assert!(e.contains("at least 5 are needed"), "{e}");
        let (_dir, path) = descriptor(&series(MIN_POINTS, false));
        let d = EmvaDataset::from_descriptor(&path).unwrap();
        let breaks = d.rule_breaks();
        assert_eq!(breaks.len(), 1);
        assert_eq!(breaks[0].part, DatasheetPart::Temporal);
        assert!(breaks[0].rule.contains("5 photon-transfer points"));
        assert!(EmvaDataset::rule_text(&breaks, DatasheetPart::Spatial).is_none());
        assert_eq!(
            EmvaDataset::rule_text(&breaks, DatasheetPart::Temporal).as_deref(),
            Some(breaks[0].rule.as_str())
        );
        let (_dir, path) = descriptor(&series(STANDARD_POINTS, true));
        let d = EmvaDataset::from_descriptor(&path).unwrap();
        assert_eq!(d.rule_breaks(), vec![]);
    }

    #[test]
    fn inconsistent_spatial_stacks_are_refused() {
        let base = series(6, true);
        let e = refused(&base.replace("d 3000.0\ni images\\img28", "d 2000.0\ni images\\img28"));
        assert!(e.contains("line 39: the bright spatial stack is at exposure 0.000003 s, the dark one (line 44) at 0.000002 s"), "{e}");
        let cut = base.find("d 3000.0\ni images\\img28").unwrap();
        let e = refused(&base[..cut]);
        assert!(
            e.contains("a bright spatial stack (4 images) without a dark spatial stack"),
            "{e}"
        );
        let twice = format!("{base}b 3000.0 301\ni x1\ni x2\ni x3\n");
        let e = refused(&twice);
        assert!(
            e.contains("line 49: a second bright spatial stack (the first at line 39)"),
            "{e}"
        );
        // A dark stack alone is kept: DSNU without PRNU.
        let dark_only = base.replace("b 3000.0 300,5\ni images\\img24.tif\ni images\\img25.tif\ni images\\img26.tif\ni images\\img27.tif\n", "");
        let (_dir, path) = descriptor(&dark_only);
        let d = EmvaDataset::from_descriptor(&path).unwrap();
        assert!(d.spatial_bright.is_none() && d.spatial_dark.is_some());
    }

    #[test]
    fn a_manifest_row_is_an_image_and_consecutive_rows_one_set() {
        let dir = tempfile::tempdir().unwrap();
        let mut rows = String::from("file,kind,exposure_s,em_gain,temperature_c,light_level\n");
        let mut add = |name: &str, kind: &str, t: f64, photons: &str| {
            std::fs::write(dir.path().join(name), b"").unwrap();
            rows.push_str(&format!("{name},{kind},{t},,,{photons}\n"));
        };
        for p in 1..=5 {
            let t = p as f64 * 1e-3;
            add(&format!("b{p}a.fits"), "flat", t, &format!("{p}00"));
            add(&format!("b{p}b.fits"), "flat", t, &format!("{p}00"));
            add(&format!("d{p}a.fits"), "dark", t, "");
            add(&format!("d{p}b.fits"), "dark", t, "");
        }
        // The spatial stack repeats the condition of the third pair, after other rows.
        for k in 0..3 {
            add(&format!("s{k}.fits"), "flat", 3e-3, "300");
        }
        for k in 0..3 {
            add(&format!("sd{k}.fits"), "dark", 3e-3, "");
        }
        let manifest = dir.path().join("m.csv");
        std::fs::write(&manifest, rows).unwrap();
        let d = EmvaDataset::from_manifest(&manifest).unwrap();
        assert_eq!(d.format, None);
        assert_eq!(d.points.len(), 5);
        assert_eq!(d.points[2].photons_per_px, Some(300.0));
        assert_eq!(d.points[2].bright[1], dir.path().join("b3b.fits"));
        assert_eq!(d.spatial_bright.as_ref().unwrap().files.len(), 3);
        assert_eq!(
            d.spatial_dark.as_ref().unwrap().files[2],
            dir.path().join("sd2.fits")
        );
    }

    #[test]
    fn photons_given_for_some_flats_only_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let mut rows = String::from("file,kind,exposure_s,em_gain,temperature_c,light_level\n");
        for p in 1..=5 {
            let photons = if p == 4 {
                String::new()
            } else {
                format!("{p}00")
            };
            for (name, kind, level) in [
                ("a", "flat", &photons),
                ("b", "flat", &photons),
                ("c", "dark", &String::new()),
                ("d", "dark", &String::new()),
            ] {
                let file = format!("{name}{p}.fits");
                std::fs::write(dir.path().join(&file), b"").unwrap();
                rows.push_str(&format!("{file},{kind},{p},,,{level}\n"));
            }
        }
        let manifest = dir.path().join("m.csv");
        std::fs::write(&manifest, rows).unwrap();
        let e = EmvaDataset::from_manifest(&manifest)
            .unwrap_err()
            .to_string();
        assert!(e.contains("m.csv: line 14: a bright pair without its photons per pixel while 4 others give theirs"), "{e}");
    }

    #[test]
    fn the_frame_check_of_a_dataset_without_points_is_an_error() {
        let d = EmvaDataset {
            source: PathBuf::from("built.txt"),
            format: None,
            points: Vec::new(),
            spatial_bright: None,
            spatial_dark: None,
        };
        let e = d.check_frames().unwrap_err().to_string();
        assert_eq!(e, "built.txt: no photon-transfer points to check");
    }
}

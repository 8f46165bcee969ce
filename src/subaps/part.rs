//! Part files: the durable, resumable record of one shard's finished sub-apertures.
//!
//! A part file (`subaps-K-of-N.part` in the output directory) starts with one JSON line, its
//! header: the format, the shard, and the binding (every option the results depend on and the
//! map's checksum) with its BLAKE3. Each finished sub-aperture then appends one line of
//! tab-separated fields, written whole and synced to disk before the next is counted, and
//! ending in a checksum of the line, so that a line torn by a kill is recognised and dropped.
//! Numbers are written in Rust's shortest round-trip form, so reading them back gives the
//! same bits: a merged result equals the one computed in a single run.

use super::geometry::{GridSpec, Layout, ValidMask};
use super::lock::PartLock;
use super::solve::WindowStats;
use crate::calib::Map;
use crate::centroid::CentroiderSpec;
use crate::effective::{Effective, EffectiveParts, Precision, Status};
use crate::montecarlo::{BgGrid, SimConfig};
use crate::{Error, Result};
use serde::{Deserialize, Serialize};
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// The `format` of a part file's header.
pub const PART_FORMAT: &str = "detnoise-subaps-part-2";

/// Fields of a record line, the checksum last.
const FIELDS: usize = 26;

/// One shard of a job: sub-apertures whose index is `k - 1` modulo `n` (round-robin, so each
/// shard samples the whole detector).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Shard {
    /// This shard, 1 to `n`.
    pub k: usize,
    /// Shards in all.
    pub n: usize,
}

impl Shard {
    /// The whole job in one shard.
    pub const ALL: Shard = Shard { k: 1, n: 1 };

    /// Parse `K/N` (1 <= K <= N); errors name `shard`.
    pub fn parse(text: &str) -> Result<Shard> {
        let bad = |why: &str| {
            Error::invalid(
                "shard",
                format!("{text:?}: {why}; expected K/N with 1 <= K <= N, e.g. 3/8"),
            )
        };
        let (k, n) = text.split_once('/').ok_or_else(|| bad("no '/'"))?;
        let num = |s: &str| {
            s.trim()
                .parse::<usize>()
                .map_err(|_| bad("not whole numbers"))
        };
        let (k, n) = (num(k)?, num(n)?);
        if !(1..=n).contains(&k) {
            return Err(bad("K must be from 1 to N"));
        }
        Ok(Shard { k, n })
    }

    /// The part file's name: `subaps-K-of-N.part`.
    pub fn file_name(&self) -> String {
        format!("subaps-{}-of-{}.part", self.k, self.n)
    }
}

/// Everything a sub-aperture's result depends on: the tool, the map's values, the geometry,
/// the configuration and the precision. Parts of one job share it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Binding {
    /// Tool and version that computed the results.
    pub tool: String,
    /// BLAKE3 (hex) of the map's shape and values (non-finite pixels alike).
    pub map_blake3: String,
    /// Map shape [rows, cols] (px).
    pub map_shape: [usize; 2],
    /// The grid (px).
    pub grid: GridSpec,
    /// BLAKE3 of the mask of valid sub-apertures, if one was given.
    pub mask_blake3: Option<String>,
    /// Grid shape [rows, cols] (sub-apertures).
    pub grid_shape: [usize; 2],
    /// Sub-apertures laid out.
    pub subaps: usize,
    /// BLAKE3 of the layout (grid shape and every sub-aperture's cell).
    pub layout_blake3: String,
    /// Valid mask cells left out: always 0 (a mask must have the grid's shape), kept in the
    /// part format.
    pub left_out: usize,
    /// Grid cells the mask marks invalid.
    pub masked: usize,
    /// Spot (`airy:D` or `gauss:SX,SY`, px).
    pub spot: String,
    /// Spot sampling.
    pub sampling: String,
    /// Signal (photons per sub-aperture).
    pub signal_photons: f64,
    /// Quantum efficiency.
    pub qe: f64,
    /// Starting iterations (frames).
    pub iters: u64,
    /// Seed of every sub-aperture (common random numbers).
    pub seed: u64,
    /// Background levels (`auto` or `start:stop:step`, e-).
    pub bg_grid: String,
    /// Half-width of the spot offsets (px).
    pub position_half_range_px: f64,
    /// Largest fraction of empty frames of an eligible level.
    pub max_empty_frac: f64,
    /// Target standard error of each value (e-; 0 = off).
    pub target_se_e: f64,
    /// Relative target (fraction of the value; 0 = off).
    pub target_rel: f64,
    /// Iteration cap per sub-aperture (frames).
    pub max_iters: u64,
    /// Centroider each sub-aperture is read through (`--centroider`).
    pub centroider: String,
}

impl Binding {
    /// The binding of a job on `map` laid out as `layout` (from `grid` and `mask`).
    pub fn new(
        map: &Map,
        (grid, mask, layout): (&GridSpec, Option<&ValidMask>, &Layout),
        cfg: &SimConfig,
        precision: &Precision,
        centroider: &CentroiderSpec,
    ) -> Binding {
        Binding {
            tool: format!("detnoise {}", env!("CARGO_PKG_VERSION")),
            map_blake3: map_digest(map),
            map_shape: [map.rows, map.cols],
            grid: *grid,
            mask_blake3: mask.map(|m| m.blake3.clone()),
            grid_shape: [layout.grid_rows, layout.grid_cols],
            subaps: layout.subaps.len(),
            layout_blake3: layout.digest(),
            left_out: 0,
            masked: layout.masked,
            spot: cfg.spot.label(),
            sampling: cfg.sampling.label().into(),
            signal_photons: cfg.signal_photons,
            qe: cfg.qe,
            iters: cfg.iters,
            seed: cfg.seed,
            bg_grid: match &cfg.bg_grid {
                BgGrid::Auto => "auto".into(),
                BgGrid::Range { start, stop, step } => format!("{start}:{stop}:{step}"),
            },
            position_half_range_px: cfg.position_half_range_px,
            max_empty_frac: cfg.max_empty_frac,
            target_se_e: precision.target_se_e,
            target_rel: precision.target_rel,
            max_iters: precision.max_iters,
            centroider: centroider.label(),
        }
    }

    /// BLAKE3 (hex) of the binding as JSON.
    pub fn digest(&self) -> String {
        let text = serde_json::to_string(self).expect("a binding encodes as JSON");
        blake3::hash(text.as_bytes()).to_hex().to_string()
    }

    /// The top-level settings in which `other` differs from this binding.
    pub fn differences(&self, other: &Binding) -> Vec<String> {
        let (a, b) = (
            serde_json::to_value(self).expect("JSON"),
            serde_json::to_value(other).expect("JSON"),
        );
        match (a, b) {
            (serde_json::Value::Object(a), serde_json::Value::Object(b)) => a
                .iter()
                .filter(|(k, v)| b.get(*k) != Some(*v))
                .map(|(k, _)| k.clone())
                .collect(),
            _ => Vec::new(),
        }
    }
}

/// BLAKE3 (hex) of a map's shape and values, every non-finite value alike.
pub fn map_digest(map: &Map) -> String {
    let mut h = blake3::Hasher::new();
    h.update(&(map.rows as u64).to_le_bytes());
    h.update(&(map.cols as u64).to_le_bytes());
    for v in &map.data {
        let v = if v.is_finite() { *v } else { f64::NAN };
        h.update(&v.to_bits().to_le_bytes());
    }
    h.finalize().to_hex().to_string()
}

/// The first line of a part file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PartHeader {
    /// [`PART_FORMAT`].
    pub format: String,
    /// BLAKE3 of `binding` (parts of one job share it).
    pub binding_blake3: String,
    /// The shard this part holds.
    pub shard: Shard,
    /// Sub-apertures of the shard.
    pub subaps_in_shard: usize,
    /// Where the map came from (for messages; not bound: the same values may live anywhere).
    pub map_source: String,
    /// The options and input the results depend on.
    pub binding: Binding,
}

impl PartHeader {
    /// The header of shard `shard` of a job bound by `binding`, `in_shard` sub-apertures.
    pub fn new(binding: Binding, shard: Shard, in_shard: usize, map_source: &str) -> Self {
        PartHeader {
            format: PART_FORMAT.into(),
            binding_blake3: binding.digest(),
            shard,
            subaps_in_shard: in_shard,
            map_source: map_source.into(),
            binding,
        }
    }
}

/// One finished sub-aperture as a part file records it.
#[derive(Debug, Clone, PartialEq)]
pub struct PartRecord {
    /// Index among the sub-apertures laid out.
    pub index: usize,
    /// Grid row.
    pub grid_row: usize,
    /// Grid column.
    pub grid_col: usize,
    /// How the value was settled.
    pub status: Status,
    /// Effective read noise (e-; NaN without a value).
    pub sigma_eff_e: f64,
    /// Its standard error (e-; NaN without a value).
    pub sigma_eff_se_e: f64,
    /// The standard error it had to reach (e-).
    pub target_se_e: Option<f64>,
    /// Iterations of the final runs.
    pub iters: u64,
    /// The window's R (px).
    pub r_px: f64,
    /// Its standard error (px).
    pub r_se_px: f64,
    /// The window's best background level (e-).
    pub b_opt_e: f64,
    /// The map in the window.
    pub window: WindowStats,
    /// The uniform camera with the same R under plain `cog` (e-; NaN without a value).
    pub sigma_cog_equiv_e: f64,
    /// Its standard error (e-; NaN without a value).
    pub sigma_cog_equiv_se_e: f64,
    /// The error's static and random parts in the window.
    pub parts: EffectiveParts,
}

impl PartRecord {
    /// The record of sub-aperture `index` at (`grid_row`, `grid_col`) solved as `e`.
    pub fn new(
        (index, grid_row, grid_col): (usize, usize, usize),
        e: &Effective,
        window: WindowStats,
    ) -> Self {
        PartRecord {
            index,
            grid_row,
            grid_col,
            status: e.status,
            sigma_eff_e: e.sigma_eff_e,
            sigma_eff_se_e: e.sigma_eff_se_e,
            target_se_e: e.target_se_e,
            iters: e.iters,
            r_px: e.r_px,
            r_se_px: e.r_se_px,
            b_opt_e: e.b_opt_e,
            window,
            sigma_cog_equiv_e: e.sigma_cog_equiv_e,
            sigma_cog_equiv_se_e: e.sigma_cog_equiv_se_e,
            parts: e.parts,
        }
    }

    /// The record as one line (with its newline).
    pub fn line(&self) -> String {
        let w = &self.window;
        let target = self.target_se_e.map_or("-".to_string(), |t| t.to_string());
        let p = &self.parts;
        let body = format!(
            "{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}",
            self.index,
            self.grid_row,
            self.grid_col,
            self.status.label(),
            self.sigma_eff_e,
            self.sigma_eff_se_e,
            target,
            self.iters,
            self.r_px,
            self.r_se_px,
            self.b_opt_e,
            w.median_e,
            w.rms_e,
            w.nonfinite_px,
            self.sigma_cog_equiv_e,
            self.sigma_cog_equiv_se_e,
            p.sigma_random_e,
            p.sigma_random_se_e,
            p.sigma_random_extrapolated,
            p.random_rms_px,
            p.static_x_px,
            p.static_y_px,
            p.static_px,
            p.static_se_px,
            p.static_resolved
        );
        format!("{body}\t{}\n", line_check(&body))
    }

    /// Parse a line written by [`PartRecord::line`] (without its newline); None when it is
    /// not one (torn or altered).
    pub fn parse(line: &str) -> Option<PartRecord> {
        let (body, check) = line.rsplit_once('\t')?;
        if check != line_check(body) {
            return None;
        }
        let f: Vec<&str> = body.split('\t').collect();
        if f.len() != FIELDS - 1 {
            return None;
        }
        let real = |s: &str| s.parse::<f64>().ok();
        let whole = |s: &str| s.parse::<usize>().ok();
        Some(PartRecord {
            index: whole(f[0])?,
            grid_row: whole(f[1])?,
            grid_col: whole(f[2])?,
            status: Status::ALL.into_iter().find(|s| s.label() == f[3])?,
            sigma_eff_e: real(f[4])?,
            sigma_eff_se_e: real(f[5])?,
            target_se_e: if f[6] == "-" { None } else { Some(real(f[6])?) },
            iters: f[7].parse().ok()?,
            r_px: real(f[8])?,
            r_se_px: real(f[9])?,
            b_opt_e: real(f[10])?,
            window: WindowStats {
                median_e: real(f[11])?,
                rms_e: real(f[12])?,
                nonfinite_px: whole(f[13])?,
            },
            sigma_cog_equiv_e: real(f[14])?,
            sigma_cog_equiv_se_e: real(f[15])?,
            parts: EffectiveParts {
                sigma_random_e: real(f[16])?,
                sigma_random_se_e: real(f[17])?,
                sigma_random_extrapolated: f[18].parse().ok()?,
                random_rms_px: real(f[19])?,
                static_x_px: real(f[20])?,
                static_y_px: real(f[21])?,
                static_px: real(f[22])?,
                static_se_px: real(f[23])?,
                static_resolved: f[24].parse().ok()?,
            },
        })
    }
}

/// The checksum field of a record line: 16 hex digits of the BLAKE3 of its body.
fn line_check(body: &str) -> String {
    blake3::hash(body.as_bytes()).to_hex()[..16].to_string()
}

/// A part file as read: its header, its complete records in file order, and where the last
/// complete line ends (a torn line after it is not counted).
#[derive(Debug, Clone)]
pub struct PartContent {
    /// The header.
    pub header: PartHeader,
    /// The complete records, in file order.
    pub records: Vec<PartRecord>,
    /// Bytes up to the end of the last complete line.
    pub valid_len: u64,
    /// Whether a torn line followed them (a run killed while writing it).
    pub torn: bool,
}

/// Read the part file at `path`. A line that fails its checksum is accepted only as the last
/// one (torn by a kill; it is not counted); anywhere else the file is refused as damaged.
pub fn read_part(path: &Path) -> Result<PartContent> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    let bad = |why: String| Error::input(path, why);
    let not_part = || {
        bad(format!(
            "not a detnoise part file (its first line is not a `{PART_FORMAT}` header)"
        ))
    };
    let head_end = bytes
        .iter()
        .position(|&b| b == b'\n')
        .ok_or_else(not_part)?;
    let head = std::str::from_utf8(&bytes[..head_end]).map_err(|_| not_part())?;
    let value: serde_json::Value = serde_json::from_str(head).map_err(|_| not_part())?;
    let format = value.get("format").and_then(|f| f.as_str()).unwrap_or("");
    // An older detnoise's part: its values have another meaning, so it cannot be resumed or
    // merged, only rerun.
    if format != PART_FORMAT && format.starts_with("detnoise-subaps-part-") {
        return Err(bad(format!(
            "written by an older detnoise (format {format:?}; this version writes \
             {PART_FORMAT:?}): rerun this shard to replace it"
        )));
    }
    let header: PartHeader = serde_json::from_value(value).map_err(|_| not_part())?;
    if header.format != PART_FORMAT {
        return Err(not_part());
    }
    check_header(&header, head).map_err(bad)?;
    let mut records = Vec::new();
    let mut pos = head_end + 1;
    let mut torn = false;
    let mut line_no = 1;
    while pos < bytes.len() {
        line_no += 1;
        let end = bytes[pos..]
            .iter()
            .position(|&b| b == b'\n')
            .map(|e| pos + e);
        let record = end.and_then(|e| {
            std::str::from_utf8(&bytes[pos..e])
                .ok()
                .and_then(PartRecord::parse)
        });
        match (record, end) {
            (Some(r), Some(e)) => {
                records.push(r);
                pos = e + 1;
            }
            (_, Some(e)) if e + 1 < bytes.len() => {
                return Err(bad(format!(
                    "line {line_no} is damaged (not a complete record) and more follow: the \
                     part file was altered; remove it to recompute its sub-apertures"
                )));
            }
            _ => {
                torn = true;
                break;
            }
        }
    }
    Ok(PartContent {
        header,
        records,
        valid_len: pos as u64,
        torn,
    })
}

/// Why the header `h`, parsed from the line `text`, cannot be a part file's as detnoise wrote
/// it: its binding edited (its checksum no longer matches), a shard out of range, or a count
/// of sub-apertures that is not its shard's.
fn check_header(h: &PartHeader, text: &str) -> std::result::Result<(), String> {
    // The checksum is of the binding's text as written: serde_json's parse of a float may be
    // one unit in the last place off, so re-encoding the parsed binding could differ.
    let written = binding_text(text).map(|b| blake3::hash(b.as_bytes()).to_hex().to_string());
    if written.as_deref() != Some(h.binding_blake3.as_str()) {
        return Err(
            "its header's options do not match their checksum (binding_blake3): the header was \
             edited; remove the part and rerun its shard to recompute it"
                .to_string(),
        );
    }
    let Shard { k, n } = h.shard;
    if !(1..=n).contains(&k) {
        return Err(format!(
            "its header's shard {k}/{n} is not one of 1..N/N: the header was edited"
        ));
    }
    let in_shard = h.binding.subaps.saturating_sub(k - 1).div_ceil(n);
    if h.subaps_in_shard != in_shard {
        return Err(format!(
            "its header counts {} sub-apertures in shard {k}/{n} of a job of {}, not {in_shard}: \
             the header was edited",
            h.subaps_in_shard, h.binding.subaps
        ));
    }
    // A forged grid (its checksum recomputed) must not lay windows beyond the map: every
    // window start computed from it is then a pixel of the map.
    let b = &h.binding;
    b.grid
        .validate()
        .map_err(|e| format!("its header's grid is not one detnoise runs: {e}"))?;
    let [rows, cols] = b.map_shape;
    if b.grid.shape_on(rows, cols) != b.grid_shape {
        return Err(format!(
            "its header's grid {} on a {rows}x{cols} px map is not {}x{} sub-apertures: the \
             header was edited",
            b.grid.text(),
            b.grid_shape[0],
            b.grid_shape[1]
        ));
    }
    Ok(())
}

/// The text of the binding in a header line: the last member, as [`PartHeader`] is written
/// (a `,"` cannot occur inside a JSON string, whose quotes are escaped).
fn binding_text(header: &str) -> Option<&str> {
    const KEY: &str = ",\"binding\":";
    let start = header.find(KEY)? + KEY.len();
    header.strip_suffix('}')?.get(start..)
}

/// An open part file that finished sub-apertures are appended to, one synced line each,
/// under its lock (no other run writes it meanwhile).
pub struct PartWriter {
    file: Mutex<std::fs::File>,
    path: PathBuf,
    _lock: PartLock,
}

impl PartWriter {
    /// Lock the part file of `header`'s shard in `dir` (another run holding it is refused,
    /// naming its pid), then resume it, or create it (the header written atomically) when
    /// absent: returns the writer and the records already there. A part written with other
    /// options is refused, naming the settings that differ; a torn last line is cut off.
    pub fn open(dir: &Path, header: &PartHeader) -> Result<(PartWriter, Vec<PartRecord>)> {
        let path = dir.join(header.shard.file_name());
        let lock = PartLock::take(&path)?;
        let done = if path.exists() {
            let content = read_part(&path)?;
            check_same_job(&path, &content.header, header)?;
            check_records(&path, &content, header.shard)?;
            if content.torn {
                let f = std::fs::OpenOptions::new()
                    .write(true)
                    .open(&path)
                    .map_err(|e| Error::io(&path, e))?;
                f.set_len(content.valid_len)
                    .and_then(|_| f.sync_all())
                    .map_err(|e| Error::io(&path, e))?;
            }
            content.records
        } else {
            let text = serde_json::to_string(header).expect("a header encodes as JSON");
            crate::output::write_atomic(&path, format!("{text}\n").as_bytes())?;
            sync_dir(dir);
            Vec::new()
        };
        let file = std::fs::OpenOptions::new()
            .append(true)
            .open(&path)
            .map_err(|e| Error::io(&path, e))?;
        Ok((
            PartWriter {
                file: Mutex::new(file),
                path,
                _lock: lock,
            },
            done,
        ))
    }

    /// Append `record` as one line and sync it to disk.
    pub fn append(&self, record: &PartRecord) -> Result<()> {
        let mut f = self.file.lock().expect("part file lock");
        f.write_all(record.line().as_bytes())
            .and_then(|_| f.sync_data())
            .map_err(|e| Error::io(&self.path, e))
    }

    /// The part file's path.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

/// Sync a directory so that a file created in it survives a crash (best effort).
fn sync_dir(dir: &Path) {
    if let Ok(d) = std::fs::File::open(dir) {
        let _ = d.sync_all();
    }
}

/// Refuse to resume a part of another job.
fn check_same_job(path: &Path, found: &PartHeader, want: &PartHeader) -> Result<()> {
    if found.binding_blake3 == want.binding_blake3 && found.shard == want.shard {
        return Ok(());
    }
    let mut differ = want.binding.differences(&found.binding);
    if found.shard != want.shard {
        differ.push("shard".into());
    }
    if differ.is_empty() {
        differ.push("binding checksum".into());
    }
    Err(Error::invalid(
        "out",
        format!(
            "{} holds results computed with other options or another map (differing: {}): \
             rerun with the options it was written with to resume it, or choose another `out`",
            path.display(),
            differ.join(", ")
        ),
    ))
}

/// Every record of `content` belongs to `shard`, once.
fn check_records(path: &Path, content: &PartContent, shard: Shard) -> Result<()> {
    let mut seen = std::collections::HashSet::new();
    for r in &content.records {
        let [grid_rows, grid_cols] = content.header.binding.grid_shape;
        if r.grid_row >= grid_rows || r.grid_col >= grid_cols {
            return Err(Error::input(
                path,
                format!(
                    "holds sub-aperture {} at grid cell ({}, {}), outside the {grid_rows}x\
                     {grid_cols} grid: the file was altered",
                    r.index, r.grid_row, r.grid_col
                ),
            ));
        }
        if r.index >= content.header.binding.subaps || r.index % shard.n != shard.k - 1 {
            return Err(Error::input(
                path,
                format!(
                    "holds sub-aperture {} which is not one of shard {}/{}: the file was altered",
                    r.index, shard.k, shard.n
                ),
            ));
        }
        if !seen.insert(r.index) {
            return Err(Error::input(
                path,
                format!("holds sub-aperture {} twice: the file was altered", r.index),
            ));
        }
    }
    Ok(())
}

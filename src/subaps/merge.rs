//! Merging part files: they must come from one job (same binding) and together hold every
//! sub-aperture exactly once; the result is the job's records in index order.

use super::geometry::layout_digest;
use super::part::{read_part, PartContent, PartHeader, PartRecord};
use crate::{Error, Result};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The records of a whole job, from its parts.
#[derive(Debug, Clone)]
pub struct Merged {
    /// The first part's header (every part shares its binding).
    pub header: PartHeader,
    /// The part files merged, as given.
    pub parts: Vec<PathBuf>,
    /// Every sub-aperture's record, in index order.
    pub records: Vec<PartRecord>,
}

/// The part files named by `paths`: files as given, and for a directory every
/// `subaps-K-of-N.part` in it (sorted). Errors name `parts`.
pub fn expand_parts(paths: &[PathBuf]) -> Result<Vec<PathBuf>> {
    if paths.is_empty() {
        return Err(Error::invalid("parts", "no part file given"));
    }
    let mut out = Vec::new();
    for p in paths {
        if p.is_dir() {
            let mut found: Vec<PathBuf> = std::fs::read_dir(p)
                .map_err(|e| Error::io(p, e))?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|f| f.is_file() && is_part_name(f))
                .collect();
            if found.is_empty() {
                return Err(Error::invalid(
                    "parts",
                    format!(
                        "{}: a directory without part files (subaps-K-of-N.part)",
                        p.display()
                    ),
                ));
            }
            found.sort();
            out.extend(found);
        } else {
            out.push(p.clone());
        }
    }
    Ok(out)
}

/// Whether `path` has the name of a part file (`subaps-K-of-N.part`).
pub fn is_part_name(path: &Path) -> bool {
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned());
    name.as_deref()
        .and_then(|n| n.strip_prefix("subaps-"))
        .and_then(|n| n.strip_suffix(".part"))
        .and_then(|n| n.split_once("-of-"))
        .is_some_and(|(k, n)| k.parse::<usize>().is_ok() && n.parse::<usize>().is_ok())
}

/// Whether `path` has the name of a part's lock file (`subaps-K-of-N.part.lock`).
pub(crate) fn is_lock_name(path: &Path) -> bool {
    path.to_str()
        .and_then(|p| p.strip_suffix(super::lock::SUFFIX))
        .is_some_and(|part| is_part_name(Path::new(part)))
}

/// Read and merge the part files `paths`: one job (the same binding), every sub-aperture
/// exactly once. A missing one is an error naming how many are missing and the incomplete
/// parts; a duplicate names both files.
pub fn merge_parts(paths: &[PathBuf]) -> Result<Merged> {
    let mut first: Option<(PartHeader, &PathBuf)> = None;
    let mut by_index: ByIndex = BTreeMap::new();
    let mut incomplete = Vec::new();
    for path in paths {
        let content = read_part(path)?;
        match &first {
            None => first = Some((content.header.clone(), path)),
            Some((h, first)) => same_job(h, first, &content.header, path)?,
        }
        incomplete.extend(incomplete_note(&content, path));
        add_records(
            &mut by_index,
            content.records,
            content.header.binding.subaps,
            path,
        )?;
    }
    let (header, _) = first.ok_or_else(|| Error::invalid("parts", "no part file given"))?;
    require_all(&by_index, &header, &incomplete)?;
    let records: Vec<PartRecord> = by_index.into_values().map(|(r, _)| r).collect();
    check_layout(&header, &records, &paths[0])?;
    Ok(Merged {
        header,
        parts: paths.to_vec(),
        records,
    })
}

/// Records by sub-aperture index, with the part file each came from.
type ByIndex<'a> = BTreeMap<usize, (PartRecord, &'a PathBuf)>;

/// Fail unless the part at `path` (header `h`) belongs to the job of `first` (header
/// `first_h`), naming what differs.
fn same_job(first_h: &PartHeader, first: &Path, h: &PartHeader, path: &Path) -> Result<()> {
    if first_h.binding_blake3 == h.binding_blake3 {
        return Ok(());
    }
    let differ = first_h.binding.differences(&h.binding);
    Err(Error::input(
        path,
        format!(
            "belongs to another job than {} (differing: {}): merge only the parts \
             of one run",
            first.display(),
            if differ.is_empty() {
                "binding checksum".to_string()
            } else {
                differ.join(", ")
            }
        ),
    ))
}

/// "path (k of n done)" for a part short of its shard's sub-apertures, for the error on
/// missing ones.
fn incomplete_note(content: &PartContent, path: &Path) -> Option<String> {
    (content.records.len() < content.header.subaps_in_shard).then(|| {
        format!(
            "{} ({} of {} done{})",
            path.display(),
            content.records.len(),
            content.header.subaps_in_shard,
            if content.torn {
                ", a torn last line"
            } else {
                ""
            }
        )
    })
}

/// Add the records of the part at `path` (of a job of `total` sub-apertures), refusing an
/// index out of range or already held by another part.
fn add_records<'a>(
    by_index: &mut ByIndex<'a>,
    records: Vec<PartRecord>,
    total: usize,
    path: &'a PathBuf,
) -> Result<()> {
    for r in records {
        if r.index >= total {
            return Err(Error::input(
                path,
                format!("holds sub-aperture {} of a job of {total}", r.index),
            ));
        }
        if let Some((_, other)) = by_index.get(&r.index) {
            return Err(Error::input(
                path,
                format!(
                    "holds sub-aperture {} which {} holds too: give each shard's part once",
                    r.index,
                    other.display()
                ),
            ));
        }
        by_index.insert(r.index, (r, path));
    }
    Ok(())
}

/// Fail unless every sub-aperture of the job is held, naming up to 5 missing ones and the
/// `incomplete` parts.
fn require_all(by_index: &ByIndex, header: &PartHeader, incomplete: &[String]) -> Result<()> {
    let total = header.binding.subaps;
    if by_index.len() >= total {
        return Ok(());
    }
    let missing: Vec<String> = (0..total)
        .filter(|i| !by_index.contains_key(i))
        .take(5)
        .map(|i| i.to_string())
        .collect();
    let shards = header.shard.n;
    Err(Error::invalid(
        "parts",
        format!(
            "{} of {total} sub-apertures are missing (e.g. {}){}: run or resume every \
             shard of 1..{shards}/{shards} and merge all their parts",
            total - by_index.len(),
            missing.join(", "),
            if incomplete.is_empty() {
                String::new()
            } else {
                format!("; incomplete parts: {}", incomplete.join(", "))
            }
        ),
    ))
}

/// Fail unless the records' cells are the job's layout (naming the first part, `first`).
fn check_layout(header: &PartHeader, records: &[PartRecord], first: &Path) -> Result<()> {
    let b = &header.binding;
    let digest = layout_digest(
        (b.grid_shape[0], b.grid_shape[1]),
        records.iter().map(|r| (r.grid_row, r.grid_col)),
    );
    if digest != b.layout_blake3 {
        return Err(Error::input(
            first,
            "the records' sub-aperture cells do not match the job's layout: a part was altered",
        ));
    }
    Ok(())
}

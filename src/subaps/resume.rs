//! A job run into an output directory: resumable (finished sub-apertures are appended to the
//! shard's part file as they complete, and a rerun skips them), shardable (a shard writes only
//! its part file), and merged into the outputs (a single run does so itself at the end, from
//! its own part file, exactly as `subaps-merge` does from several).

use super::merge::{expand_parts, is_lock_name, is_part_name, merge_parts, Merged};
use super::outputs::{write_outputs, SubapsSummary, OUTPUT_NAMES};
use super::part::{read_part, PartWriter, Shard};
use super::run::{solve_each, SubapsJob};
use crate::output::manifest::survey;
use crate::output::{DirPlan, OutputDir};
use crate::progress::Observer;
use crate::{Error, Result};
use std::path::{Path, PathBuf};

/// Where a job's results go.
#[derive(Debug, Clone)]
pub struct DirTarget<'a> {
    /// The output directory: the part file, and for a single run the outputs.
    pub out: &'a Path,
    /// Write beside files detnoise did not write (never replacing them).
    pub force: bool,
    /// The job's input files (never written over).
    pub inputs: &'a [PathBuf],
}

/// What a run into a directory did.
#[derive(Debug, Clone)]
pub struct DirRun {
    /// The part file.
    pub part: PathBuf,
    /// Sub-apertures of the shard.
    pub in_shard: usize,
    /// Of them, found finished in the part file (not recomputed).
    pub resumed: usize,
    /// Of them, computed by this run.
    pub computed: usize,
    /// The summary, when this run wrote the outputs (a single, unsharded run).
    pub summary: Option<SubapsSummary>,
}

/// Run shard `shard` of `job` into `target.out`: check the directory before any work (it may
/// hold detnoise's own files and part files; anything else needs `force`), resume the shard's
/// part file or create it, solve the rest in parallel, and for the whole job in one shard
/// write the outputs ([`OUTPUT_NAMES`]) from the part file.
pub fn run_into_dir(
    job: &SubapsJob,
    shard: Shard,
    target: &DirTarget,
    observer: &dyn Observer,
) -> Result<DirRun> {
    let plan = job.plan()?;
    // The part file is not in a manifest: the output directory takes the outputs beside it
    // (a new directory, or one holding only detnoise's files and parts; else `force`).
    let force = target.force || !target.out.exists() || holds_only_ours(target.out)?;
    // The standard checks of an output directory (not the input, not a file, writable...);
    // the directory it builds is used for the outputs of a single run.
    let dir = OutputDir::prepare(
        target.out,
        DirPlan {
            command: "subaps",
            force,
            inputs: target.inputs,
            names: &OUTPUT_NAMES,
        },
    )?;
    std::fs::create_dir_all(target.out).map_err(|e| Error::io(target.out, e))?;
    let header = plan.header(shard);
    let (writer, done) = PartWriter::open(target.out, &header)?;
    let finished: std::collections::HashSet<usize> = done.iter().map(|r| r.index).collect();
    let todo: Vec<_> = plan
        .layout
        .shard(shard.k, shard.n)
        .into_iter()
        .filter(|s| !finished.contains(&s.index))
        .collect();
    solve_each(&plan, &job.config, &job.precision, &todo, observer, &|r| {
        writer.append(&r)
    })?;
    let part = writer.path().to_path_buf();
    let summary = if shard == Shard::ALL {
        let mut merged = merge_parts(std::slice::from_ref(&part))?;
        // The map read by this run (the part's binding, its BLAKE3 included, is this run's),
        // not the path a resumed part was begun with.
        merged.header.map_source.clone_from(&header.map_source);
        let (summary, _) = write_merged(&merged, &dir)?;
        dir.commit()?;
        Some(summary)
    } else {
        None
    };
    // The part stays locked until the outputs are in place.
    drop(writer);
    Ok(DirRun {
        part,
        in_shard: header.subaps_in_shard,
        resumed: finished.len(),
        computed: todo.len(),
        summary,
    })
}

/// Merge the part files `parts` (files, or directories of part files) into the outputs in
/// `out`, a directory of its own (the parts are inputs: it may not hold them). Returns the
/// merged job and its summary.
pub fn merge_into_dir(
    parts: &[PathBuf],
    out: &Path,
    force: bool,
) -> Result<(Merged, SubapsSummary)> {
    let files = expand_parts(parts)?;
    let dir = OutputDir::prepare(
        out,
        DirPlan {
            command: "subaps-merge",
            force,
            inputs: &files,
            names: &OUTPUT_NAMES,
        },
    )?;
    let merged = merge_parts(&files)?;
    let (summary, _) = write_merged(&merged, &dir)?;
    dir.commit()?;
    Ok((merged, summary))
}

fn write_merged(merged: &Merged, dir: &OutputDir) -> Result<(SubapsSummary, Vec<PathBuf>)> {
    write_outputs(&merged.header, &merged.records, &dir.path(""))
}

/// Whether `out` is an existing directory whose entries detnoise did not list in a manifest
/// are all part files and their locks (so that a rerun or another shard may write beside
/// them without `force`). A part file that cannot be read is an error saying why (damaged,
/// edited), not a file detnoise did not write.
fn holds_only_ours(out: &Path) -> Result<bool> {
    if !out.is_dir() {
        return Ok(false);
    }
    let s = survey(out).map_err(|e| Error::io(out, e))?;
    for p in &s.foreign {
        let path = out.join(p);
        let name = p.to_string_lossy();
        // A part file being created by another shard: its header, written atomically.
        let creating = name.starts_with(".subaps-") && name.contains(".part.");
        if creating || is_lock_name(&path) {
            continue;
        }
        if !(is_part_name(&path) && path.is_file()) {
            return Ok(false);
        }
        read_part(&path)?;
    }
    Ok(true)
}

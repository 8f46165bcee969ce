//! Running a job: every sub-aperture (or one shard's) solved in parallel, each finished one
//! handed on at once (appended to the part file, or kept in memory for the report).

use super::geometry::{Geometry, Layout, Subap};
use super::ladder::{checkpoints, ladder_sigmas, references, Ladder};
use super::part::{Binding, PartHeader, PartRecord, Shard};
use super::solve::{check_centroider, solve_group, NoiseMap, Step, WindowStats, GROUP};
use crate::calib::Map;
use crate::centroid::CentroiderSpec;
use crate::effective::Precision;
use crate::montecarlo::SimConfig;
use crate::progress::Observer;
use crate::{Error, Result};
use rayon::prelude::*;
use std::collections::HashSet;
use std::sync::Mutex;

/// A per-sub-aperture job: a measured noise map (e-), the lenslet geometry, and the one
/// configuration every sub-aperture is solved in (its `subap_px` the grid's size; its seed
/// shared by all: common random numbers) to `precision`.
#[derive(Debug, Clone)]
pub struct SubapsJob<'a> {
    /// The measured noise map (e-).
    pub map: &'a Map,
    /// The lenslet geometry.
    pub geometry: &'a Geometry,
    /// The configuration of every sub-aperture.
    pub config: SimConfig,
    /// The precision of every value, and the iteration cap.
    pub precision: Precision,
    /// The centroider every sub-aperture is read through (the constant-sigma references too,
    /// each at its own best setting).
    pub centroider: CentroiderSpec,
}

/// A job checked and laid out on its map.
pub struct Plan<'a> {
    /// The map, cut into windows.
    pub noise: NoiseMap<'a>,
    /// The sub-apertures.
    pub layout: Layout,
    /// What the results depend on.
    pub binding: Binding,
    /// The centroider.
    pub centroider: CentroiderSpec,
}

impl<'a> SubapsJob<'a> {
    /// Check the geometry, the configuration and the precision (errors name the field), then
    /// the map (in e-, with a finite pixel) and the layout on it.
    pub fn plan(&self) -> Result<Plan<'a>> {
        let g = &self.geometry.grid;
        g.validate()?;
        if self.config.subap_px != g.size_px {
            return Err(Error::invalid(
                "subap_px",
                format!(
                    "{} px differs from the grid's sub-aperture size {} px (`subap_grid`)",
                    self.config.subap_px, g.size_px
                ),
            ));
        }
        self.config.validate()?;
        self.precision.validate(self.config.iters)?;
        self.centroider.validate()?;
        let noise = NoiseMap::new(self.map)?;
        let layout = self.geometry.layout(self.map.rows, self.map.cols)?;
        // The centroider is built by each solve: one that cannot read these windows is
        // refused now, before any output exists.
        let first = noise.readout(&layout.subaps[0], g.size_px);
        check_centroider(&self.config, self.centroider, &first)?;
        let binding = Binding::new(
            self.map,
            (g, self.geometry.mask.as_ref(), &layout),
            &self.config,
            &self.precision,
            &self.centroider,
        );
        Ok(Plan {
            noise,
            layout,
            binding,
            centroider: self.centroider,
        })
    }
}

impl Plan<'_> {
    /// The header of `shard`'s part file.
    pub fn header(&self, shard: Shard) -> PartHeader {
        let in_shard = self.layout.shard(shard.k, shard.n).len();
        PartHeader::new(
            self.binding.clone(),
            shard,
            in_shard,
            &self.noise.map.source,
        )
    }
}

/// Solve `todo` (sub-apertures of `plan`) in configuration `cfg`, handing each record to
/// `sink` as soon as it is finished (from worker threads, in no fixed order).
///
/// The constant-sigma ladder (`ladder`) is run once; the sub-apertures then run in groups of
/// [`GROUP`] to the first checkpoint, in parallel, and those short of their target run again,
/// regrouped, to the checkpoint they ask for, until every one is settled. A sub-aperture's
/// result depends on its own window and the seed only (not on its group, the shard or the
/// threads). The observer sees one stage, `subaps`, counting sub-apertures; each solve's
/// warnings reach it once per distinct message, and it is polled between groups (and by each
/// run between batches) to stop the run.
pub fn solve_each(
    plan: &Plan,
    cfg: &SimConfig,
    precision: &Precision,
    todo: &[Subap],
    observer: &dyn Observer,
    sink: &(dyn Fn(PartRecord) -> Result<()> + Sync),
) -> Result<()> {
    let pixels = (cfg.subap_px * cfg.subap_px) as u64;
    observer.begin(
        "subaps",
        todo.len() as u64,
        cfg.iters * pixels * todo.len() as u64,
    );
    observer.unit("sub-apertures");
    let seen = Mutex::new(HashSet::new());
    let inner = PerSubap {
        outer: observer,
        seen: &seen,
    };
    let result = solve_rounds(plan, (cfg, precision), todo, (observer, &inner), sink);
    observer.end();
    result
}

/// The rounds of [`solve_each`]: the ladder, then groups to their checkpoints until every
/// sub-aperture is settled.
fn solve_rounds(
    plan: &Plan,
    (cfg, precision): (&SimConfig, &Precision),
    todo: &[Subap],
    (observer, inner): (&dyn Observer, &PerSubap),
    sink: &(dyn Fn(PartRecord) -> Result<()> + Sync),
) -> Result<()> {
    let sigmas = ladder_sigmas(&plan.noise);
    let references = references(&sigmas);
    let checkpoints = checkpoints(cfg.iters, precision);
    let mut ladder = Ladder::new(cfg, (sigmas, &references), plan.centroider, checkpoints)?;
    let mut pending: Vec<(usize, Subap)> = todo.iter().map(|&s| (0, s)).collect();
    while !pending.is_empty() {
        // Groups of sub-apertures bound for the same checkpoint, in index order.
        pending.sort_by_key(|(k, s)| (*k, s.index));
        // The first round evaluates everyone at the first checkpoint; those short of their
        // target then go on (a minority, most of them to the cap), so the ladder is run
        // to the cap at once and groups continue as far as they need.
        let top = match pending[pending.len() - 1].0 {
            0 => 0,
            _ => ladder.checkpoints.len() - 1,
        };
        ladder.reach(top, inner, 0)?;
        // Small jobs get smaller groups: every thread busy, and records written as they come
        // (a killed run keeps more). The groups change the cost, never a result.
        let size = pending
            .len()
            .div_ceil(4 * rayon::current_num_threads())
            .clamp(1, GROUP);
        let groups: Vec<&[(usize, Subap)]> = pending
            .chunk_by(|a, b| a.0 == b.0)
            .flat_map(|same| same.chunks(size))
            .collect();
        let ladder = &ladder;
        let later = groups
            .par_iter()
            .map(|group| {
                if observer.cancelled() {
                    return Err(Error::Interrupted);
                }
                let job = (cfg, &plan.noise, plan.centroider);
                let steps = solve_group(job, ladder, group, precision, inner)?;
                let mut later = Vec::new();
                for (&(_, s), step) in group.iter().zip(steps) {
                    match step {
                        Step::Done(v) => {
                            let window = WindowStats::of(&plan.noise.window(&s, cfg.subap_px));
                            let at = (s.index, s.grid_row, s.grid_col);
                            sink(PartRecord::new(at, &v, window))?;
                            observer.advance(1);
                        }
                        Step::More(next) => later.push((next, s)),
                    }
                }
                Ok(later)
            })
            .collect::<Result<Vec<_>>>()?;
        pending = later.concat();
    }
    Ok(())
}

/// The observer of one solve: its progress in pixel-frames stays inside (the stage counts
/// sub-apertures); each distinct warning is passed on once; cancellation is the outer one's.
struct PerSubap<'a> {
    outer: &'a dyn Observer,
    seen: &'a Mutex<HashSet<String>>,
}

impl Observer for PerSubap<'_> {
    fn warn(&self, message: &str) {
        if self
            .seen
            .lock()
            .expect("warning set")
            .insert(message.to_string())
        {
            self.outer.warn(&format!(
                "{message} (a sub-aperture's solve; the same warning is not repeated)"
            ));
        }
    }

    fn cancelled(&self) -> bool {
        self.outer.cancelled()
    }
}

/// Solve every sub-aperture of `job` in memory (no part file): the job's header and its
/// records in index order. For callers that want the map at once (the report).
pub fn solve_all(
    job: &SubapsJob,
    observer: &dyn Observer,
) -> Result<(PartHeader, Vec<PartRecord>)> {
    let plan = job.plan()?;
    let records = Mutex::new(Vec::with_capacity(plan.layout.subaps.len()));
    solve_each(
        &plan,
        &job.config,
        &job.precision,
        &plan.layout.subaps,
        observer,
        &|r| {
            records.lock().expect("records").push(r);
            Ok(())
        },
    )?;
    let mut records = records.into_inner().expect("records");
    records.sort_by_key(|r| r.index);
    Ok((plan.header(Shard::ALL), records))
}

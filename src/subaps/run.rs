//! Running a job: every sub-aperture (or one shard's) solved in parallel, each finished one
//! handed on at once (appended to the part file, or kept in memory for the report).

use super::geometry::{Geometry, Layout, Subap};
use super::part::{Binding, PartHeader, PartRecord, Shard};
use super::solve::{check_centroider, solve_subap, NoiseMap, WindowStats};
use crate::calib::Map;
use crate::centroid::CentroiderSpec;
use crate::effective::{planned_work, Precision};
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
    /// The centroider every sub-aperture is read through (the references use `cog`).
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

/// Solve `todo` (sub-apertures of `plan`) in parallel in configuration `cfg`, handing each
/// record to `sink` as soon as it is finished (from worker threads, in no fixed order). The
/// observer sees one stage, `subaps`, counting sub-apertures; each solve's warnings reach it
/// once per distinct message, and it is polled between sub-apertures (and by each solve
/// between batches) to stop the run.
pub fn solve_each(
    plan: &Plan,
    cfg: &SimConfig,
    precision: &Precision,
    todo: &[Subap],
    observer: &dyn Observer,
    sink: &(dyn Fn(PartRecord) -> Result<()> + Sync),
) -> Result<()> {
    let work = planned_work(cfg) * todo.len() as u64;
    observer.begin("subaps", todo.len() as u64, work);
    observer.unit("sub-apertures");
    let seen = Mutex::new(HashSet::new());
    let inner = PerSubap {
        outer: observer,
        seen: &seen,
    };
    let result = todo.par_iter().try_for_each(|s| {
        if observer.cancelled() {
            return Err(Error::Interrupted);
        }
        let e = solve_subap(cfg, &plan.noise, s, plan.centroider, precision, &inner)?;
        let window = WindowStats::of(&plan.noise.window(s, cfg.subap_px));
        sink(PartRecord::new(
            (s.index, s.grid_row, s.grid_col),
            &e,
            window,
        ))?;
        observer.advance(1);
        Ok(())
    });
    observer.end();
    result
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

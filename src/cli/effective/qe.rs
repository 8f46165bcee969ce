//! `detnoise effective --simple-qe`: the QE factor of the simple EMCCD model over the grid.

use super::super::progress::Terminal;
use crate::detector::{ModelParams, ModelSpec};
use crate::effective::{effective_qe_table, write_qe_tables, QePrecision, QeRecord};
use crate::montecarlo::SimConfig;
use crate::output::OutputDir;
use crate::Result;
use std::fmt::Write as _;

/// Solve every configuration, write the tables and the charts into `dir` and print the table.
pub(super) fn run(
    configs: &[SimConfig],
    specs: &[ModelSpec],
    params: &ModelParams,
    precision: &QePrecision,
    dir: &OutputDir,
) -> Result<()> {
    let records = effective_qe_table(configs, specs, params, precision, &Terminal::default())?;
    write_qe_tables(&records, &dir.path(""))?;
    crate::charts::qe_factor::save_charts(&records, dir)?;
    print!("{}", qe_terminal_table(&records));
    Ok(())
}

/// The records as the terminal shows them (under 100 columns): the configuration, the factor
/// and its SE, its departure from 0.5 in SE, the iterations and the status word; no value is
/// printed for a status that has none.
pub fn qe_terminal_table(records: &[QeRecord]) -> String {
    let mut out = String::new();
    if let Some(first) = records.first() {
        let c = &first.config;
        let _ = writeln!(
            out,
            "{}: QE factor of emccd-simple (read noise {:.4} e-), gain {}, {} sampling, QE {}, \
             seed {}",
            first.model,
            first.qe.read_noise_e,
            first.em_gain,
            c.sampling.label(),
            c.qe,
            c.seed
        );
    }
    let _ = writeln!(
        out,
        "{:>5}  {:<12} {:>8} {:>9} {:>9} {:>8} {:>8}  status",
        "subap", "spot", "photons", "iters", "qe_factor", "SE", "z(0.5)"
    );
    for r in records {
        let (c, q) = (&r.config, &r.qe);
        let num = |v: Option<f64>, d: usize| v.map_or("-".to_string(), |v| format!("{v:.d$}"));
        let valued = q.status.has_value();
        let finite = |v: f64| (valued && v.is_finite()).then_some(v);
        let _ = writeln!(
            out,
            "{:>5}  {:<12} {:>8} {:>9} {:>9} {:>8} {:>8}  {}",
            c.subap_px,
            c.spot.label(),
            c.signal_photons,
            q.iters,
            num(finite(q.qe_factor), 3),
            num(finite(q.qe_factor_se), 3),
            num(q.paper_z(), 1),
            q.status.label()
        );
    }
    out
}

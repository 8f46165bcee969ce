//! `detnoise effective --simple-qe`: the QE factor of the simple EMCCD model over the grid.

use super::super::progress::Terminal;
use crate::detector::{ModelParams, ModelSpec};
use crate::effective::{effective_qe_table, write_qe_tables, QePrecision};
use crate::montecarlo::SimConfig;
use crate::output::OutputDir;
use crate::Result;

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
    print!("{}", super::qe_terminal_table(&records));
    Ok(())
}

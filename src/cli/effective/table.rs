//! The terminal tables of `effective` and `effective --simple-qe` (under 100 columns): a line
//! stating the run, the configuration columns both share, each one's value columns, the
//! iterations and the status word; no value is printed for a status that has none.

use super::super::table::{self, Align, Column, Width};
use crate::effective::{EffectiveRecord, QeRecord, Status};
use crate::montecarlo::SimConfig;
use std::fmt::Write as _;

/// The effective read noise of each record: its value and SE, and the SE it had to reach (and,
/// when a centroider other than `cog` is in the table, the cog-equivalent).
pub fn terminal_table(records: &[EffectiveRecord]) -> String {
    let mut out = String::new();
    if let Some(first) = records.first() {
        let c = &first.config;
        let _ = writeln!(
            out,
            "{}: effective read noise (e-), {} sampling, QE {}, seed {}",
            first.model,
            c.sampling.label(),
            c.qe,
            c.seed
        );
    }
    let mut columns = with_config_columns([
        right("iters", 9, |r: &EffectiveRecord| {
            r.effective.iters.to_string()
        }),
        right("sigma_eff", 10, |r| {
            num(r.value(r.effective.sigma_eff_e), 3)
        }),
        right("SE", 8, |r| num(r.value(r.effective.sigma_eff_se_e), 3)),
        right("target", 8, |r| num(r.effective.target_se_e, 3)),
        status(|r| r.effective.status.label().to_string()),
    ]);
    // Another centroider than cog has a cog-equivalent of its own (its SE is in the files):
    // a column before the status, which plain-cog tables do not have.
    let cog = crate::centroid::CentroiderSpec::default().label();
    if records.iter().any(|r| r.centroider != cog) {
        let at = columns.len() - 1;
        columns.insert(
            at,
            right("cog_equiv", 9, |r: &EffectiveRecord| {
                let v = r.effective.sigma_cog_equiv_e;
                num(v.is_finite().then_some(v), 3)
            }),
        );
    }
    // Records of several centroiders come in groups, each headed by its centroider.
    let several = records
        .iter()
        .any(|r| r.centroider != records[0].centroider);
    out + &table::render(&columns, records, |k| {
        let r = &records[k];
        (several && (k == 0 || records[k - 1].centroider != r.centroider))
            .then(|| format!("centroider {}:", r.centroider))
    })
}

/// The QE factor of each record: its value and SE, and its departure from 0.5 in SE.
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
    let columns = with_config_columns([
        right("iters", 9, |r: &QeRecord| r.qe.iters.to_string()),
        right("qe_factor", 9, |r| num(r.value(r.qe.qe_factor), 3)),
        right("SE", 8, |r| num(r.value(r.qe.qe_factor_se), 3)),
        right("z(0.5)", 8, |r| num(r.qe.paper_z(), 1)),
        status(|r| r.qe.status.label().to_string()),
    ]);
    out + &table::render(&columns, records, |_| None)
}

/// A record of the grid `effective` runs over.
trait GridRecord {
    /// Its configuration.
    fn config(&self) -> &SimConfig;
    /// Whether its status has a value to print.
    fn has_value(&self) -> bool;
    /// `v` when the status has a value and `v` is finite.
    fn value(&self, v: f64) -> Option<f64> {
        (self.has_value() && v.is_finite()).then_some(v)
    }
}

impl GridRecord for EffectiveRecord {
    fn config(&self) -> &SimConfig {
        &self.config
    }
    fn has_value(&self) -> bool {
        !matches!(
            self.effective.status,
            Status::Unreachable | Status::NoEligibleLevel
        )
    }
}

impl GridRecord for QeRecord {
    fn config(&self) -> &SimConfig {
        &self.config
    }
    fn has_value(&self) -> bool {
        self.qe.status.has_value()
    }
}

/// The configuration columns (sub-aperture, spot, photons), then `rest`.
fn with_config_columns<R: GridRecord, const N: usize>(rest: [Column<R>; N]) -> Vec<Column<R>> {
    let spot = Column {
        head: "spot",
        align: Align::Left,
        width: Width::AtLeast(12),
        gap: 2,
        cell: |r: &R| r.config().spot.label(),
    };
    let mut columns = vec![
        Column {
            gap: 0,
            ..right("subap", 5, |r: &R| r.config().subap_px.to_string())
        },
        spot,
        right("photons", 8, |r: &R| r.config().signal_photons.to_string()),
    ];
    columns.extend(rest);
    columns
}

/// A right-aligned column at least `width` wide, a space after the previous one.
fn right<R>(head: &'static str, width: usize, cell: fn(&R) -> String) -> Column<R> {
    Column {
        head,
        align: Align::Right,
        width: Width::AtLeast(width),
        gap: 1,
        cell,
    }
}

/// The status word, last, two spaces after the values.
fn status<R>(cell: fn(&R) -> String) -> Column<R> {
    Column {
        head: "status",
        align: Align::Left,
        width: Width::AtLeast(0),
        gap: 2,
        cell,
    }
}

/// `v` to `decimals` decimals, or `-` when there is none.
fn num(v: Option<f64>, decimals: usize) -> String {
    v.map_or("-".to_string(), |v| format!("{v:.decimals$}"))
}

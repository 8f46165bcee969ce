//! The simple EMCCD model's effective QE factor in a report: the page's section (a sentence on
//! where the paper's 0.5 holds, the chart of [`crate::charts::qe_factor`], the table) and the
//! key numbers of `summary.json`.

use super::html::{figure, num};
use crate::detector::EmccdSimple;
use crate::effective::{QeRecord, QeStatus};
use crate::output::html_escape as esc;
use crate::spot::Spot;
use std::fmt::Write as _;

/// Standard errors within which a factor agrees with the paper's 0.5.
pub const HOLDS_WITHIN_SE: f64 = 2.0;

/// One configuration's factor in `summary.json`.
#[derive(Debug, Clone, serde::Serialize)]
pub struct QeAt {
    /// Sub-aperture size (px per side).
    pub subap_px: usize,
    /// Spot label.
    pub spot: String,
    /// Signal (photons per sub-aperture).
    pub signal_photons: f64,
    /// The factor (unitless; null without a value).
    pub qe_factor: Option<f64>,
    /// Its standard error (null without a value).
    pub qe_factor_se: Option<f64>,
    /// Its status word.
    pub status: QeStatus,
}

impl QeAt {
    fn of(r: &QeRecord) -> Self {
        let finite = |v: f64| (r.qe.status.has_value() && v.is_finite()).then_some(v);
        QeAt {
            subap_px: r.config.subap_px,
            spot: r.config.spot.label(),
            signal_photons: r.config.signal_photons,
            qe_factor: finite(r.qe.qe_factor),
            qe_factor_se: finite(r.qe.qe_factor_se),
            status: r.qe.status,
        }
    }

    fn describe(&self) -> String {
        format!(
            "{}×{} px, {}, S = {}",
            self.subap_px, self.subap_px, self.spot, self.signal_photons
        )
    }
}

/// The effective QE factor's key numbers (`summary.json` `effective_qe`).
#[derive(Debug, Clone, serde::Serialize)]
pub struct QeSummary {
    /// Read noise of the simple model (e-, referred to the input): the camera's over its gain.
    pub simple_read_noise_e: f64,
    /// Configurations solved.
    pub configurations: usize,
    /// Configurations whose factor is `ok`.
    pub ok: usize,
    /// `ok` factors within 2 SE of the paper's 0.5.
    pub paper_holds: usize,
    /// `ok` factors more than 2 SE from 0.5.
    pub paper_fails: usize,
    /// ...of which below 0.5 (the camera does worse than the paper's simple model).
    pub paper_fails_below: usize,
    /// The smallest `ok` factor and where.
    pub lowest: Option<QeAt>,
    /// The largest `ok` factor and where.
    pub highest: Option<QeAt>,
    /// The factor at the operating point, when it is one of the grid's configurations.
    pub at_operating_point: Option<QeAt>,
    /// Per signal (ascending): where 0.5 holds.
    pub by_signal: Vec<HoldsAt>,
}

/// How many `ok` factors at one signal agree with 0.5 within 2 SE.
#[derive(Debug, Clone, serde::Serialize)]
pub struct HoldsAt {
    /// Signal (photons per sub-aperture).
    pub signal_photons: f64,
    /// `ok` factors at this signal.
    pub ok: usize,
    /// ...of which within 2 SE of 0.5.
    pub paper_holds: usize,
    /// The mean `ok` factor at this signal (unitless; null without one).
    pub mean_qe_factor: Option<f64>,
}

impl QeSummary {
    /// The summary of `records`; `op` is the operating point's configuration (sub-aperture,
    /// spot, signal).
    pub fn new(records: &[QeRecord], op: (usize, Spot, f64)) -> Self {
        let ok: Vec<&QeRecord> = records
            .iter()
            .filter(|r| r.qe.status == QeStatus::Ok)
            .collect();
        let fails: Vec<&&QeRecord> = ok.iter().filter(|r| !holds(r)).collect();
        let by_q = |a: &&&QeRecord, b: &&&QeRecord| a.qe.qe_factor.total_cmp(&b.qe.qe_factor);
        let config =
            |r: &&QeRecord| (r.config.subap_px, r.config.spot, r.config.signal_photons) == op;
        QeSummary {
            simple_read_noise_e: records.first().map_or(f64::NAN, |r| r.qe.read_noise_e),
            configurations: records.len(),
            ok: ok.len(),
            paper_holds: ok.len() - fails.len(),
            paper_fails: fails.len(),
            paper_fails_below: fails
                .iter()
                .filter(|r| r.qe.qe_factor < EmccdSimple::PAPER_FACTOR)
                .count(),
            lowest: ok.iter().min_by(by_q).map(|r| QeAt::of(r)),
            highest: ok.iter().max_by(by_q).map(|r| QeAt::of(r)),
            at_operating_point: records.iter().find(|r| config(r)).map(QeAt::of),
            by_signal: by_signal(&ok),
        }
    }

    /// Where the paper's 0.5 holds (within 2 SE) and where it does not, with the numbers.
    pub fn sentence(&self) -> String {
        if self.ok == 0 {
            return format!(
                "No configuration's factor reached the precision target ({} solved), so this \
                 report cannot say where the paper's 0.5 holds: see the table's status words.",
                self.configurations
            );
        }
        let q = |a: &Option<QeAt>| {
            a.as_ref().map_or(String::new(), |a| {
                format!(
                    "{} ± {} ({})",
                    num(a.qe_factor.unwrap_or(f64::NAN), 3),
                    num(a.qe_factor_se.unwrap_or(f64::NAN), 3),
                    a.describe()
                )
            })
        };
        let mut s = format!(
            "The paper's factor 0.5 holds (within {HOLDS_WITHIN_SE} SE) in {} of the {} \
             configurations with an <span class=\"status\">ok</span> factor",
            self.paper_holds, self.ok
        );
        if self.paper_fails == 0 {
            s.push_str(
                ": for this camera the paper's simple model is right everywhere it was tested.",
            );
        } else {
            let _ = write!(
                s,
                ", and not in {}: in {} of them the factor is below 0.5 (the camera does worse \
                 than the paper's simple model, which is optimistic there), in {} above. The \
                 factor ranges from {} to {}.",
                self.paper_fails,
                self.paper_fails_below,
                self.paper_fails - self.paper_fails_below,
                q(&self.lowest),
                q(&self.highest)
            );
        }
        let per_signal: Vec<String> = self
            .by_signal
            .iter()
            .filter(|b| b.ok > 0)
            .map(|b| {
                format!(
                    "S = {}: {} of {} (mean q {})",
                    b.signal_photons,
                    b.paper_holds,
                    b.ok,
                    num(b.mean_qe_factor.unwrap_or(f64::NAN), 3)
                )
            })
            .collect();
        if self.paper_fails > 0 && per_signal.len() > 1 {
            let _ = write!(s, " Where it holds, by signal: {}.", per_signal.join("; "));
        }
        if self.ok < self.configurations {
            let _ = write!(
                s,
                " {} configurations have no ok factor (see their status).",
                self.configurations - self.ok
            );
        }
        s
    }
}

/// Per signal (ascending) of the `ok` records: how many hold, and their mean factor.
fn by_signal(ok: &[&QeRecord]) -> Vec<HoldsAt> {
    let mut signals: Vec<f64> = ok.iter().map(|r| r.config.signal_photons).collect();
    signals.sort_by(f64::total_cmp);
    signals.dedup();
    signals
        .into_iter()
        .map(|s| {
            let at: Vec<&&QeRecord> = ok.iter().filter(|r| r.config.signal_photons == s).collect();
            let mean = at.iter().map(|r| r.qe.qe_factor).sum::<f64>() / at.len() as f64;
            HoldsAt {
                signal_photons: s,
                ok: at.len(),
                paper_holds: at.iter().filter(|r| holds(r)).count(),
                mean_qe_factor: mean.is_finite().then_some(mean),
            }
        })
        .collect()
}

/// Whether an `ok` factor agrees with 0.5 within [`HOLDS_WITHIN_SE`] standard errors.
fn holds(r: &QeRecord) -> bool {
    r.qe.paper_z().is_some_and(|z| z.abs() <= HOLDS_WITHIN_SE)
}

/// A factor as the page shows it: `ok` as q ± SE, `imprecise` greyed with its word, a bound
/// as "≥ 1" with its word, no value as its word alone.
fn fmt_factor(r: &QeRecord) -> String {
    let (q, se, st) = (r.qe.qe_factor, r.qe.qe_factor_se, r.qe.status);
    let word = format!("<span class=\"status\">{}</span>", st.label());
    match st {
        QeStatus::Ok => format!("{} ± {}", num(q, 3), num(se, 3)),
        QeStatus::Imprecise => format!(
            "<span class=\"muted\">{} ± {} {word}</span>",
            num(q, 3),
            num(se, 3)
        ),
        QeStatus::AboveRange => format!("≥ 1 {word}"),
        _ => word,
    }
}

/// The page's section: heading, sentence, chart of the operating spot (if drawn), the table
/// and the status words.
pub fn html_section(records: &[QeRecord], summary: &QeSummary, chart: Option<&str>) -> String {
    let mut h = String::from("<h2>The simple model's effective QE factor</h2>");
    let _ = write!(
        h,
        "<p>The paper recommends its simple EMCCD model (Poisson of half the flux, read noise \
         0.1 e⁻) for AO design. For each configuration, the QE factor q for which <code>emccd-simple:q</code> \
         with this camera's read noise over its gain ({} e⁻) has the same centroid error R as the \
         exact register with the fitted gain and read noise (common random numbers; SE from the \
         paired difference). Use these factors in an AO simulation that models this EMCCD as a \
         reduced QE.</p><p>{}</p>",
        num(summary.simple_read_noise_e, 3),
        summary.sentence()
    );
    if let Some(src) = chart {
        figure(
            &mut h,
            src,
            "Effective QE factor of the simple model against signal",
            "Effective QE factor q of the simple model against signal, one line per \
             sub-aperture size, at the operating point's spot, with error bars of one standard \
             error; the paper's 0.5 is marked. Only ok factors are drawn.",
        );
    }
    h.push_str(
        "<table><tr><th>sub-aperture</th><th>spot</th><th>signal (photons)</th><th>q</th>\
         <th>(q − 0.5) / SE</th><th>0.5 holds</th><th>frames</th></tr>",
    );
    for r in records {
        let z = r.qe.paper_z();
        let verdict = match (r.qe.status, z) {
            (QeStatus::Ok, Some(_)) if holds(r) => "yes",
            (QeStatus::Ok, Some(_)) => "no",
            _ => "–",
        };
        let _ = write!(
            h,
            "<tr><td>{n}×{n} px</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{verdict}</td><td>{}</td></tr>",
            esc(&r.config.spot.label()),
            r.config.signal_photons,
            fmt_factor(r),
            z.map_or("–".into(), |z| num(z, 1)),
            r.qe.iters,
            n = r.config.subap_px,
        );
    }
    h.push_str("</table><h3>Status words of the QE factor</h3><dl class=\"legend\">");
    for s in QeStatus::ALL {
        let _ = write!(
            h,
            "<dt><span class=\"status\">{}</span></dt><dd>{}</dd>",
            s.label(),
            esc(s.meaning())
        );
    }
    h.push_str("</dl>");
    h
}

#[cfg(test)]
mod tests;

//! The effective-noise heatmaps: one chart per signal over sub-aperture size x spot, all on one
//! colour scale (0 to the 95th percentile of the run's `ok` cells, or a fixed scale), with the
//! cells that are not `ok` drawn grey and hatched with their status word.

use crate::effective::{EffectiveRecord, Status};
use crate::output::OutputDir;
use crate::plot::Heatmap;
use crate::spot::Spot;
use crate::stats::percentile;
use crate::{Error, Result};
use std::path::PathBuf;

/// Percentile of the `ok` cells' effective noise that tops an automatic colour scale.
pub const SCALE_PERCENTILE: f64 = 95.0;

/// The colour scale of a run's heatmaps: 0 to `top_e` (e-), with the rule that chose it.
#[derive(Debug, Clone, PartialEq)]
pub struct NoiseScale {
    /// Top of the scale (e-); larger values take its top colour and a corner mark.
    pub top_e: f64,
    /// `top_e` as printed (a readable number: two significant digits).
    pub top_label: String,
    /// Why this top: "95th percentile of ok cells", "the paper's scale", ...
    pub rule: String,
}

impl NoiseScale {
    /// 0 to the [`SCALE_PERCENTILE`]th percentile of the `ok` records' sigma_eff (e-), rounded
    /// up to two significant digits; 0-1 e- when no record is `ok` (then nothing is coloured).
    pub fn from_ok(records: &[EffectiveRecord]) -> NoiseScale {
        let ok: Vec<f64> = records
            .iter()
            .filter(|r| r.effective.status == Status::Ok)
            .map(|r| r.effective.sigma_eff_e)
            .collect();
        let p = percentile(&ok, SCALE_PERCENTILE);
        if p.is_finite() && p > 0.0 {
            let (top_e, top_label) = round_up_2_digits(p);
            NoiseScale {
                top_e,
                top_label,
                rule: format!("{SCALE_PERCENTILE:.0}th percentile of ok cells"),
            }
        } else {
            NoiseScale::fixed(1.0, "no ok cell to scale by")
        }
    }

    /// The fixed scale 0 to `top_e` (e-), chosen by `rule`.
    pub fn fixed(top_e: f64, rule: &str) -> NoiseScale {
        NoiseScale {
            top_e,
            top_label: format!("{top_e}"),
            rule: rule.into(),
        }
    }

    /// The scale and its rule in words: "colour scale 0-4.8 e-, 95th percentile of ok cells".
    pub fn describe(&self) -> String {
        format!("colour scale 0-{} e-, {}", self.top_label, self.rule)
    }
}

/// `x` > 0 rounded up to two significant digits, with its text (4.73 -> 4.8, 12.1 -> 13).
pub fn round_up_2_digits(x: f64) -> (f64, String) {
    let exp = x.log10().floor() as i32 - 1;
    let step = 10f64.powi(exp);
    // A hair of tolerance: 4.8 must not become 4.9 through 4.8 / 0.1 = 48.000000000000004.
    let units = (x / step - 1e-9).ceil().max(1.0);
    let decimals = (-exp).max(0) as usize;
    let top = format!("{:.*}", decimals, units * step);
    (top.parse().expect("a formatted number"), top)
}

/// The y axis of a set of spots: its title and each spot's label on it.
fn spot_axis(spots: &[Spot]) -> (&'static str, Vec<String>) {
    if spots.iter().all(|s| matches!(s, Spot::Airy { .. })) {
        let names = spots
            .iter()
            .map(|s| match s {
                Spot::Airy { diameter_px } => format!("{diameter_px}"),
                Spot::Gauss { .. } => unreachable!("all Airy"),
            })
            .collect();
        ("spot diameter, first Airy minimum (px)", names)
    } else if spots.iter().all(|s| matches!(s, Spot::Gauss { .. })) {
        let names = spots
            .iter()
            .map(|s| match s {
                Spot::Gauss {
                    sigma_x_px,
                    sigma_y_px,
                } => format!("{sigma_x_px}, {sigma_y_px}"),
                Spot::Airy { .. } => unreachable!("all Gaussian"),
            })
            .collect();
        ("Gaussian spot, sigma x, y (px)", names)
    } else {
        let names = spots.iter().map(Spot::label).collect();
        (
            "spot (airy: first-minimum diameter; gauss: sigma x,y; px)",
            names,
        )
    }
}

/// The text of a cell that is not a result: its status word, and for `imprecise` the value
/// with its standard error above it.
pub fn cell_mark(r: &EffectiveRecord) -> Option<String> {
    let e = &r.effective;
    match e.status {
        Status::Ok => None,
        Status::Imprecise => Some(format!(
            "{:.2} ± {:.2}\n{}",
            e.sigma_eff_e,
            e.sigma_eff_se_e,
            e.status.label()
        )),
        s => Some(s.label().to_string()),
    }
}

/// The heatmap of `records` at `signal_photons` (sub-aperture size x spot) on `scale`. The
/// records must be of one model; `title` heads the chart.
pub fn heatmap(
    records: &[EffectiveRecord],
    signal_photons: f64,
    scale: &NoiseScale,
    title: String,
) -> Result<Heatmap> {
    let mut subaps: Vec<usize> = records.iter().map(|r| r.config.subap_px).collect();
    subaps.sort_unstable();
    subaps.dedup();
    let mut spots: Vec<Spot> = Vec::new();
    for r in records {
        if !spots.contains(&r.config.spot) {
            spots.push(r.config.spot);
        }
    }
    let (y_label, spot_names) = spot_axis(&spots);
    let mut values = vec![vec![f64::NAN; subaps.len()]; spots.len()];
    let mut marks = vec![vec![None; subaps.len()]; spots.len()];
    for r in records
        .iter()
        .filter(|r| r.config.signal_photons == signal_photons)
    {
        let i = subaps
            .iter()
            .position(|&n| n == r.config.subap_px)
            .ok_or_else(|| Error::Numeric("heatmap: sub-aperture outside the grid".into()))?;
        let j = spots
            .iter()
            .position(|s| *s == r.config.spot)
            .ok_or_else(|| Error::Numeric("heatmap: spot outside the grid".into()))?;
        values[j][i] = r.effective.sigma_eff_e;
        marks[j][i] = cell_mark(r);
    }
    let mut h = Heatmap::new(
        title,
        "sub-aperture size (px)",
        y_label,
        subaps.iter().map(|n| n.to_string()).collect(),
        spot_names,
        values,
        "effective read noise (e-)",
    );
    h.marks = marks;
    h.decimals = 2;
    h.range = Some((0.0, scale.top_e));
    h.note = format!(
        "{} · {} above the scale · hatched: no result (status)",
        scale.describe(),
        Heatmap::CLIPPED_MARK
    );
    Ok(h)
}

/// The signals of `records`, ascending.
pub fn signals(records: &[EffectiveRecord]) -> Vec<f64> {
    let mut s: Vec<f64> = records.iter().map(|r| r.config.signal_photons).collect();
    s.sort_by(f64::total_cmp);
    s.dedup();
    s
}

/// One heatmap per signal of `records` on `scale`, as PNG and SVG at `path(signal, ext)`, each
/// titled `title(signal)`; returns the paths written.
pub fn save_heatmaps(
    records: &[EffectiveRecord],
    scale: &NoiseScale,
    title: &dyn Fn(f64) -> String,
    path: &dyn Fn(f64, &str) -> PathBuf,
) -> Result<Vec<PathBuf>> {
    let mut written = Vec::new();
    for s in signals(records) {
        let h = heatmap(records, s, scale, title(s))?;
        for ext in ["png", "svg"] {
            let p = path(s, ext);
            h.save(&p)?;
            written.push(p);
        }
    }
    Ok(written)
}

/// One heatmap per signal level (PNG and SVG, `effective_noise_S<signal>`): sub-aperture size x
/// spot, colour = sigma_eff_e (the same-centroider value) on one scale for every signal
/// ([`NoiseScale::from_ok`]), cells that are not `ok` grey with their status. The records must be of one model.
pub fn effective_heatmaps(records: &[EffectiveRecord], dir: &OutputDir) -> Result<Vec<PathBuf>> {
    let model = records.first().map_or("", |r| r.model.as_str());
    let scale = NoiseScale::from_ok(records);
    let mut centroiders: Vec<&str> = Vec::new();
    for r in records {
        if !centroiders.contains(&r.centroider.as_str()) {
            centroiders.push(&r.centroider);
        }
    }
    let mut paths = Vec::new();
    for c in centroiders {
        // The paper's centroider keeps the plain names; the others are named in the file, and
        // the title says their uniform cameras are read through the same centroider.
        let (suffix, named) = match c {
            "cog" => (String::new(), String::new()),
            c => (
                format!("_{}", c.replace(':', "_")),
                format!(", {c} (same-centroider)"),
            ),
        };
        let mine: Vec<EffectiveRecord> = records
            .iter()
            .filter(|r| r.centroider == c)
            .cloned()
            .collect();
        paths.extend(save_heatmaps(
            &mine,
            &scale,
            &|s| {
                format!(
                    "Effective read noise (e-), {model}{named}, S = {s} photons per sub-aperture"
                )
            },
            &|s, ext| dir.path(&format!("effective_noise_S{s}{suffix}.{ext}")),
        )?);
    }
    Ok(paths)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::effective::Effective;
    use crate::montecarlo::SimConfig;

    /// A record of the fitted pdf at (n px, airy:d, s photons) with sigma_eff +- se and `status`.
    pub(crate) fn record(
        n: usize,
        d: f64,
        s: f64,
        sigma: f64,
        se: f64,
        status: Status,
    ) -> EffectiveRecord {
        let cfg = SimConfig {
            spot: Spot::Airy { diameter_px: d },
            signal_photons: s,
            ..SimConfig::paper(n)
        };
        let e = Effective {
            sigma_eff_e: sigma,
            sigma_eff_se_e: se,
            sigma_cog_equiv_e: sigma,
            sigma_cog_equiv_se_e: se,
            r_px: 0.3,
            r_se_px: 0.003,
            b_opt_e: 0.0,
            param_name: None,
            param_opt: None,
            sigma_grid_e: vec![],
            r_const_px: vec![],
            iters: cfg.iters,
            target_se_e: Some(0.05),
            status,
            parts: Default::default(),
        };
        EffectiveRecord::new("scmos-random".into(), &cfg, &e)
    }

    /// Every status over a 4 x 3 grid at two signals: ok cells 1.0, 1.5, ..., 9.0 e- (17 of
    /// them), and non-ok cells with values far above them that must not set the scale.
    pub(crate) fn every_status() -> Vec<EffectiveRecord> {
        let subaps = [4, 8, 12, 16];
        let spots = [1.0, 2.0, 6.0];
        let mut out = Vec::new();
        let mut ok = (2..=18).map(|k| k as f64 * 0.5);
        for s in [20.0, 50.0] {
            for (i, &n) in subaps.iter().enumerate() {
                for (j, &d) in spots.iter().enumerate() {
                    let r = match (s == 20.0, i, j) {
                        (true, 3, 2) => record(n, d, s, 67.31, 120.65, Status::Imprecise),
                        (true, 3, 1) => record(n, d, s, 0.0, 0.2, Status::LowerBound),
                        (true, 3, 0) => record(n, d, s, f64::NAN, f64::NAN, Status::Unreachable),
                        (false, 3, 2) => {
                            record(n, d, s, f64::NAN, f64::NAN, Status::NoEligibleLevel)
                        }
                        _ => match ok.next() {
                            Some(v) => record(n, d, s, v, 0.05, Status::Ok),
                            None => record(n, d, s, 29.71, 18.47, Status::Imprecise),
                        },
                    };
                    out.push(r);
                }
            }
        }
        out
    }

    #[test]
    fn readable_tops_round_up_to_two_significant_digits() {
        for (x, top, label) in [
            (4.73, 4.8, "4.8"),
            (4.8, 4.8, "4.8"),
            (12.1, 13.0, "13"),
            (0.873, 0.88, "0.88"),
            (100.0, 100.0, "100"),
            (0.05, 0.05, "0.050"),
            (6.0001, 6.1, "6.1"),
        ] {
            assert_eq!(round_up_2_digits(x), (top, label.to_string()), "{x}");
        }
    }

    #[test]
    fn the_scale_is_the_95th_percentile_of_the_ok_cells_only() {
        let records = every_status();
        let ok: Vec<f64> = (2..=18).map(|k| k as f64 * 0.5).collect();
        assert_eq!(
            records
                .iter()
                .filter(|r| r.effective.status == Status::Ok)
                .count(),
            ok.len()
        );
        // 95th percentile of 1.0..9.0 in steps of 0.5 (17 values): position 0.95 x 16 = 15.2,
        // 8.5 + 0.2 x 0.5 = 8.6; the imprecise 67.31 and 29.71 e- would raise it.
        assert!((percentile(&ok, 95.0) - 8.6).abs() < 1e-12);
        let scale = NoiseScale::from_ok(&records);
        assert_eq!((scale.top_e, scale.top_label.as_str()), (8.6, "8.6"));
        assert_eq!(
            scale.describe(),
            "colour scale 0-8.6 e-, 95th percentile of ok cells"
        );
        let none_ok: Vec<EffectiveRecord> = records
            .into_iter()
            .filter(|r| r.effective.status != Status::Ok)
            .collect();
        assert_eq!(NoiseScale::from_ok(&none_ok).top_e, 1.0);
    }

    #[test]
    fn cells_that_are_not_ok_carry_their_status_word_and_no_colour() {
        let records = every_status();
        let scale = NoiseScale::from_ok(&records);
        let h = heatmap(&records, 20.0, &scale, "S = 20".into()).unwrap();
        assert_eq!(h.x_label, "sub-aperture size (px)");
        assert_eq!(h.y_label, "spot diameter, first Airy minimum (px)");
        assert_eq!(h.x_categories, ["4", "8", "12", "16"]);
        assert_eq!(h.y_categories, ["1", "2", "6"]);
        assert_eq!(h.range, Some((0.0, 8.6)));
        // Row = spot, column = sub-aperture: the 16 px column holds the three non-ok cells.
        let col: Vec<Option<&str>> = h.marks.iter().map(|r| r[3].as_deref()).collect();
        assert_eq!(
            col,
            [
                Some("unreachable"),
                Some("lower_bound"),
                Some("67.31 ± 120.65\nimprecise")
            ]
        );
        assert!(h.marks.iter().all(|r| r[..3].iter().all(Option::is_none)));
        let h50 = heatmap(&records, 50.0, &scale, "S = 50".into()).unwrap();
        assert_eq!(h50.marks[2][3].as_deref(), Some("no_eligible_level"));

        let dir = tempfile::tempdir().unwrap();
        let written = save_heatmaps(&records, &scale, &|s| format!("S = {s}"), &|s, ext| {
            dir.path().join(format!("h{s}.{ext}"))
        })
        .unwrap();
        assert_eq!(written.len(), 4);
        let svg = std::fs::read_to_string(dir.path().join("h20.svg")).unwrap();
        for text in [
            "unreachable",
            "lower_bound",
            "imprecise",
            "67.31 ± 120.65",
            "colour scale 0-8.6 e-, 95th percentile of ok cells",
            "spot diameter, first Airy minimum (px)",
            "sub-aperture size (px)",
        ] {
            assert!(svg.contains(text), "lacks {text:?}");
        }
        assert!(!svg.contains("NaN"));
        // Marked cells are filled grey; the clipped 9.0 e- cell (above 8.6) takes the top colour.
        let grey = svg.matches("fill=\"#DEDEDE\"").count();
        assert_eq!(grey, 3, "grey cells");
        if let Some(keep) = std::env::var_os("DETNOISE_PLOT_DIR") {
            for f in written {
                std::fs::copy(&f, std::path::Path::new(&keep).join(f.file_name().unwrap()))
                    .unwrap();
            }
        }
    }
}

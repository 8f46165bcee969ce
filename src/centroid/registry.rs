//! The registry's machinery over a table of [`CentroiderEntry`]s: the names, the help, lookup
//! and parsing of `NAME[:PARAM]`. The table itself is `centroid::CENTROIDERS`.

use super::spec::{CentroiderEntry, CentroiderSpec};
use crate::{Error, Result};

/// Every entry's name joined by `sep`, in the table's order.
pub(super) fn names(entries: &[CentroiderEntry], sep: &str) -> String {
    let names: Vec<&str> = entries.iter().map(|e| e.name).collect();
    names.join(sep)
}

/// The entry named `name`.
pub(super) fn find(
    entries: &'static [CentroiderEntry],
    name: &str,
) -> Option<&'static CentroiderEntry> {
    entries.iter().find(|e| e.name == name)
}

/// Parse `NAME[:PARAM]` against `entries`; errors name the `centroider` field and list the
/// known names.
pub(super) fn parse(entries: &'static [CentroiderEntry], text: &str) -> Result<CentroiderSpec> {
    let invalid = |why: String| Error::invalid("centroider", why);
    let (name, arg) = match text.split_once(':') {
        Some((n, a)) => (n, Some(a)),
        None => (text, None),
    };
    let entry = find(entries, name).ok_or_else(|| {
        invalid(format!(
            "'{text}': unknown; known: {}",
            names(entries, ", ")
        ))
    })?;
    let param = match (arg, &entry.param) {
        (None, _) => None,
        (Some(_), None) => return Err(invalid(format!("'{text}': {name} takes no parameter"))),
        (Some(a), Some(_)) => Some(
            a.parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| invalid(format!("'{text}': parameter must be a number")))?,
        ),
    };
    let spec = CentroiderSpec { entry, param };
    spec.validate()?;
    Ok(spec)
}

/// The methods part of `--centroider`'s long help: one line per entry, its name and its help.
pub(super) fn help(entries: &[CentroiderEntry]) -> String {
    entries
        .iter()
        .map(|e| format!("\n  {:<12} {}", e.name, e.help))
        .collect()
}

/// What a fixed parameter means, per entry that takes one: `K in sigmas, M in ...`.
pub(super) fn units(entries: &[CentroiderEntry]) -> String {
    let units: Vec<String> = entries
        .iter()
        .filter_map(|e| e.param.as_ref())
        .map(|p| format!("{} in {}", p.symbol, p.unit))
        .collect();
    units.join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::centroid::{cog, CentroidFrame, CentroidWorker, Centroider, Setting, SettingSums};
    use crate::centroid::{CentroiderParam, ParamRange};
    use crate::detector::{ModelParams, ModelSpec};
    use crate::montecarlo::{sweep_with, SimConfig};

    /// A centroider added through the registry alone: the centre of gravity (no background
    /// subtracted, negative pixels clipped) scaled by a factor A towards the centre, A swept.
    const ADDED: CentroiderEntry = CentroiderEntry {
        name: "test-shrunk",
        help: "centre of gravity times A",
        param: Some(CentroiderParam {
            name: "a_factor",
            symbol: "A",
            unit: "times the centroid",
            meaning: "factor applied to the centroid",
            range: ParamRange {
                least: 0.0,
                inclusive: true,
                whole: false,
            },
            grid: |_| vec![0.0, 0.5, 1.0],
        }),
        mask_above: false,
        build: |_, factors, ctx| {
            Ok(Box::new(Shrunk {
                factors: factors.to_vec(),
                n: ctx.subap_px,
            }))
        },
    };
    const TABLE: &[CentroiderEntry] = &[ADDED];

    /// The test centroider: its factors and the sub-aperture side (px).
    struct Shrunk {
        factors: Vec<f64>,
        n: usize,
    }

    impl Centroider for Shrunk {
        fn name(&self) -> String {
            ADDED.name.into()
        }
        fn param_name(&self) -> Option<&'static str> {
            ADDED.param.map(|p| p.name)
        }
        fn settings(&self) -> Vec<Setting> {
            let setting = |&a: &f64| Setting {
                param: Some(a),
                b_e: 0.0,
                part: 0,
            };
            self.factors.iter().map(setting).collect()
        }
        fn sums(&self) -> SettingSums {
            SettingSums::new(&[self.factors.len()])
        }
        fn needs_noise_map(&self) -> bool {
            false
        }
        fn worker(&self) -> Box<dyn CentroidWorker + '_> {
            Box::new(ShrunkWorker(self))
        }
    }

    struct ShrunkWorker<'c>(&'c Shrunk);

    impl CentroidWorker for ShrunkWorker<'_> {
        fn accumulate(&mut self, f: &CentroidFrame, acc: &mut SettingSums) {
            let clipped: Vec<f64> = f.image_e.iter().map(|x| x.max(0.0)).collect();
            let estimate = cog(&clipped, self.0.n);
            let sums = acc.part_mut(0);
            for (k, a) in self.0.factors.iter().enumerate() {
                let (x, y) = estimate.map_or((0.0, 0.0), |(x, y)| (a * x, a * y));
                let (ex, ey) = (x - f.truth_px.0, y - f.truth_px.1);
                sums.add_error(k, ex.hypot(ey), (ex, ey));
                sums.empty[k] += u64::from(estimate.is_none());
            }
        }
    }

    #[test]
    fn a_centroider_without_a_variant_parses_names_itself_and_runs_in_the_sweep() {
        assert_eq!(names(TABLE, ","), "test-shrunk");
        assert_eq!(help(TABLE), "\n  test-shrunk  centre of gravity times A");
        assert_eq!(units(TABLE), "A in times the centroid");
        let swept = parse(TABLE, "test-shrunk").unwrap();
        let fixed = parse(TABLE, "test-shrunk:1").unwrap();
        assert_eq!((swept.entry.name, swept.param), ("test-shrunk", None));
        assert_eq!(
            (fixed.label(), fixed.param),
            ("test-shrunk:1".into(), Some(1.0))
        );
        assert_ne!(swept, fixed);
        let err = parse(TABLE, "test-shrunk:-1").unwrap_err().to_string();
        assert_eq!(
            err,
            "invalid `centroider`: test-shrunk:-1: A must be >= 0 (times the centroid)"
        );
        let err = parse(TABLE, "cog").unwrap_err().to_string();
        assert_eq!(
            err,
            "invalid `centroider`: 'cog': unknown; known: test-shrunk"
        );

        // Through the Monte-Carlo sweep beside cog, on the same frames: at A = 1 it is cog at
        // b = 0 (cog's distances are single precision: 1e-6 relative bounds the difference);
        // at A = 0 its estimate is the centre, farther from the truth than the centroid.
        let cfg = SimConfig {
            iters: 2000,
            ..SimConfig::paper(6)
        };
        let centroiders = [swept, CentroiderSpec::default(), fixed];
        let model = ModelSpec::ScmosConstant(Some(1.0));
        let silent = crate::progress::Silent;
        let records = sweep_with(
            &[cfg],
            &[model],
            &centroiders,
            &ModelParams::default(),
            &silent,
        )
        .unwrap();
        let [swept, cog, fixed] = &records[..] else {
            panic!("one record per centroider: {}", records.len())
        };
        let (swept, cog, fixed) = (&swept.result, &cog.result, &fixed.result);
        assert_eq!(
            (swept.centroider.as_str(), swept.param_name),
            ("test-shrunk", Some("a_factor"))
        );
        assert_eq!(fixed.centroider, "test-shrunk:1");
        let params: Vec<Option<f64>> = swept.levels.iter().map(|l| l.param).collect();
        assert_eq!(params, [Some(0.0), Some(0.5), Some(1.0)]);
        let (at_one, cog_at_zero) = (&swept.levels[2], &cog.levels[0]);
        assert_eq!(cog_at_zero.b_e, 0.0);
        assert!(
            (at_one.r_px / cog_at_zero.r_px - 1.0).abs() < 1e-6,
            "{at_one:?} {cog_at_zero:?}"
        );
        assert_eq!(fixed.levels.len(), 1);
        assert_eq!(fixed.levels[0].r_px, at_one.r_px);
        assert!(swept.levels[0].r_px > at_one.r_px + 5.0 * at_one.r_se_px);
    }
}

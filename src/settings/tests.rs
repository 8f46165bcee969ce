//! The registry against itself and against the library's own constants and defaults.

use super::*;
use crate::detector::{ModelParams, MODELS};
use crate::montecarlo::SimConfig;
use std::collections::BTreeSet;
use std::ops::Bound::{Excluded, Included, Unbounded};

#[test]
fn fields_keys_and_flags_are_unique() {
    let (mut fields, mut keys, mut flags) = (BTreeSet::new(), BTreeSet::new(), BTreeSet::new());
    for s in all() {
        assert!(fields.insert(s.field), "field {} twice", s.field);
        assert!(keys.insert(s.key), "keyword {} twice", s.key);
        assert!(flags.insert(s.flag), "flag {} twice", s.flag);
        assert!(s.flag.starts_with("--"), "{}", s.flag);
        assert!(!s.help.is_empty() && !s.help.ends_with('.'), "{}", s.field);
    }
}

#[test]
fn every_default_is_a_value_the_setting_takes() {
    for s in all() {
        if let Some(v) = s.default_value() {
            s.check(v.clone())
                .unwrap_or_else(|e| panic!("{}: default {v:?}: {e}", s.field));
        }
    }
}

#[test]
fn every_field_a_readout_model_reads_is_a_readout_setting() {
    for model in MODELS {
        for field in model.params {
            assert!(
                READOUT.iter().any(|s| s.field == *field),
                "{} reads {field}, which is no readout setting",
                model.name
            );
        }
    }
}

#[test]
fn model_params_default_is_the_registry_default_and_the_papers() {
    let d = ModelParams::default();
    // The paper's EMCCD (SPEC section 3) and the project's documented defaults.
    assert_eq!(
        (d.em_gain, d.stages, d.emccd_read_noise_e),
        (500.0, 520, 50.0)
    );
    assert_eq!((d.sigma_e, d.pattern_seed), (1.0, 2015));
    assert!(!d.cascade_register && d.gaussian_switch_e.is_none());
    assert_eq!(d.pp_rule, crate::detector::pp::PpRule::PoissonPrior);
    assert!(d.map.is_none() && d.rts_table.is_none() && d.dark_frames.is_none());
    assert_eq!(
        DARK_FRAMES_MAX_MIB
            .default_value()
            .map(|v| format!("{v:?}")),
        Some(format!(
            "{:?}",
            Value::Real(crate::detector::dark_frames::DEFAULT_MAX_MIB)
        ))
    );
}

#[test]
fn run_defaults_are_the_papers_configuration() {
    let paper = SimConfig::paper(16);
    let v = Values::default();
    assert_eq!(v.real(&QE), Some(paper.qe));
    assert_eq!(v.whole(&ITERS), Some(paper.iters));
    assert_eq!(
        v.real(&POSITION_HALF_RANGE_PX),
        Some(paper.position_half_range_px)
    );
    assert_eq!(v.real(&MAX_EMPTY_FRAC), Some(paper.max_empty_frac));
    assert_eq!(v.text(&SAMPLING).as_deref(), Some(paper.sampling.label()));
    let Kind::Whole(_, hi) = ITERS.kind else {
        panic!("iters is whole")
    };
    assert_eq!(hi, SimConfig::MAX_ITERS);
}

#[test]
fn the_choices_are_the_librarys_names() {
    use crate::detector::pp::PpRule;
    let Kind::Choice(rules) = PP_RULE.kind else {
        panic!("pp_rule is a choice")
    };
    let labels: Vec<_> = PpRule::ALL.iter().map(|r| r.label()).collect();
    assert_eq!(rules, &labels[..]);
    for r in PpRule::ALL {
        assert_eq!(PpRule::parse(r.label()), Some(r));
    }
    let Kind::Choice(samplings) = SAMPLING.kind else {
        panic!("sampling is a choice")
    };
    for s in crate::spot::Sampling::ALL {
        assert!(samplings.contains(&s.label()));
        assert_eq!(crate::spot::Sampling::parse(s.label()), Some(s));
    }
}

/// Values at and just beyond each end of a setting's range, and words in and out of its
/// choices: (value, taken). Shared with the command line's test (`cli::settings::tests`).
pub(crate) fn probes(kind: Kind) -> Vec<(Value, bool)> {
    let nudge = |a: f64, up: bool| {
        let step = a.abs().max(1.0) * 1e-9;
        if up {
            a + step
        } else {
            a - step
        }
    };
    match kind {
        Kind::Real(lo, hi) => {
            let mut p = Vec::new();
            match lo {
                Included(a) => p.extend([(a, true), (nudge(a, false), false)]),
                Excluded(a) => p.extend([(a, false), (nudge(a, true), true)]),
                Unbounded => p.push((-1e300, true)),
            }
            match hi {
                Included(b) => p.extend([(b, true), (nudge(b, true), false)]),
                Excluded(b) => p.extend([(b, false), (nudge(b, false), true)]),
                Unbounded => p.push((1e300, true)),
            }
            p.extend([(f64::NAN, false), (f64::INFINITY, false)]);
            p.into_iter().map(|(v, ok)| (Value::Real(v), ok)).collect()
        }
        Kind::Whole(lo, hi) => {
            let mut p = vec![(lo, true), (hi, true)];
            if lo > 0 {
                p.push((lo - 1, false));
            }
            if hi < u64::MAX {
                p.push((hi + 1, false));
            }
            p.into_iter().map(|(v, ok)| (Value::Whole(v), ok)).collect()
        }
        Kind::Choice(words) => {
            let mut p: Vec<_> = words
                .iter()
                .map(|w| (Value::Text(w.to_string()), true))
                .collect();
            p.push((Value::Text("no-such-word".into()), false));
            p
        }
        _ => Vec::new(),
    }
}

/// A probe as typed on the command line.
pub(crate) fn typed(value: &Value) -> String {
    match value {
        Value::Real(v) => format!("{v:e}"),
        Value::Whole(v) => v.to_string(),
        Value::Text(t) => t.clone(),
        other => unreachable!("probes are numbers or words: {other:?}"),
    }
}

#[test]
fn parse_and_check_agree_at_the_ends_of_every_range() {
    for s in all() {
        for (value, taken) in probes(s.kind) {
            assert_eq!(
                s.check(value.clone()).is_ok(),
                taken,
                "{}: {value:?}",
                s.field
            );
            let text = typed(&value);
            assert_eq!(s.parse(&text).is_ok(), taken, "{}: {text}", s.field);
        }
    }
}

#[test]
fn messages_state_the_range_and_unit() {
    assert_eq!(QE.expected(), "must be a number in (0, 1]");
    assert_eq!(
        EMCCD_READ_NOISE_E.expected(),
        "must be a number in [0, 10000] e-"
    );
    assert_eq!(
        STAGES.expected(),
        "must be a whole number from 1 to 2000 stages"
    );
    assert_eq!(
        QE.check(Value::Real(1.5)).unwrap_err(),
        "1.5: must be a number in (0, 1]"
    );
    assert_eq!(
        PP_RULE.parse("pixel").unwrap_err(),
        "must be one of poisson-prior, equal-density, pixel-prior"
    );
}

#[test]
fn a_model_lacking_what_it_reads_names_the_setting() {
    let specs = [crate::detector::ModelSpec::ScmosMap];
    let e = ModelParams::check_settings(&Values::default(), &specs).unwrap_err();
    assert_eq!(
        e.to_string(),
        "invalid `map`: the scmos-map model needs a measured noise map (FILE, e-): give `map`"
    );
    let mut v = Values::default();
    v.set(&PDF_MODEL, Value::Text("empirical".into()));
    let e = ModelParams::check_settings(&v, &[]).unwrap_err();
    assert!(e.to_string().starts_with("invalid `pdf_model`"), "{e}");
}

#[test]
fn precision_defaults_are_the_librarys() {
    use crate::effective::Precision;
    let v = Values::default();
    assert_eq!(v.real(&TARGET_SE_E), Some(Precision::DEFAULT_TARGET_SE_E));
    assert_eq!(v.real(&TARGET_REL), Some(Precision::DEFAULT_TARGET_REL));
    assert_eq!(v.whole(&MAX_ITERS), None);
}

#[test]
fn every_amplitude_has_a_physical_upper_bound() {
    // Issue 30: 1e20 e- of read noise (or 1e300 e-/adu) ran, and its centroid sums overflowed
    // into an empty R. Each amplitude's range ends at a bound its help gives a reason for.
    let amplitudes = [
        (&EMCCD_READ_NOISE_E, MAX_NOISE_E),
        (&SIGMA_E, MAX_NOISE_E),
        (&ROW_NOISE_E, MAX_NOISE_E),
        (&COLUMN_NOISE_E, MAX_NOISE_E),
        (&GAIN_E_PER_ADU, MAX_GAIN_E_PER_ADU),
    ];
    for (s, max) in amplitudes {
        let Kind::Real(_, hi) = s.kind else {
            panic!("{} is a number", s.field)
        };
        assert_eq!(hi, Included(max), "{}", s.field);
        assert!(s.help.contains("at most 1e4 ("), "{}: {}", s.field, s.help);
        assert!(
            s.parse("1e20").is_err() && s.parse("1e4").is_ok(),
            "{}",
            s.field
        );
    }
    // Whatever else is read in e- is bounded too.
    for s in all() {
        if let Kind::Real(_, Unbounded) = s.kind {
            assert!(
                !s.unit.starts_with("e-"),
                "{} ({}) is unbounded",
                s.field,
                s.unit
            );
        }
    }
}

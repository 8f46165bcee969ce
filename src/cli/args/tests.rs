//! Tests of the value parsers and the sweep options.

use super::super::fields::to_cli;
use super::*;

#[test]
fn real_parser_states_the_range_and_refuses_non_finite_values() {
    let qe = real(Excluded(0.0), Included(1.0), "");
    assert_eq!(qe("0.7"), Ok(0.7));
    assert_eq!(qe("1"), Ok(1.0));
    for bad in ["0", "80", "-1", "nan", "inf", "x", ""] {
        assert_eq!(qe(bad), Err("must be a number in (0, 1]".into()), "{bad}");
    }
    let noise = real(Included(0.0), Unbounded, "e-");
    assert_eq!(noise("0"), Ok(0.0));
    assert_eq!(noise("-1"), Err("must be a number >= 0 e-".into()));
    let gain = real(Included(1.0), Included(MAX_EM_GAIN), "e-/e-");
    assert_eq!(
        gain("1e9"),
        Err("must be a number in [1, 10000] e-/e-".into())
    );
}

#[test]
fn whole_parser_accepts_exponent_notation_and_states_the_range() {
    let iters = whole::<u64>(2, SimConfig::MAX_ITERS, "frames");
    assert_eq!(iters("10000"), Ok(10_000));
    assert_eq!(iters("1e6"), Ok(1_000_000));
    for bad in ["0", "1", "-1", "2.5", "1e10", "many"] {
        assert_eq!(
            iters(bad),
            Err("must be a whole number from 2 to 1000000000 frames".into()),
            "{bad}"
        );
    }
    let stages = whole::<u32>(1, MAX_STAGES as u64, "stages");
    assert!(stages("4294967296").is_err());
    assert_eq!(
        whole::<u64>(0, u64::MAX, "")("18446744073709551615"),
        Ok(u64::MAX)
    );
}

#[test]
fn each_list_option_names_itself() {
    for (text, option) in [("4;8", "--subap"), ("x", "--signal")] {
        let e = parse_list::<usize>(text, option).unwrap_err().to_string();
        assert!(e.contains(option), "{e}");
    }
    let sweep = |subap: &str, signal: &str| SweepArgs {
        subap: subap.into(),
        spot: vec!["airy:2".into()],
        sampling: Sampling::Integrated,
        signal: signal.into(),
        qe: 1.0,
        iters: 100,
        seed: 1,
        bg_grid: "auto".into(),
        position_range: 0.5,
        max_empty_frac: 0.01,
    };
    // As the command line shows them: the library names fields, the CLI maps them to flags.
    let shown = |s: SweepArgs| to_cli(s.validate().unwrap_err()).to_string();
    let e = shown(sweep("0", "50"));
    assert!(e.contains("--subap") && !e.contains("--signal"), "{e}");
    let e = shown(sweep("8", "-5"));
    assert!(e.contains("--signal") && !e.contains("--subap"), "{e}");
    sweep("2,8", "20,1e9").validate().unwrap();
}

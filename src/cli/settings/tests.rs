//! Every option of every command that shares a flag with the settings registry takes the
//! registry's default and range (the generated ones by construction, the others checked here),
//! and each generated option reads back the value typed.

use crate::settings::{self, Kind, Setting};

/// Texts at and just beyond each end of a setting's range (the registry's own probes, as
/// typed), and a fraction where a whole number is due: (text, taken).
fn probes(kind: Kind) -> Vec<(String, bool)> {
    use crate::settings::tests::{probes, typed};
    let mut p: Vec<_> = probes(kind).iter().map(|(v, ok)| (typed(v), *ok)).collect();
    if let Kind::Whole(..) = kind {
        p.push(("1.5".into(), false));
    }
    p
}

/// Every (command, option) whose flag is a registry setting's.
fn registry_options() -> Vec<(String, clap::Arg, &'static Setting)> {
    let cmd = crate::cli::command();
    let mut found = Vec::new();
    for sub in cmd.get_subcommands() {
        for arg in sub.get_arguments() {
            let Some(long) = arg.get_long() else { continue };
            let flag = format!("--{long}");
            if let Some(s) = settings::all().find(|s| s.flag == flag) {
                found.push((sub.get_name().to_string(), arg.clone(), s));
            }
        }
    }
    found
}

#[test]
fn every_option_with_a_registry_flag_takes_its_default_and_range() {
    let options = registry_options();
    // The Monte-Carlo commands carry every readout, run and centroider setting; `effective`
    // its precision too.
    for name in ["simulate", "effective"] {
        let groups = settings::GROUPS.iter();
        let carried = groups.filter(|(g, _)| match *g {
            "precision" => name == "effective",
            "report" => false,
            _ => true,
        });
        for s in carried.flat_map(|(_, group)| group.iter()) {
            assert!(
                options
                    .iter()
                    .any(|(c, _, o)| c == name && o.flag == s.flag),
                "{name} lacks {}",
                s.flag
            );
        }
    }
    let (mut checked, mut wrong) = (0, Vec::new());
    for (name, arg, s) in &options {
        let defaults: Vec<String> = arg
            .get_default_values()
            .iter()
            .map(|d| d.to_string_lossy().into_owned())
            .collect();
        // A report runs every registered centroider: a list that grows with the registry.
        let registry: Vec<String> = match (name.as_str(), s.field) {
            ("report", "centroider") => vec![crate::centroid::centroider_names().to_string()],
            _ => settings::default_in(name, s)
                .iter()
                .map(|d| d.to_string())
                .collect(),
        };
        if defaults != registry {
            wrong.push(format!(
                "{name} {}: default {defaults:?}, registry {registry:?}",
                s.flag
            ));
        }
        for (text, taken) in probes(s.kind) {
            // The option's own value parser alone (its relations to other options stripped).
            let bare = clap::Arg::new("v")
                .long("v")
                .value_parser(arg.get_value_parser().clone());
            let one = clap::Command::new("t").arg(bare);
            let typed = ["t".to_string(), format!("--v={text}")];
            if one.try_get_matches_from(typed).is_ok() != taken {
                wrong.push(format!(
                    "{name} {}={text}: taken {}, registry {taken}",
                    s.flag, !taken
                ));
            }
        }
        checked += 1;
    }
    assert!(
        wrong.is_empty(),
        "differ from the registry:\n{}",
        wrong.join("\n")
    );
    assert!(checked > 60, "only {checked} options checked");
}

#[test]
fn the_generated_options_read_back_what_was_typed() {
    use clap::Parser;
    #[derive(clap::Parser, Debug)]
    struct Cli {
        #[command(flatten)]
        d: crate::cli::args::DetectorArgs,
        #[command(flatten)]
        s: crate::cli::args::SweepArgs,
    }
    let cli = Cli::try_parse_from([
        "x",
        "--em-gain",
        "1000",
        "--stages",
        "604",
        "--pp-rule",
        "pixel-prior",
        "--dark-frames",
        "a.fits",
        "b.fits",
        "--spot",
        "gauss:1,2",
        "--spot",
        "airy:3",
        "--iters",
        "1e3",
    ])
    .unwrap();
    let (d, s) = (&cli.d.values, &cli.s.values);
    assert_eq!(d.real(&settings::EM_GAIN), Some(1000.0));
    assert_eq!(d.whole(&settings::STAGES), Some(604));
    assert_eq!(d.text(&settings::PP_RULE).as_deref(), Some("pixel-prior"));
    assert_eq!(d.paths(&settings::DARK_FRAMES).len(), 2);
    assert!(!d.is_given(&settings::SIGMA_E));
    assert_eq!(d.real(&settings::SIGMA_E), Some(1.0));
    assert_eq!(s.texts(&settings::SPOT), ["gauss:1,2", "airy:3"]);
    assert_eq!(s.whole(&settings::ITERS), Some(1000));
    // A typo in a word is refused with clap's suggestion.
    let e = Cli::try_parse_from(["x", "--pp-rule", "pixel-priors"]).unwrap_err();
    assert!(e.to_string().contains("pixel-prior"), "{e}");
}

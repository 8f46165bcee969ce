//! Tests of the command line as a whole: consistency, exit codes, and the help pages.

use super::*;

#[test]
fn model_options_list_every_registered_model() {
    for name in ["simulate", "effective"] {
        let mut cmd = command();
        let sub = cmd.find_subcommand_mut(name).expect("subcommand");
        let help = sub.render_long_help().to_string();
        for entry in crate::detector::MODELS {
            assert!(
                help.contains(entry.name),
                "{name} --help lacks {}",
                entry.name
            );
        }
    }
}

#[test]
fn command_is_consistent_and_every_help_lists_the_exit_codes() {
    let cmd = command();
    cmd.clone().debug_assert();
    assert!(cmd.get_after_help().is_some());
    for sub in cmd.get_subcommands() {
        let help = sub
            .get_after_help()
            .map(|h| h.to_string())
            .unwrap_or_default();
        assert!(
            help.contains("130"),
            "{} help lacks the exit codes",
            sub.get_name()
        );
    }
    // A command's own long help text keeps them (it replaces the short help's end).
    for (name, help) in long_helps() {
        assert!(
            help.contains("130  interrupted"),
            "{name} --help lacks the exit codes"
        );
    }
}

/// Every subcommand's long help as printed by `detnoise SUB --help`, by subcommand name
/// (clap's own `help` subcommand left out).
fn long_helps() -> Vec<(String, String)> {
    let mut cmd = command();
    cmd.build();
    let names: Vec<String> = cmd
        .get_subcommands()
        .map(|s| s.get_name().to_string())
        .filter(|name| name != "help")
        .collect();
    names
        .into_iter()
        .map(|name| {
            let sub = cmd.find_subcommand_mut(&name).expect("subcommand");
            let help = sub.render_long_help().to_string();
            (name, help)
        })
        .collect()
}

/// The help blocks of the options (and positional arguments) of a rendered long help: each
/// from its `--name <VALUE>` line to the next option or section heading, without the model
/// registry a `--model` help lists (its entries state their own argument's defaults).
fn option_blocks(help: &str) -> Vec<String> {
    let mut blocks: Vec<String> = Vec::new();
    let mut open = false;
    for line in help.lines() {
        let indent = line.len() - line.trim_start().len();
        let head = line.trim_start();
        if (1..=6).contains(&indent) && (head.starts_with('-') || head.starts_with('<')) {
            blocks.push(String::new());
            open = true;
        } else if indent == 0 && !line.is_empty() {
            open = false;
        }
        if open {
            let block = blocks.last_mut().expect("open block");
            block.push_str(line.trim());
            block.push('\n');
        }
    }
    blocks
        .into_iter()
        .map(
            |b| match (b.find("Models (NAME[:ARG]):"), b.find("[default:")) {
                (Some(i), Some(j)) if i < j => format!("{}{}", &b[..i], &b[j..]),
                _ => b,
            },
        )
        .collect()
}

#[test]
fn no_option_states_a_default_beside_the_one_clap_shows() {
    // The class of bug: "Default: 5 [default: 5]" (darks, ptc) and a value's description
    // saying "(the default)" under another real default (`paper --sampling`).
    let (mut seen, mut twice) = (0, Vec::new());
    for (name, help) in long_helps() {
        for block in option_blocks(&help) {
            let Some(at) = block.find("[default:") else {
                continue;
            };
            seen += 1;
            let end = at + block[at..].find(']').expect("closing bracket");
            let words = format!("{}{}", &block[..at], &block[end + 1..]).to_lowercase();
            if words.contains("default") {
                twice.push(format!("detnoise {name}:\n{block}"));
            }
        }
    }
    assert!(seen > 40, "only {seen} options with a default found");
    assert!(
        twice.is_empty(),
        "options stating a default in words beside clap's:\n{}",
        twice.join("\n")
    );
}

/// Units a value-taking option's help may state (whole words, after trimming punctuation).
const UNIT_WORDS: [&str; 16] = [
    "s",
    "Hz",
    "C",
    "px",
    "pixels",
    "e-",
    "e-/e-",
    "1/e-",
    "adu",
    "photons",
    "photo-electrons",
    "frames",
    "stages",
    "threads",
    "samples",
    "sigmas",
];
/// Units of more than one word.
const UNIT_PHRASES: [&str; 2] = ["standard deviations", "standard errors"];
/// Words that say a value has no unit: a dimensionless number, a name, or a path.
const NO_UNIT_WORDS: [&str; 8] = [
    "unitless",
    "name",
    "names",
    "path",
    "file",
    "files",
    "directory",
    "glob",
];

/// How the help of a value-taking argument states what its value is, or None when it does
/// not: its possible values (a name), a path type, a unit or a no-unit word.
fn value_kind(arg: &clap::Arg) -> Option<String> {
    if !arg.get_possible_values().is_empty() {
        return Some("a name from its possible values".into());
    }
    use clap::ValueHint::{AnyPath, DirPath, FilePath};
    if matches!(arg.get_value_hint(), AnyPath | DirPath | FilePath) {
        return Some("a path".into());
    }
    let help = arg
        .get_long_help()
        .or(arg.get_help())
        .map(|h| h.to_string())
        .unwrap_or_default();
    let trim: &[char] = &['(', ')', '[', ']', ',', ';', '.', ':', '`', '\'', '"'];
    let words = help.split_whitespace().map(|w| w.trim_matches(trim));
    let found = words
        .filter(|w| UNIT_WORDS.contains(w) || NO_UNIT_WORDS.contains(&&*w.to_lowercase()))
        .map(str::to_string)
        .next();
    found.or_else(|| {
        UNIT_PHRASES
            .iter()
            .find(|p| help.contains(*p))
            .map(|p| p.to_string())
    })
}

#[test]
fn every_value_option_states_its_unit_or_that_it_has_none() {
    // The rule: a value-taking option (or positional argument) is an enum (its possible values
    // are names), has a path type, or its help contains a unit from UNIT_WORDS/UNIT_PHRASES or
    // one of NO_UNIT_WORDS ("unitless", "name", "path", ...).
    let mut cmd = command();
    cmd.build();
    let (mut seen, mut silent) = (0, Vec::new());
    for sub in cmd.get_subcommands() {
        for arg in sub.get_arguments() {
            if arg.is_hide_set() || !arg.get_action().takes_values() {
                continue;
            }
            seen += 1;
            if value_kind(arg).is_none() {
                let help = arg.get_help().map(|h| h.to_string()).unwrap_or_default();
                silent.push(format!("{} --{}: {help}", sub.get_name(), arg.get_id()));
            }
        }
    }
    assert!(seen > 80, "only {seen} value-taking options found");
    assert!(
        silent.is_empty(),
        "options whose help states no unit (nor unitless/name/path):\n{}",
        silent.join("\n")
    );
}

#[test]
fn paper_help_states_the_sampling_default_paper_uses() {
    let matches = command()
        .try_get_matches_from(["detnoise", "paper", "--out", "figs"])
        .unwrap();
    let Command::Paper(args) = Cli::from_arg_matches(&matches).unwrap().command else {
        panic!("not the paper command");
    };
    let (_, help) = long_helps()
        .into_iter()
        .find(|(name, _)| name == "paper")
        .expect("paper");
    let block = option_blocks(&help)
        .into_iter()
        .find(|b| b.starts_with("--sampling"))
        .expect("--sampling in paper --help");
    let stated = format!("[default: {}]", args.sampling.label());
    assert!(block.contains(&stated), "{block} lacks {stated}");
    // And no word of the block calls another value the default.
    assert_eq!(
        block.to_lowercase().matches("default").count(),
        1,
        "{block}"
    );
}

#[test]
fn report_help_says_what_each_simulation_option_does_in_a_report() {
    let (_, help) = long_helps()
        .into_iter()
        .find(|(name, _)| name == "report")
        .expect("report");
    let explained = &help[help
        .find("How a report uses the simulation options:")
        .expect("the explanation in report --help")..];
    assert!(explained.contains("Exit status:"), "exit codes after it");
    // Every option of the Monte-Carlo (simulate's, but for its own outputs and models) and the
    // report's own second QE are named, used or not.
    let mut cmd = command();
    cmd.build();
    let own = ["model", "format", "out", "plot", "force", "threads", "help"];
    let sim = cmd.find_subcommand("simulate").expect("simulate");
    let longs = sim
        .get_arguments()
        .filter(|a| !a.is_hide_set() && !own.contains(&a.get_id().as_str()))
        .filter_map(|a| a.get_long())
        .chain(["qe-emccd"]);
    let missing: Vec<String> = longs
        .map(|l| format!("--{l}"))
        .filter(|flag| !explained.contains(flag.as_str()))
        .collect();
    assert!(
        missing.is_empty(),
        "report --help does not explain {missing:?}"
    );
    let cap = crate::report::QUICK_MAX_ITERS;
    let stated = format!("{},{:03}", cap / 1000, cap % 1000);
    let flat = explained.split_whitespace().collect::<Vec<_>>().join(" ");
    assert!(flat.contains(&format!("--quick caps --iters at {stated}")));
}

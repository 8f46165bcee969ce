//! The `detnoise` command line: a thin layer over the library.

pub mod args;
pub mod campaign;
pub mod darks;
pub mod datasheet;
pub mod effective;
pub mod emgain;
pub mod fields;
pub mod fit_pdf;
pub mod paper;
pub mod progress;
pub mod ptc;
pub mod report;
pub mod settings;
pub mod simulate;
pub mod subaps;
pub mod synth;
pub mod table;

use crate::error::{EXIT_CODES_HELP, EXIT_OK, EXIT_USAGE};
use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};

/// Most worker threads accepted by `--threads`.
pub const MAX_THREADS: u64 = 1024;

/// detnoise: read-noise models of sCMOS and EMCCD cameras for Shack-Hartmann wavefront sensors.
///
/// Units: positions and errors in pixels (px), signals in photons per sub-aperture, noise and
/// background levels in electrons (e-) referred to the detector input.
#[derive(Parser, Debug)]
#[command(name = "detnoise", version, about, long_about = None, max_term_width = 100)]
pub struct Cli {
    /// Worker threads, 1 to 1024 (default: all cores). Results do not depend on it.
    #[arg(long, global = true, value_parser = args::whole::<usize>(1, MAX_THREADS, "threads"))]
    pub threads: Option<usize>,
    /// The subcommand to run (simulate, effective, report, ...).
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands.
#[derive(Subcommand, Debug)]
pub enum Command {
    /// Sub-aperture Monte-Carlo: mean radial centroid error R for readout models over a sweep.
    Simulate(simulate::SimulateArgs),
    /// Effective Gaussian read noise of a detector over sub-aperture sizes, spots and signals.
    Effective(effective::EffectiveArgs),
    /// Regenerate every figure of Basden (2015) with data, captions and an index page.
    Paper(paper::PaperArgs),
    /// The end-to-end detector report: darks (and flats) in, effective read noise out.
    Report(report::ReportArgs),
    /// Per-pixel offset and read-noise maps from a dark stack.
    Darks(darks::DarksArgs),
    /// Fit models of the per-pixel read-noise pdf to a noise map (e-).
    FitPdf(fit_pdf::FitPdfArgs),
    /// Fit bias, read noise, EM gain and light level to EMCCD frames.
    Emgain(emgain::EmgainArgs),
    /// Photon transfer: conversion gain (global and per pixel) from darks and flats.
    Ptc(ptc::PtcArgs),
    /// Write a synthetic sCMOS or EMCCD stack with a manifest of its truth.
    Synth(synth::SynthArgs),
    /// Effective read noise of every sub-aperture of a measured noise map (resumable, shardable).
    Subaps(subaps::SubapsArgs),
    /// Merge the part files of `subaps --shard K/N` runs into the per-sub-aperture map.
    SubapsMerge(subaps::SubapsMergeArgs),
    /// A characterisation campaign: dark and flat stacks at several exposure times, EM gains
    /// and temperatures, each streamed once into its noise figures.
    Campaign(campaign::CampaignArgs),
    /// The EMVA 1288 (release 4.0) datasheet of a camera from its photon-transfer pairs and
    /// spatial stacks, every number with its standard error.
    Datasheet(datasheet::DatasheetArgs),
}

/// The command line: the derived parser, with the exit codes at the end of every help page,
/// and negative numbers accepted as option values so that they reach the range checks.
pub fn command() -> clap::Command {
    fn finish(cmd: clap::Command) -> clap::Command {
        // A command's own long help text (`report`) comes before the exit codes.
        let cmd = match cmd.get_after_long_help().map(|h| h.to_string()) {
            Some(own) => cmd.after_long_help(format!("{own}\n\n{EXIT_CODES_HELP}")),
            None => cmd,
        };
        cmd.after_help(EXIT_CODES_HELP).mut_args(|a| {
            let takes_values = a.get_action().takes_values();
            a.allow_negative_numbers(takes_values)
        })
    }
    finish(Cli::command()).mut_subcommands(|sub| with_model_list(finish(sub)))
}

/// A command with a `--model` option gets the registry's list of models in its long help, with
/// the parameters each model uses shown as flags.
fn with_model_list(cmd: clap::Command) -> clap::Command {
    if !cmd.get_arguments().any(|a| a.get_id() == "model") {
        return cmd;
    }
    cmd.mut_arg("model", |a| {
        let short = a.get_help().map(|h| h.to_string()).unwrap_or_default();
        let models = fields::flags_in(&crate::detector::models_help());
        a.long_help(format!("{short}\n\nModels (NAME[:ARG]):\n{models}"))
    })
}

/// Parse the command line, run it, and return the process exit code.
pub fn main() -> i32 {
    main_from(std::env::args_os())
}

/// Parse `args` (the program name first, as in `std::env::args_os`), run the command, and
/// return the process exit code: the entry of the binary and of the Python package's
/// `detnoise` command. A parse error or `--help` prints and ends the process, as clap does.
pub fn main_from<I, T>(args: I) -> i32
where
    I: IntoIterator<Item = T>,
    T: Into<std::ffi::OsString> + Clone,
{
    let cli = match Cli::from_arg_matches(&command().get_matches_from(args)) {
        Ok(cli) => cli,
        Err(e) => e.exit(),
    };
    if let Err(e) = crate::output::temps::install_interrupt_handler() {
        eprintln!("detnoise: warning: {e}");
    }
    if let Some(t) = cli.threads {
        if let Err(e) = rayon::ThreadPoolBuilder::new()
            .num_threads(t)
            .build_global()
        {
            eprintln!("detnoise: error: invalid option --threads: cannot start {t} threads: {e}");
            return EXIT_USAGE;
        }
    }
    let result = match &cli.command {
        Command::Simulate(a) => simulate::run_cli(a),
        Command::Effective(a) => effective::run_cli(a),
        Command::Paper(a) => paper::run_cli(a),
        Command::Report(a) => report::run_cli(a),
        Command::Darks(a) => darks::run(a),
        Command::FitPdf(a) => fit_pdf::run(a),
        Command::Emgain(a) => emgain::run(a),
        Command::Ptc(a) => ptc::run(a),
        Command::Synth(a) => synth::run(a),
        Command::Subaps(a) => subaps::run_cli(a),
        Command::SubapsMerge(a) => subaps::run_merge_cli(a),
        Command::Campaign(a) => campaign::run(a),
        Command::Datasheet(a) => datasheet::run(a),
    };
    // An interruption being handled ends the process with its own code: wait for it.
    crate::output::temps::settle();
    match result {
        Ok(()) => EXIT_OK,
        Err(e) => {
            let e = fields::to_cli(crate::output::temps::hide_temporaries(e));
            eprintln!("detnoise: error: {e}");
            e.exit_code()
        }
    }
}

#[cfg(test)]
mod tests;

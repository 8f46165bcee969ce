//! The `detnoise` command line: a thin layer over the library.

pub mod args;
mod charts;
pub mod darks;
pub mod effective;
pub mod emgain;
pub mod fit_pdf;
pub mod paper;
pub mod progress;
pub mod ptc;
pub mod report;
mod report_page;
pub mod simulate;
pub mod synth;

use clap::{Parser, Subcommand};

/// detnoise: read-noise models of sCMOS and EMCCD cameras for Shack-Hartmann wavefront sensors.
///
/// Units: positions and errors in pixels (px), signals in photons per sub-aperture, noise and
/// background levels in electrons (e-) referred to the detector input.
#[derive(Parser, Debug)]
#[command(name = "detnoise", version, about, long_about = None, max_term_width = 100)]
pub struct Cli {
    /// Worker threads (default: all cores). Results do not depend on it.
    #[arg(long, global = true)]
    pub threads: Option<usize>,
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
}

/// Parse the command line, run it, and return the process exit code.
pub fn main() -> i32 {
    let cli = Cli::parse();
    if let Err(e) = crate::output::temps::install_interrupt_handler() {
        eprintln!("detnoise: warning: {e}");
    }
    if let Some(t) = cli.threads {
        if let Err(e) = rayon::ThreadPoolBuilder::new()
            .num_threads(t.max(1))
            .build_global()
        {
            eprintln!("detnoise: cannot set --threads: {e}");
            return 2;
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
    };
    // An interruption being handled ends the process with its own code: wait for it.
    crate::output::temps::settle();
    match result {
        Ok(()) => 0,
        Err(e) => {
            let e = crate::output::temps::hide_temporaries(e);
            eprintln!("detnoise: error: {e}");
            e.exit_code()
        }
    }
}

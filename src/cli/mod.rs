//! Command-line interface: one module per subcommand.

pub mod darks;
pub mod emgain;
pub mod fit_pdf;
pub mod ptc;
pub mod synth;

use clap::{Parser, Subcommand};

/// detnoise: read-noise models of sCMOS and EMCCD cameras for Shack-Hartmann wavefront sensors.
#[derive(Parser, Debug)]
#[command(version, about)]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
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

/// Parse the command line, run the subcommand and exit with the error's code on failure.
pub fn main() {
    let cli = Cli::parse();
    let r = match &cli.command {
        Command::Darks(a) => darks::run(a),
        Command::FitPdf(a) => fit_pdf::run(a),
        Command::Emgain(a) => emgain::run(a),
        Command::Ptc(a) => ptc::run(a),
        Command::Synth(a) => synth::run(a),
    };
    if let Err(e) = r {
        eprintln!("error: {e}");
        std::process::exit(e.exit_code());
    }
}

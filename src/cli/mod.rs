//! Command-line interface: one module per subcommand.

pub mod darks;
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
        Command::Ptc(a) => ptc::run(a),
        Command::Synth(a) => synth::run(a),
    };
    if let Err(e) = r {
        eprintln!("error: {e}");
        std::process::exit(e.exit_code());
    }
}

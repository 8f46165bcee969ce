//! `detnoise ptc`: photon transfer (conversion gain) from dark and flat stacks.

/// Options of `detnoise ptc`.
#[derive(clap::Args, Debug)]
pub struct PtcArgs {}

/// Run `detnoise ptc`.
pub fn run(_args: &PtcArgs) -> crate::Result<()> {
    Err(crate::Error::usage("ptc", "not implemented yet"))
}

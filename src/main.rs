//! The `detnoise` binary: see `detnoise --help`.

fn main() {
    std::process::exit(detnoise::cli::main());
}

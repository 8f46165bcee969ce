//! The `detnoise` command of the Python package: the library's command line, run in the
//! Python process (`detnoise._cli:main` calls [`run_cli`] with `sys.argv`).

use pyo3::prelude::*;

/// Run the `detnoise` command line with `args` (the program name first, as `sys.argv`) and
/// return its exit status. It prints as the binary does and handles Ctrl-C itself; `--help`
/// and a bad option end the process with clap's status.
#[pyfunction]
pub fn run_cli(py: Python<'_>, args: Vec<String>) -> i32 {
    py.detach(|| detnoise::cli::main_from(args))
}

//! The Python extension module `detnoise._detnoise`: numpy in and out over the detnoise
//! library (see the pure-Python package `python/detnoise/` for the public names and the
//! `.pyi` stubs). One job per file: `readout` (the camera as a noise generator), `calib`
//! (frames and dark maps), `campaign` (a campaign measured and decomposed), `datasheet` (the
//! EMVA 1288 datasheet), `fit` (the pdf and EM-gain fits), `sim` (simulate, effective),
//! `report`, `cli` (the `detnoise` command); `params` (readout-model keywords), `observer`
//! (progress, warnings, Ctrl-C), `errors` and `convert` are shared.

mod calib;
mod campaign;
mod cli;
mod convert;
mod datasheet;
mod errors;
mod fit;
mod observer;
mod params;
mod readout;
mod report;
mod sim;

use pyo3::prelude::*;

/// The extension module.
#[pymodule]
fn _detnoise(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    let names: Vec<&str> = detnoise::detector::MODEL_NAMES.split(", ").collect();
    m.add("MODEL_NAMES", names)?;
    m.add(
        "MODELS_HELP",
        errors::keywords_in(&detnoise::detector::models_help()),
    )?;
    m.add("MODEL_PARAMS", params::keywords())?;
    m.add("SETTINGS", params::settings_table(py)?)?;
    m.add(
        "DetnoiseWarning",
        py.get_type::<observer::DetnoiseWarning>(),
    )?;
    m.add_class::<readout::PyReadout>()?;
    m.add_class::<calib::StackIterator>()?;
    m.add_class::<calib::PyDarkMaps>()?;
    m.add_class::<fit::PdfFit>()?;
    m.add_class::<fit::PyEmGainFit>()?;
    m.add_class::<report::Report>()?;
    m.add_class::<campaign::PyCampaign>()?;
    m.add_class::<datasheet::PyDatasheet>()?;
    m.add_function(wrap_pyfunction!(calib::read_stack, m)?)?;
    m.add_function(wrap_pyfunction!(calib::dark_maps_py, m)?)?;
    m.add_function(wrap_pyfunction!(campaign::campaign_py, m)?)?;
    m.add_function(wrap_pyfunction!(datasheet::datasheet_py, m)?)?;
    m.add_function(wrap_pyfunction!(fit::fit_pdf_py, m)?)?;
    m.add_function(wrap_pyfunction!(fit::fit_emgain_py, m)?)?;
    m.add_function(wrap_pyfunction!(sim::simulate, m)?)?;
    m.add_function(wrap_pyfunction!(sim::effective, m)?)?;
    m.add_function(wrap_pyfunction!(report::report, m)?)?;
    m.add_function(wrap_pyfunction!(cli::run_cli, m)?)?;
    Ok(())
}

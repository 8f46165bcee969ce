//! `detnoise datasheet` as a library call: check the output folder and the dataset before any
//! frame is read, compute, and write the sheet's files into a folder that appears only whole.

use std::path::{Path, PathBuf};

use super::beyond::{beyond, BeyondOptions};
use super::dataset::EmvaDataset;
use super::datasheet::{compute, Datasheet};
use super::sheet::Sheet;
use super::spatial::SpatialOptions;
use crate::error::Result;
use crate::output::{DirPlan, OutputDir};

/// Where a datasheet's dataset is described.
#[derive(Clone, Debug)]
pub enum DatasheetInput {
    /// An EMVA 1288 descriptor file (as the reference implementation reads it).
    Descriptor(PathBuf),
    /// A campaign manifest (CSV).
    Manifest(PathBuf),
}

/// One `datasheet` job.
#[derive(Clone, Debug)]
pub struct DatasheetRun {
    /// The dataset.
    pub input: DatasheetInput,
    /// Output folder.
    pub out: PathBuf,
    /// Write beside foreign files in an existing `out` (never replacing them).
    pub force: bool,
    /// Spatial settings (defect threshold, histogram bins).
    pub spatial: SpatialOptions,
    /// Where the effective read noise of the dark noise map is computed.
    pub beyond: BeyondOptions,
}

/// What `datasheet` may write (glob patterns), for the output folder's checks.
pub const DATASHEET_NAMES: [&str; 12] = [
    "datasheet.json",
    "datasheet.xml",
    "datasheet.csv",
    "datasheet.html",
    "*.png",
    "*.svg",
    // The per-pixel maps (crate::emva::beyond).
    "gain_dn_per_e.fits",
    "gain_se_dn_per_e.fits",
    "dark_current_e_per_s.fits",
    "dark_current_se_e_per_s.fits",
    "rms_e.fits",
    "rms_se_e.fits",
];

/// Run the job: the datasheet, its sheet and the folder written.
pub fn run(job: &DatasheetRun) -> Result<(Datasheet, Sheet, PathBuf)> {
    job.beyond.validate()?;
    let dataset = match &job.input {
        DatasheetInput::Descriptor(p) => EmvaDataset::from_descriptor(p)?,
        DatasheetInput::Manifest(p) => EmvaDataset::from_manifest(p)?,
    };
    let mut inputs = vec![dataset.source.clone()];
    inputs.extend(all_files(&dataset));
    let dir = OutputDir::prepare(
        &job.out,
        DirPlan {
            command: "datasheet",
            force: job.force,
            inputs: &inputs,
            names: &DATASHEET_NAMES,
        },
    )?;
    let (datasheet, sheet) = write_all(&dataset, &job.spatial, &job.beyond, &dir.path(""))?;
    let out = dir.commit()?;
    Ok((datasheet, sheet, out))
}

/// Check the frames of `dataset`, compute its datasheet and write every file of it (sheet,
/// figures, per-pixel maps, XML) into the folder `dir` (being built by its caller).
pub fn write_all(
    dataset: &EmvaDataset,
    spatial: &SpatialOptions,
    beyond_options: &BeyondOptions,
    dir: &Path,
) -> Result<(Datasheet, Sheet)> {
    dataset.check_frames()?;
    if let Some(first) = dataset.points.first() {
        let shape = super::pairs::frame_shape(&first.bright[0])?;
        beyond_options.check_shape(shape, &first.bright[0])?;
    }
    let datasheet = compute(dataset, spatial)?;
    let mut sheet = datasheet.sheet(dataset);
    let beyond = beyond(dataset, &datasheet, beyond_options)?;
    beyond.add_to(&mut sheet);
    let (maps_written, sheet_written) = rayon::join(|| beyond.write(dir), || sheet.write(dir));
    maps_written?;
    sheet_written?;
    // The reference implementation's XML result file, beside the sheet.
    super::xml::write_xml(&datasheet, dir)?;
    Ok((datasheet, sheet))
}

/// Every frame file the dataset names.
fn all_files(dataset: &EmvaDataset) -> Vec<PathBuf> {
    let pairs = dataset
        .points
        .iter()
        .flat_map(|p| p.bright.iter().chain(&p.dark).cloned());
    let spatial = [&dataset.spatial_bright, &dataset.spatial_dark]
        .into_iter()
        .flatten()
        .flat_map(|s| s.files.clone());
    pairs.chain(spatial).collect()
}

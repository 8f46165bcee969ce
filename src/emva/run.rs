//! `detnoise datasheet` as a library call: check the output folder and the dataset before any
//! frame is read, compute, and write the sheet's files into a folder that appears only whole.

use std::path::PathBuf;

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
pub const DATASHEET_NAMES: [&str; 11] = [
    "datasheet.json",
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
    dataset.check_frames()?;
    if let Some(first) = dataset.points.first() {
        let shape = super::pairs::frame_shape(&first.bright[0])?;
        job.beyond.check_shape(shape, &first.bright[0])?;
    }
    let datasheet = compute(&dataset, &job.spatial)?;
    let mut sheet = datasheet.sheet(&dataset);
    let beyond = beyond(&dataset, &datasheet, &job.beyond)?;
    beyond.add_to(&mut sheet);
    beyond.write(&dir.path(""))?;
    sheet.write(&dir.path(""))?;
    let out = dir.commit()?;
    Ok((datasheet, sheet, out))
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

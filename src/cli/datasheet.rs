//! `detnoise datasheet`: the EMVA 1288 (release 4.0) datasheet of a camera from its dataset.

use std::ops::Bound::{Excluded, Included};
use std::path::PathBuf;

use super::args::real;
use crate::emva::beyond::BeyondOptions;
use crate::emva::run::{run as run_datasheet, DatasheetInput, DatasheetRun};
use crate::emva::spatial::SpatialOptions;
use crate::error::Result;
use crate::report::OperatingPoint;

/// Options of `detnoise datasheet`.
#[derive(clap::Args, Debug)]
#[command(group(clap::ArgGroup::new("input").required(true).args(["emva_descriptor", "manifest"])))]
pub struct DatasheetArgs {
    /// EMVA 1288 descriptor file, as the reference implementation writes and reads it
    /// (`n BITS W H`, `b TEXP_NS PHOTONS` bright and `d TEXP_NS` dark points, `i PATH`
    /// images; exposure in ns, photons per pixel; `\` in paths read as a folder separator).
    #[arg(long, value_name = "FILE")]
    pub emva_descriptor: Option<PathBuf>,
    /// Campaign manifest (CSV, `file,kind,exposure_s,em_gain,temperature_c,light_level`;
    /// light_level in photons per pixel), one row per image: consecutive rows of one
    /// condition form a set, two images a photon-transfer pair, more a spatial stack.
    #[arg(long, value_name = "FILE")]
    pub manifest: Option<PathBuf>,
    /// Output directory: datasheet.json, datasheet.csv, datasheet.html and its figures (PNG
    /// and SVG), written only when the run succeeds; an existing directory is replaced only
    /// if detnoise wrote it.
    #[arg(long)]
    pub out: PathBuf,
    /// Write into an existing --out that holds other files (they are never replaced or deleted).
    #[arg(long)]
    pub force: bool,
    /// Defect pixels: farther than this many robust standard deviations from the median
    /// (dark image) or from their 5x5 neighbourhood's median (PRNU image), > 0 and at most
    /// 1000.
    #[arg(long, default_value_t = 6.0, value_parser = real(Excluded(0.0), Included(1000.0), "robust standard deviations"))]
    pub defect_sigma: f64,
    /// The Shack-Hartmann sub-aperture of the effective read noise of the dark noise map
    /// (section "Beyond the standard"), as the report's: sub-aperture size (px per side), spot
    /// (airy:D or gauss:SX,SY, px) and signal (photons per sub-aperture), e.g. 12,airy:4,100;
    /// cog, QE 1, the quick precision (at most 24,000 frames).
    #[arg(long, value_name = "SUBAP,SPOT,SIGNAL", default_value = OperatingPoint::DEFAULT_TEXT, allow_hyphen_values = true)]
    pub operating_point: String,
}

/// Widest label of the terminal table (characters); longer ones take a line of their own.
const LABEL_COLUMNS: usize = 60;

/// Run `detnoise datasheet`.
pub fn run(args: &DatasheetArgs) -> Result<()> {
    let input = match (&args.emva_descriptor, &args.manifest) {
        (Some(d), _) => DatasheetInput::Descriptor(d.clone()),
        (None, Some(m)) => DatasheetInput::Manifest(m.clone()),
        (None, None) => unreachable!("clap requires one input"),
    };
    let job = DatasheetRun {
        input,
        out: args.out.clone(),
        force: args.force,
        spatial: SpatialOptions {
            defect_factor: args.defect_sigma,
            ..SpatialOptions::default()
        },
        beyond: BeyondOptions {
            point: OperatingPoint::parse(&args.operating_point)?,
            ..BeyondOptions::default()
        },
    };
    let (_, sheet, out) = run_datasheet(&job)?;
    // One write, its failure ignored: a reader that closes the pipe early (`| head`) is not
    // an error of the run, whose files are already in place.
    let label = |row: &crate::emva::sheet::Row| {
        format!("{} ({})", row.label, row.unit)
            .trim_end_matches(" ()")
            .to_string()
    };
    // The label column as wide as the longest label up to LABEL_COLUMNS; a longer label
    // gets a line of its own and its value the next, so that the values line up.
    let rows = sheet.sections.iter().flat_map(|s| &s.rows);
    let fits = |l: &String| l.chars().count() <= LABEL_COLUMNS;
    let width = rows
        .map(label)
        .filter(fits)
        .map(|l| l.chars().count())
        .max();
    let width = width.unwrap_or(0);
    let mut text = String::new();
    for section in &sheet.sections {
        text.push_str(&section.title);
        text.push('\n');
        for row in &section.rows {
            let q = &row.quantity;
            let shown = crate::emva::page::value_pm(q);
            let mut label = label(row);
            if !fits(&label) {
                text.push_str(&format!("  {label}\n"));
                label.clear();
            }
            text.push_str(&format!(
                "  {label:<width$} {shown:>24}  {}\n",
                q.status.label()
            ));
        }
    }
    let _ = std::io::Write::write_all(&mut std::io::stdout().lock(), text.as_bytes());
    for note in &sheet.notes {
        eprintln!("note: {note}");
    }
    eprintln!("wrote {}", out.display());
    Ok(())
}

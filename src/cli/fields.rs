//! Library field names -> command-line flags, so that errors name the option the user typed.
//!
//! The library names its settings by field (`emccd_read_noise_e`); the command line spells them
//! as flags (`--emccd-read-noise`). The readout and run settings take their flags from the
//! registry ([`crate::settings`]); this list holds the other commands' fields. A setting with
//! two spellings across commands maps to one field per meaning, so each field has exactly one
//! flag.

use crate::Error;

/// Every library field outside the settings registry that an error can name, with the flag
/// that sets it on the command line.
pub const FIELD_FLAGS: &[(&str, &str)] = &[
    ("out", "--out"),
    ("force", "--force"),
    ("stacks", "STACK"),
    // Monte-Carlo configurations, spots, output files (montecarlo, spot, output).
    ("plot", "--plot"),
    // Data path (io, calib, fit, synth): darks, ptc, fit-pdf, emgain, synth, and the pdf files
    // and maps they write for simulate/effective.
    ("clip", "--clip"),
    ("sigma_clip", "--sigma-clip"),
    ("hot_sigma", "--hot-sigma"),
    ("dead_fraction", "--dead-fraction"),
    ("rts_sigma", "--rts-sigma"),
    ("flats", "--flats"),
    ("gain_map", "--gain-map"),
    ("offset", "--offset"),
    ("read_noise", "--read-noise"),
    ("fixed_bias_adu", "--offset"),
    ("fixed_read_noise_adu", "--read-noise"),
    ("serial_cic", "--serial-cic"),
    ("bin_width_adu", "--bin-width-adu"),
    ("reference_stack", "--reference-stack"),
    ("reference_offset", "--reference-offset"),
    ("unit", "--unit"),
    ("models", "--models"),
    ("upper_cut_e", "--upper-cut-e"),
    ("model", "--model"),
    ("shape", "--shape"),
    ("frames", "--frames"),
    ("rms_pdf", "--rms-pdf"),
    // campaign: stacks given as FITS files, their kind (crate::campaign::KeywordOptions).
    ("files", "FILES"),
    ("kind", "--kind"),
    ("kind_key", "--kind-key"),
    ("temperature", "--temperature-term"),
    ("conversion_gain", "--gain-e-per-adu"),
    // campaign: the decomposition's classes and fit flag (crate::campaign::fit::FitThresholds).
    ("warm_sigma", "--warm-sigma"),
    ("warm_e_per_s", "--warm-e-per-s"),
    ("hot_e_per_s", "--hot-e-per-s"),
    ("bad_fit_p_value", "--bad-fit-p-value"),
    // synth: non-Gaussian sCMOS noise (crate::synth::Defects); its `row_noise_e` and
    // `column_noise_e` are the registry's (scmos-correlated's amplitudes, same flags).
    ("rts_fraction", "--rts-fraction"),
    ("rts_steps_e", "--rts-steps-e"),
    ("rts_step_spread", "--rts-step-spread"),
    ("rts_dwell_frames", "--rts-dwell-frames"),
    ("rts_occupancy", "--rts-occupancy"),
    ("hot_fraction", "--hot-fraction"),
    ("hot_dark_e", "--hot-dark-e"),
    // Effective QE factor of the simple EMCCD model (crate::effective::QePrecision, issue 14).
    ("qe_target_se", "--qe-target-se"),
    // report (crate::report::ReportOptions)
    ("darks_paths", "--darks"),
    ("flats_paths", "--flats"),
    ("subaps_px", "--subap"),
    ("spots", "--spot"),
    ("signals_photons", "--signal"),
    // report: the operating point of the headline numbers (crate::report::OperatingPoint)
    // Per-sub-aperture noise map (crate::subaps): geometry, shards, part files to merge.
    // Centroiders (centroid).
    ("shard", "--shard"),
    ("parts", "PART"),
];

/// Fields of library-only settings (chart building blocks) that no option sets: errors about
/// them are programming errors of a caller and keep the library's name.
pub const LIBRARY_ONLY_FIELDS: &[&str] = &[
    // A spatial stack given to the EMVA library without files (the datasheet's dataset loader
    // never builds one).
    "spatial_stack",
    // Campaign decomposition options no option sets (the fitted EM gains come from the
    // campaign's own histogram fits; `hot` is the class rule as a whole, its thresholds have
    // options); the emgain histogram's pixel mask.
    "em_gains",
    "hot",
    "keep",
    "axis_range",
    "heatmap_values",
    "hist_range",
    "hist_edges",
    "image_grid",
    "chart_path",
    "chart_size_px",
    // Readout models (detector): `PpConfig` settings that no option sets.
    "pp_lambda_max",
    "pp_zero_one",
];

/// Every field with its flag: the registry's settings, then [`FIELD_FLAGS`].
pub fn all_field_flags() -> impl Iterator<Item = (&'static str, &'static str)> {
    let registry = crate::settings::all().map(|s| (s.field, s.flag));
    registry.chain(FIELD_FLAGS.iter().copied())
}

/// The flag of library field `field`, if it has one.
pub fn flag_of(field: &str) -> Option<&'static str> {
    all_field_flags()
        .find(|(f, _)| *f == field)
        .map(|(_, flag)| flag)
}

/// `message` with every `` `field` `` mention replaced by its flag.
pub fn flags_in(message: &str) -> String {
    all_field_flags().fold(message.to_string(), |m, (field, flag)| {
        m.replace(&format!("`{field}`"), flag)
    })
}

/// The error as the command line shows it: library fields replaced by their flags.
pub fn to_cli(e: Error) -> Error {
    match e {
        Error::Usage { field, message } => Error::Usage {
            field: flag_of(&field).map(str::to_string).unwrap_or(field),
            message: flags_in(&message),
        },
        Error::Input { path, message } => Error::Input {
            path,
            message: flags_in(&message),
        },
        Error::Numeric(message) => Error::Numeric(flags_in(&message)),
        other @ (Error::Io { .. } | Error::Interrupted) => other,
    }
}

#[cfg(test)]
mod tests;

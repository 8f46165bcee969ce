//! A characterisation campaign: dark (and flat) stacks of one camera at several exposure
//! times, EM gains and temperatures, each streamed once to per-pixel moments
//! ([`ConditionStats`]), and the per-pixel decomposition of the mean dark into a fixed offset,
//! clock-induced charge and dark current with their standard errors.
//!
//! Layout: `condition` holds the shared types, `input` reads the stacks and their conditions
//! (a CSV manifest, FITS header keywords or an EMVA 1288 descriptor), `checks` refuses an
//! inconsistent campaign before any frame is read, `measure` streams each stack once into its
//! [`ConditionStats`] (and fits the EM histogram of EMCCD darks), `fit` decomposes every
//! pixel's mean dark into offset, CIC and dark current, `outputs` writes conditions.csv and
//! campaign.json, `camera` the measured camera as a camera model, and `run` is the whole `campaign` command as one call.

mod camera;
mod checks;
mod condition;
pub mod fit;
pub mod input;
mod measure;
mod outputs;
mod run;

pub use camera::{camera_model, REGISTER_STAGES};
pub use checks::{check_campaign, CampaignPlan, Design, MIN_CIC_GAINS, MIN_DARK_EXPOSURES};
pub use condition::{Condition, ConditionStats, StackKind};
pub use input::{CampaignInput, CampaignStack, KeywordOptions, Listing};
pub use measure::{measure_campaign, measure_stack, MeasureOptions, StackMeasurement};
pub use outputs::{
    write_campaign_outputs, CampaignSummary, ConditionRow, StackSummary, CAMERA_DIR,
    CAMPAIGN_OUTPUTS, DATASHEET_DIR,
};
pub use run::{run, CampaignRun, CampaignRunResult};

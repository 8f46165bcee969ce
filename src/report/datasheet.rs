//! The EMVA 1288 datasheet in the report: when the camera model of `--camera` is the `camera`
//! folder of a campaign run on an EMVA 1288 dataset (`detnoise campaign --emva-descriptor`,
//! which writes the datasheet into the campaign's `datasheet` folder), the camera section
//! gains the datasheet's key numbers and a link to its page. Read from the campaign's
//! datasheet.json; nothing is written.

use std::fmt::Write as _;
use std::path::{Component, Path, PathBuf};

use serde::Serialize;

use crate::campaign::DATASHEET_DIR;
use crate::emva::QuantityStatus;
use crate::output::html_escape as esc;

/// The datasheet rows the report shows (datasheet.json keys), in order.
pub const KEY_ROWS: [&str; 12] = [
    "system_gain_dn_per_e",
    "quantum_efficiency_percent",
    "dark_noise_e",
    "saturation_capacity_e",
    "snr_max_db",
    "dynamic_range_db",
    "sensitivity_threshold_e",
    "linearity_error_min_percent",
    "linearity_error_max_percent",
    "dark_current_mean_e_per_s",
    "dsnu_e",
    "prnu_percent",
];

/// One number of the datasheet as the report shows it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DatasheetNumber {
    /// Its datasheet.json key (units in the name).
    pub key: String,
    /// Its label on the datasheet.
    pub label: String,
    /// Its unit.
    pub unit: String,
    /// The value (null when unavailable).
    pub value: Option<f64>,
    /// Its standard error, same unit (null when not known).
    pub se: Option<f64>,
    /// Its status word (`ok`, `imprecise`, `out_of_rules`, `unavailable`).
    pub status: String,
}

/// The campaign's datasheet as the report links it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DatasheetLink {
    /// The datasheet's page (datasheet.html), as found.
    pub page: PathBuf,
    /// The page relative to the report's folder (the link on the report's page).
    pub href: String,
    /// The key numbers ([`KEY_ROWS`] the datasheet has).
    pub numbers: Vec<DatasheetNumber>,
}

/// The datasheet of the campaign whose `camera` folder is `camera_dir`, linked from the report
/// written to `report_dir`; None when that folder is not a campaign's or its campaign has no
/// datasheet (a campaign not run on an EMVA 1288 dataset).
pub fn find(camera_dir: &Path, report_dir: &Path) -> Option<DatasheetLink> {
    let campaign = camera_dir.parent()?;
    let dir = campaign.join(DATASHEET_DIR);
    let json = dir.join("datasheet.json");
    let page = dir.join("datasheet.html");
    if !(campaign.join("campaign.json").is_file() && json.is_file() && page.is_file()) {
        return None;
    }
    let sheet: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).ok()?).ok()?;
    let rows: Vec<&serde_json::Value> = sheet["sections"]
        .as_array()?
        .iter()
        .filter_map(|s| s["rows"].as_array())
        .flatten()
        .collect();
    let numbers = KEY_ROWS
        .iter()
        .filter_map(|key| {
            let r = rows.iter().find(|r| r["key"] == *key)?;
            let text = |k: &str| r[k].as_str().unwrap_or_default().to_string();
            Some(DatasheetNumber {
                key: key.to_string(),
                label: text("label"),
                unit: text("unit"),
                value: r["value"].as_f64(),
                se: r["se"].as_f64(),
                status: text("status"),
            })
        })
        .collect();
    Some(DatasheetLink {
        href: relative(&page, report_dir),
        page,
        numbers,
    })
}

/// `target` relative to the folder `from` (both made absolute; `from` need not exist yet),
/// with `/` separators; the absolute path when they share no root.
fn relative(target: &Path, from: &Path) -> String {
    let abs = |p: &Path| {
        let p = std::path::absolute(p).unwrap_or_else(|_| p.to_path_buf());
        p.canonicalize().unwrap_or(p)
    };
    let (t, f) = (abs(target), abs(from));
    let tc: Vec<Component> = t.components().collect();
    let fc: Vec<Component> = f.components().collect();
    let common = tc.iter().zip(&fc).take_while(|(a, b)| a == b).count();
    if common == 0 {
        return t.display().to_string();
    }
    let up = std::iter::repeat_n("..".to_string(), fc.len() - common);
    let down = tc[common..]
        .iter()
        .map(|c| c.as_os_str().to_string_lossy().into_owned());
    up.chain(down).collect::<Vec<_>>().join("/")
}

/// The datasheet's section on the report's page.
pub fn section_html(h: &mut String, d: &DatasheetLink) {
    h.push_str("<h2>Datasheet (EMVA 1288)</h2>");
    let _ = write!(
        h,
        "<p>The campaign that measured this camera model was run on an EMVA 1288 dataset: its \
         datasheet (release 4.0, every number with its standard error) is <a href=\"{}\">{}</a>, \
         with the standard's figures, datasheet.json, datasheet.csv and datasheet.xml beside it. \
         Its key numbers:</p><table><tr><th>quantity</th><th>value</th><th>unit</th>\
         <th>status</th></tr>",
        esc(&d.href),
        esc(&d.page.display().to_string())
    );
    for n in &d.numbers {
        let q = crate::emva::Quantity {
            value: n.value.unwrap_or(f64::NAN),
            se: n.se.unwrap_or(f64::NAN),
            status: QuantityStatus::Ok,
        };
        let _ = write!(
            h,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            esc(&n.label),
            crate::emva::page::value_pm(&q),
            esc(&n.unit),
            esc(&n.status)
        );
    }
    h.push_str("</table>");
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn links_are_relative_to_the_report() {
        let t = Path::new("/a/campaign/datasheet/datasheet.html");
        assert_eq!(
            relative(t, Path::new("/a/report")),
            "../campaign/datasheet/datasheet.html"
        );
        assert_eq!(
            relative(t, Path::new("/a/campaign")),
            "datasheet/datasheet.html"
        );
    }
}

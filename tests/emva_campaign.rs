//! `detnoise campaign --emva-descriptor` on an EMVA 1288 dataset also writes its datasheet
//! (the campaign's `datasheet` folder, as `detnoise datasheet` writes it), and the report of
//! the campaign's camera model finds it and shows its key numbers with a link to its page.

use std::path::PathBuf;

use assert_cmd::Command;
use detnoise::emva::datasheet::compute;
use detnoise::emva::spatial::SpatialOptions;
use detnoise::emva::xml::xml;
use detnoise::emva::EmvaDataset;
use detnoise::report::datasheet::{find, section_html};

fn descriptor() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("data-synthetic/emva-cmos-64x96/EMVA1288descriptor.txt")
}

#[test]
fn an_emva_campaign_writes_its_datasheet_and_the_report_links_it() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("campaign");
    Command::cargo_bin("detnoise")
        .unwrap()
        .args(["campaign", "--gain-e-per-adu", "2.5", "--emva-descriptor"])
        .arg(descriptor())
        .arg("--out")
        .arg(&out)
        .assert()
        .success();
    let dir = out.join("datasheet");
    for name in [
        "datasheet.json",
        "datasheet.csv",
        "datasheet.html",
        "datasheet.xml",
        "photon_transfer.png",
    ] {
        assert!(dir.join(name).is_file(), "{name}");
    }
    // The same datasheet as `detnoise datasheet` on the same descriptor.
    let dataset = EmvaDataset::from_descriptor(&descriptor()).unwrap();
    let datasheet = compute(&dataset, &SpatialOptions::default()).unwrap();
    assert_eq!(
        std::fs::read_to_string(dir.join("datasheet.xml")).unwrap(),
        xml(&datasheet)
    );

    // The report of the campaign's camera model, written beside the campaign.
    let link = find(&out.join("camera"), &tmp.path().join("report")).expect("found");
    assert_eq!(link.href, "../campaign/datasheet/datasheet.html");
    let k = link
        .numbers
        .iter()
        .find(|n| n.key == "system_gain_dn_per_e")
        .unwrap();
    assert_eq!(k.value, Some(datasheet.temporal.system_gain_dn_per_e.value));
    assert_eq!(k.unit, "DN/e-");
    assert_eq!(link.numbers.len(), 12);
    let mut h = String::new();
    section_html(&mut h, &link);
    assert!(h.contains("<h2>Datasheet (EMVA 1288)</h2>"), "{h}");
    assert!(
        h.contains("<a href=\"../campaign/datasheet/datasheet.html\">"),
        "{h}"
    );
    assert!(h.contains("<td>System gain K</td>"), "{h}");

    // A camera folder outside a campaign, or a campaign without a datasheet: no section.
    std::fs::remove_file(out.join("campaign.json")).unwrap();
    assert!(find(&out.join("camera"), tmp.path()).is_none());
}

//! detnoise's `datasheet.xml` against the XML result file the EMVA 1288 reference
//! implementation (`emva1288` 1.0.2, `Results1288.xml()`) writes for the same fixture
//! (`tests/fixtures/emva1288/*/results.xml`, made by `make_xml.py`): the same elements in the
//! same order with the same tags, and the same numbers within the tolerances of
//! tests/emva_reference.rs.

use std::path::{Path, PathBuf};

use detnoise::emva::datasheet::compute;
use detnoise::emva::run::{run, DatasheetInput, DatasheetRun};
use detnoise::emva::spatial::SpatialOptions;
use detnoise::emva::xml::{xml, XML_FILE};
use detnoise::emva::EmvaDataset;

fn fixture(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/emva1288")
        .join(name)
}

/// An element: its tag, its text (trimmed) and its children.
#[derive(Debug)]
struct Node {
    tag: String,
    text: String,
    children: Vec<Node>,
}

/// Parse the element starting at `s[*at..]` (no attributes, declarations or comments: the
/// files compared have none).
fn parse(s: &str, at: &mut usize) -> Node {
    let skip_ws = |at: &mut usize| {
        while s[*at..].starts_with(char::is_whitespace) {
            *at += 1;
        }
    };
    skip_ws(at);
    assert!(s[*at..].starts_with('<'), "an element at byte {at}");
    let end = *at + s[*at..].find('>').unwrap();
    let tag = s[*at + 1..end].to_string();
    assert!(
        !tag.contains(' ') && !tag.ends_with('/'),
        "plain tag {tag:?}"
    );
    *at = end + 1;
    let mut node = Node {
        tag,
        text: String::new(),
        children: Vec::new(),
    };
    loop {
        let next = *at + s[*at..].find('<').unwrap();
        let text = s[*at..next].trim();
        if s[next..].starts_with("</") {
            node.text = text
                .replace("&lt;", "<")
                .replace("&gt;", ">")
                .replace("&amp;", "&");
            let close = format!("</{}>", node.tag);
            assert!(s[next..].starts_with(&close), "{close} at byte {next}");
            *at = next + close.len();
            return node;
        }
        assert!(text.is_empty(), "mixed content in <{}>", node.tag);
        *at = next;
        node.children.push(parse(s, at));
    }
}

fn read_xml(text: &str) -> Node {
    let mut at = 0;
    let root = parse(text, &mut at);
    assert!(text[at..].trim().is_empty(), "text after the root element");
    root
}

/// The relative tolerance of a result (tests/emva_reference.rs's), None: compared exactly.
fn tolerance(name: &str) -> f64 {
    match name {
        // The exact SNR = 1 root, where the reference approximates (1/8 K / sigma_y.dark e-).
        "u_e_min" | "u_p_min" | "DR" => 0.012,
        "DR_dB" => 0.002,
        _ => 1e-6,
    }
}

/// Whether number texts `ours` and `theirs` agree within `rel` (nan with nan, None with
/// None).
fn agree(ours: &str, theirs: &str, rel: f64) -> bool {
    match (ours.parse::<f64>(), theirs.parse::<f64>()) {
        (Ok(a), Ok(b)) if a.is_nan() || b.is_nan() => a.is_nan() && b.is_nan(),
        (Ok(a), Ok(b)) => (a - b).abs() <= rel * b.abs().max(1e-12),
        _ => ours == theirs,
    }
}

/// Every difference between detnoise's XML and the reference's (empty: none).
fn differences(ours: &Node, theirs: &Node) -> Vec<String> {
    let mut out = Vec::new();
    let tags = |n: &Node| n.children.iter().map(|c| c.tag.clone()).collect::<Vec<_>>();
    assert_eq!(ours.tag, "results");
    assert_eq!(tags(ours), tags(theirs), "sections");
    for (so, st) in ours.children.iter().zip(&theirs.children) {
        assert_eq!(tags(so), tags(st), "results of {}", so.tag);
        for (ro, rt) in so.children.iter().zip(&st.children) {
            let name = &ro.tag;
            assert_eq!(tags(ro), tags(rt), "tags of {name}");
            for (eo, et) in ro.children.iter().zip(&rt.children) {
                match eo.tag.as_str() {
                    "value" => {
                        if !agree(&eo.text, &et.text, tolerance(name)) {
                            out.push(format!("{name}: {} vs {}", eo.text, et.text));
                        }
                    }
                    "data" => out.extend(data(name, eo, et)),
                    _ => assert_eq!(eo.text, et.text, "<{}> of {name}", eo.tag),
                }
            }
        }
    }
    out
}

/// A histogram's arrays: the reference's `model` of an accumulated histogram is left out on
/// purpose (module doc of detnoise::emva::xml); every other array agrees number by number.
fn data(name: &str, ours: &Node, theirs: &Node) -> Vec<String> {
    let mut out = Vec::new();
    let wanted: Vec<&str> = theirs
        .children
        .iter()
        .map(|c| c.tag.as_str())
        .filter(|t| !(name.ends_with("_accumulated") && *t == "model"))
        .collect();
    let got: Vec<&str> = ours.children.iter().map(|c| c.tag.as_str()).collect();
    assert_eq!(got, wanted, "arrays of {name}");
    for o in &ours.children {
        let t = theirs.children.iter().find(|c| c.tag == o.tag).unwrap();
        let (a, b): (Vec<&str>, Vec<&str>) = (
            o.text.split_whitespace().collect(),
            t.text.split_whitespace().collect(),
        );
        if a.len() != b.len() {
            out.push(format!(
                "{name}/{}: {} vs {} numbers",
                o.tag,
                a.len(),
                b.len()
            ));
            continue;
        }
        // The normal model: detnoise scales it by the bin width W (its total is the pixel
        // count), the reference by (max - min) / Q, which is less by a factor between
        // (Q - 1) / Q and 1 for Q bins (detnoise::emva::spatial::Binned::normal_model).
        let scale = if o.tag == "model" {
            let f = |v: &[&str]| v.iter().map(|x| x.parse::<f64>().unwrap()).sum::<f64>();
            let ratio = f(&b) / f(&a);
            let q = a.len() as f64;
            assert!(
                ((q - 1.0) / q..=1.0 + 1e-12).contains(&ratio),
                "{name}: model scale {ratio} for {q} bins"
            );
            ratio
        } else {
            1.0
        };
        let scaled: Vec<String> = a
            .iter()
            .map(|x| (x.parse::<f64>().unwrap() * scale).to_string())
            .collect();
        let bad = scaled
            .iter()
            .zip(&b)
            .filter(|(x, y)| !agree(x, y, 1e-6))
            .count();
        if bad > 0 {
            out.push(format!(
                "{name}/{}: {bad} of {} numbers differ",
                o.tag,
                a.len()
            ));
        }
    }
    out
}

fn ours(dir: &Path) -> String {
    let dataset = EmvaDataset::from_descriptor(&dir.join("EMVA1288descriptor.txt")).unwrap();
    xml(&compute(&dataset, &SpatialOptions::default()).unwrap())
}

#[test]
fn the_exposure_series_fixture_writes_the_references_xml() {
    let dir = fixture("emva-ref-96x128");
    let theirs = std::fs::read_to_string(dir.join("results.xml")).unwrap();
    let ours = ours(&dir);
    let diff = differences(&read_xml(&ours), &read_xml(&theirs));
    assert!(diff.is_empty(), "{diff:#?}");
    // Not only the same numbers: the same text where the numbers are the same.
    for line in [
        "    <K>\n      <section>sensitivity</section>\n      <short>System gain</short>\n      <symbol>K</symbol>\n      <unit>$DN/e^-$</unit>\n      <latexname>K</latexname>\n      <value>",
        "<unit>$e^-/\\mu m^2$</unit>\n      <latexname>UEMin</latexname>\n      <value>None</value>",
        "    <index_u_ysat>\n      <section>sensitivity</section>\n      <short>Saturation index</short>\n      <value>47</value>",
    ] {
        assert!(ours.contains(line) && theirs.contains(line), "{line}");
    }
}

#[test]
fn the_64_row_fixture_writes_nan_where_the_reference_does() {
    // One exposure time: no dark current; no row pattern: the row DSNU and the row and
    // column PRNU are NaN in the reference and unavailable in detnoise, `nan` in both files.
    let dir = fixture("emva-ref-64x64");
    let theirs = std::fs::read_to_string(dir.join("results.xml")).unwrap();
    let ours = ours(&dir);
    let diff = differences(&read_xml(&ours), &read_xml(&theirs));
    assert!(diff.is_empty(), "{diff:#?}");
    for name in [
        "u_I_mean",
        "u_I_var",
        "DSNU1288_row",
        "PRNU1288_row",
        "PRNU1288_col",
    ] {
        let ours = read_xml(&ours);
        let value = ours
            .children
            .iter()
            .flat_map(|s| &s.children)
            .find(|r| r.tag == name)
            .and_then(|r| r.children.iter().find(|c| c.tag == "value"))
            .unwrap();
        assert_eq!(value.text, "nan", "{name}");
    }
}

#[test]
fn datasheet_writes_the_xml_beside_the_sheet() {
    let dir = fixture("emva-ref-64x64");
    let tmp = tempfile::tempdir().unwrap();
    let job = DatasheetRun {
        input: DatasheetInput::Descriptor(dir.join("EMVA1288descriptor.txt")),
        out: tmp.path().join("ds"),
        force: false,
        spatial: SpatialOptions::default(),
        beyond: Default::default(),
    };
    let (datasheet, _, out) = run(&job).unwrap();
    let written = std::fs::read_to_string(out.join(XML_FILE)).unwrap();
    assert_eq!(written, xml(&datasheet));
}

//! astropy reads detnoise's FITS outputs to the same values and promised headers.
//! Optional: skips (with a message) when python3 or astropy is missing.

use std::process::Command;

use detnoise::calib::darks::{dark_maps, DarkOptions};
use detnoise::io::FrameStack;
use detnoise::synth::SynthFormat;
use detnoise::synth::{write_synthetic, Camera, ScmosParams, SynthSpec};

const SCRIPT: &str = r#"
import json, sys
from astropy.io import fits
out = {}
for name in sys.argv[1:]:
    with fits.open(name) as h:
        d = h[0].data
        out[name] = {"shape": list(d.shape), "bunit": h[0].header.get("BUNIT"),
                     "creator": h[0].header.get("CREATOR"), "nframes": h[0].header.get("NFRAMES"),
                     "first_row": [float(x) for x in d[0]], "sum": float(d.astype("f8").sum())}
print(json.dumps(out))
"#;

#[test]
fn astropy_reads_our_maps() {
    let ok = Command::new("python3")
        .args(["-c", "import astropy"])
        .output()
        .map(|o| o.status.success())
        .unwrap_or(false);
    if !ok {
        eprintln!("SKIPPED astropy_reads_our_maps: python3 with astropy not available");
        return;
    }
    let d = tempfile::tempdir().unwrap();
    let sp = SynthSpec {
        camera: Camera::Scmos(ScmosParams::default()),
        shape: (6, 10),
        frames: 30,
        light_e: 0.0,
        seed: 4,
        u16_samples: true,
    };
    let stack_path = d.path().join("s.fits");
    write_synthetic(&sp, &detnoise::pdf::paper(), SynthFormat::Fits, &stack_path).unwrap();
    let stack = FrameStack::open(std::slice::from_ref(&stack_path)).unwrap();
    let opts = DarkOptions::default();
    let maps = dark_maps(&stack, &opts).unwrap();
    let out = d.path().join("out");
    let inputs = detnoise::calib::summary::inputs(&stack, detnoise::io::Checksum::Blake3).unwrap();
    detnoise::calib::darks::write_outputs(
        &out,
        &stack,
        &maps,
        &opts,
        Some(0.25),
        inputs,
        "summary.json",
    )
    .unwrap();
    let files: Vec<String> = [
        "offset_adu.fits",
        "rms_adu.fits",
        "rms_e.fits",
        "flags.fits",
    ]
    .iter()
    .map(|f| out.join(f).to_string_lossy().into_owned())
    .collect();
    let o = Command::new("python3")
        .arg("-c")
        .arg(SCRIPT)
        .args(&files)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let check = |file: &str, unit: Option<&str>, map: &[f64]| {
        let e = &v[file];
        assert_eq!(
            e["shape"],
            serde_json::json!([6, 10]),
            "{file}: astropy shape is (rows, cols)"
        );
        assert_eq!(e["bunit"].as_str(), unit, "{file}: BUNIT");
        assert!(e["creator"].as_str().unwrap().starts_with("detnoise"));
        assert_eq!(e["nframes"], 30);
        let row: Vec<f64> = e["first_row"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect();
        // serde_json parses decimals to within an ulp, so compare to 1e-12 relative.
        for (a, b) in row.iter().zip(&map[..10]) {
            assert!(
                (a - b).abs() <= 1e-12 * b.abs().max(1.0),
                "{file}: first row {a} vs {b}"
            );
        }
        let sum: f64 = map.iter().sum();
        assert!((e["sum"].as_f64().unwrap() - sum).abs() <= 1e-9 * sum.abs());
    };
    check(&files[0], Some("adu"), &maps.offset_adu.data);
    check(&files[1], Some("adu"), &maps.rms_adu.data);
    let rms_e: Vec<f64> = maps.rms_adu.data.iter().map(|r| r * 0.25).collect();
    check(&files[2], Some("electron"), &rms_e);
    let flags: Vec<f64> = maps.flags.iter().map(|f| *f as f64).collect();
    check(&files[3], None, &flags);
}

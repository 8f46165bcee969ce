//! `detnoise paper --quick` produces every figure file, and the PNGs decode.

use assert_cmd::Command;

#[test]
fn quick_paper_run_writes_every_figure() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("figs");
    Command::cargo_bin("detnoise")
        .unwrap()
        .args(["paper", "--quick", "--out"])
        .arg(&out)
        .assert()
        .success();
    let index = std::fs::read_to_string(out.join("index.html")).unwrap();
    let readme = std::fs::read_to_string(out.join("README.md")).unwrap();
    let mut pngs = 0;
    for n in 1..=14 {
        let prefix = format!("fig{n:02}-");
        let files: Vec<_> = std::fs::read_dir(&out)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().to_string())
            .filter(|f| f.starts_with(&prefix))
            .collect();
        for ext in ["png", "svg", "csv"] {
            assert!(
                files.iter().any(|f| f.ends_with(ext)),
                "figure {n} lacks a .{ext}: {files:?}"
            );
        }
        assert!(
            readme.contains(&format!("## Fig. {n}:")),
            "README lacks figure {n}"
        );
        for f in &files {
            let path = out.join(f);
            assert!(
                std::fs::metadata(&path).unwrap().len() > 100,
                "{f} is (nearly) empty"
            );
            if f.ends_with(".png") {
                let img = image::open(&path).unwrap_or_else(|e| panic!("{f} does not decode: {e}"));
                assert!(
                    img.width() >= 400 && img.height() >= 300,
                    "{f} is too small"
                );
                assert!(index.contains(f.as_str()), "index.html does not show {f}");
                pngs += 1;
            }
        }
    }
    // 12 single figures, two Fig. 11 panels and six Fig. 12 panels.
    assert_eq!(pngs, 12 + 2 + 6);
    // Fig. 12's table states each cell's status; a value that is not a number is an empty cell.
    let fig12 = std::fs::read_to_string(out.join("fig12-effective-read-noise.csv")).unwrap();
    let mut rows = fig12.lines();
    assert!(rows.next().unwrap().ends_with(",status"));
    let words = [
        "ok",
        "imprecise",
        "lower_bound",
        "unreachable",
        "no_eligible_level",
    ];
    for row in rows {
        assert!(words.contains(&row.rsplit(',').next().unwrap()), "{row}");
    }
    assert!(!fig12.contains("NaN"));
    // No partial directory is left beside the output.
    let siblings: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(siblings.len(), 1, "{siblings:?}");
}

//! Helpers shared by the integration tests (`mod common;` in each file that uses them).

// Each test file is its own crate and uses only some of these.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

use assert_cmd::Command;
use detnoise::io::FrameStack;

/// Options that make a Monte-Carlo run fast: 1,000 iterations, no precision target.
pub const FAST: [&str; 8] = [
    "--iters",
    "1000",
    "--max-iters",
    "1000",
    "--target-se-e",
    "0",
    "--target-rel",
    "0",
];

/// The `detnoise` binary built for this test run (needs the `cli` feature).
pub fn detnoise() -> Command {
    Command::cargo_bin("detnoise").unwrap()
}

/// `detnoise datasheet --emva-descriptor descriptor --out out`, which must succeed; its output.
pub fn datasheet(descriptor: &Path, out: &Path) -> std::process::Output {
    let o = detnoise()
        .args(["datasheet", "--emva-descriptor"])
        .arg(descriptor)
        .arg("--out")
        .arg(out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    o
}

/// Path of the bundled stack `name` under `data-synthetic/`.
pub fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("data-synthetic")
        .join(name)
}

/// The frame stack in the single file `p`.
pub fn open(p: &Path) -> FrameStack {
    FrameStack::open(&[p.to_path_buf()]).unwrap()
}

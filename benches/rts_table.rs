//! Loading an `rts.csv` for `scmos-rts`: wall seconds to read and parse the table and to build
//! the model on a 2048x2048 px map, at 50,000, 200,000 and 1,000,000 telegraph pixels (a 4k x
//! 4k camera with 2 % RTS pixels has 300,000), in a scrambled pixel order.
//!
//! `cargo bench --bench rts_table` (all three sizes), or `-- ROWS...` for other row counts.
//! Target: linear in the rows, 1,000,000 rows in a few seconds (issue 30: it was quadratic,
//! 200,000 rows 56 s). The Monte-Carlo does not depend on the table's size beyond its build.

use detnoise::calib::{Map, Unit};
use detnoise::detector::{ModelParams, ModelSpec, RtsTable};
use detnoise::progress::Silent;
use std::fmt::Write;
use std::sync::Arc;
use std::time::Instant;

/// Side of the map (px): 4.2 million pixels, room for a million distinct telegraph pixels.
const SIDE: usize = 2048;

/// An `rts.csv` of `rows` two-level `ok` pixels in the shared format, at distinct places of a
/// SIDE x SIDE frame in a scrambled order (an odd multiplier permutes the frame's indices).
fn table_text(rows: usize) -> String {
    let mut text = String::from("x_px,y_px,n_levels,status");
    for k in 1..=3 {
        let _ = write!(
            text,
            ",level_{k}_adu,level_{k}_se_adu,level_{k}_e,occupancy_{k},occupancy_{k}_se,\
             width_{k}_adu,width_{k}_e,dwell_{k}_frames,dwell_{k}_se_frames"
        );
    }
    let n = SIDE * SIDE;
    for i in 0..rows {
        let p = i.wrapping_mul(2_654_435_761) % n;
        let _ = write!(
            text,
            "\n{},{},2,ok,-6,0.1,-1.5,0.25,0.01,4,1,10,1,2,0.1,0.5,0.75,0.01,4,1,30,2,,,,,,,,,",
            p % SIDE,
            p / SIDE
        );
    }
    text.push('\n');
    text
}

fn main() {
    let counts: Vec<usize> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    let counts = if counts.is_empty() {
        vec![50_000, 200_000, 1_000_000]
    } else {
        counts
    };
    let map = Arc::new(
        Map::new(SIDE, SIDE, vec![1.0; SIDE * SIDE], Unit::Electrons).with_source("bench map"),
    );
    let dir = tempfile::tempdir().expect("a temporary directory");
    println!("rts.csv of two-level pixels on a {SIDE}x{SIDE} px map; wall seconds");
    println!(
        "{:>9} {:>9} {:>8} {:>8} {:>8}",
        "rows", "MB", "read", "build", "per row"
    );
    for rows in counts {
        let path = dir.path().join("rts.csv");
        let text = table_text(rows);
        std::fs::write(&path, &text).expect("write the table");
        let t0 = Instant::now();
        let table = RtsTable::read(&path, &Silent).expect("a valid table");
        let read = t0.elapsed().as_secs_f64();
        assert_eq!(table.pixels.len(), rows);
        let params = ModelParams {
            map: Some(map.clone()),
            rts_table: Some(Arc::new(table)),
            ..ModelParams::default()
        };
        let t1 = Instant::now();
        let model = ModelSpec::parse("scmos-rts")
            .and_then(|s| s.build(&params, 16))
            .expect("scmos-rts builds");
        let build = t1.elapsed().as_secs_f64();
        std::hint::black_box(&model);
        println!(
            "{rows:>9} {:>9.1} {read:>8.3} {build:>8.3} {:>6.2} us",
            text.len() as f64 / 1e6,
            (read + build) / rows as f64 * 1e6
        );
    }
}

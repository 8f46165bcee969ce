//! Running one file through the library entry points of `darks`, `emgain` and `fit-pdf`,
//! and judging the outcome: Ok, or errors that name the file; never a panic, a hang or an
//! allocation beyond what the file can hold.

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::Path;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use detnoise::calib::darks::{dark_maps, DarkOptions};
use detnoise::calib::{Map, Unit};
use detnoise::fit::emgain::{accumulate, fit_emgain_of_stack, EmGainOptions};
use detnoise::fit::pdf_fit::fit_pdf_of_map;
use detnoise::fit::PdfFitOptions;
use detnoise::io::{FrameStack, MAX_EXPANSION};
use detnoise::Error;

use super::alloc;
use super::fixtures::Role;

/// Fixed work of an entry point whose size depends on no header: the EM-gain fit's model
/// grid (at most 2^19 complex cells and its FFT plan) and histogram (2^22 bins), the pdf
/// tables, a chart's raster.
pub const WORK_BYTES: usize = 96 << 20;

/// Largest single allocation allowed for a file of `len` bytes: the fixed work, plus the
/// file's decoded size as f64 (8 bytes per byte at most) expanded [`MAX_EXPANSION`]-fold when
/// the data may be compressed.
pub fn allowed_bytes(len: usize) -> usize {
    WORK_BYTES + 8 * MAX_EXPANSION as usize * len
}

/// `darks` (stack, dark maps) and `emgain` (histogram of the stack, EM-gain fit), each
/// independently; an error at opening ends both.
fn stack_entry_points(path: &Path) -> Vec<(&'static str, Result<(), Error>)> {
    let stack = match FrameStack::open(&[path.to_path_buf()]) {
        Ok(s) => s,
        Err(e) => return vec![("open stack", Err(e))],
    };
    let darks = dark_maps(&stack, &DarkOptions::default()).map(|_| ());
    let emgain = accumulate(&stack, None, None)
        .and_then(|(h, _)| fit_emgain_of_stack(&stack, &h, &EmGainOptions::default()))
        .map(|_| ());
    vec![("darks", darks), ("emgain", emgain)]
}

/// `fit-pdf`: read the map, fit every model, draw the chart (SVG, into `scratch`).
fn map_entry_point(path: &Path, scratch: &Path) -> Vec<(&'static str, Result<(), Error>)> {
    let r = Map::read(path, Unit::Electrons).and_then(|map| {
        let report = fit_pdf_of_map(path, &map.data, &PdfFitOptions::default())?;
        detnoise::fit::pdf_fit::chart(&report, &map.data, &scratch.join("pdf_fit.svg"))
    });
    vec![("fit-pdf", r)]
}

/// Files for which some entry point succeeded (mutants still read as valid files): shows
/// how deep the mutants reach.
pub static ALL_OK: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);

/// What went wrong with one file, if anything.
pub fn judge(path: &Path, role: Role, scratch: &Path) -> Option<String> {
    let len = std::fs::metadata(path)
        .map(|m| m.len() as usize)
        .unwrap_or(0);
    alloc::reset_largest();
    let r = catch_unwind(AssertUnwindSafe(|| match role {
        Role::Stack => stack_entry_points(path),
        Role::Map => map_entry_point(path, scratch),
    }));
    let mut bad = Vec::new();
    match r {
        Err(payload) => {
            let msg = payload
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| payload.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_else(|| "non-string panic".into());
            bad.push(format!("PANIC: {msg}"));
        }
        Ok(results) => {
            if results.iter().any(|r| r.1.is_ok()) {
                ALL_OK.fetch_add(1, Ordering::Relaxed);
            }
            let name = path.display().to_string();
            for (entry, r) in results {
                if let Err(e) = r {
                    let text = e.to_string();
                    let names_file = matches!(&e, Error::Input { path: p, .. } | Error::Io { path: p, .. } if p == path);
                    if !names_file || !text.contains(&name) {
                        bad.push(format!("{entry}: error does not name the file: {text}"));
                    }
                }
            }
        }
    }
    let largest = alloc::largest();
    if largest > allowed_bytes(len) {
        bad.push(format!(
            "allocated {largest} bytes at once, over {} for a {len}-byte file",
            allowed_bytes(len)
        ));
    }
    (!bad.is_empty()).then(|| bad.join("; "))
}

/// A watchdog: aborts the process, naming the running file, when one takes longer than
/// `budget` (a hang cannot be caught any other way).
pub struct Watchdog {
    started_ms: Arc<AtomicU64>,
    label: Arc<Mutex<String>>,
    stop: Arc<AtomicBool>,
    epoch: Instant,
}

impl Watchdog {
    /// Start watching with a per-file `budget`.
    pub fn start(budget: Duration) -> Watchdog {
        let w = Watchdog {
            started_ms: Arc::new(AtomicU64::new(u64::MAX)),
            label: Arc::new(Mutex::new(String::new())),
            stop: Arc::new(AtomicBool::new(false)),
            epoch: Instant::now(),
        };
        let (started, label, stop, epoch) = (
            w.started_ms.clone(),
            w.label.clone(),
            w.stop.clone(),
            w.epoch,
        );
        std::thread::spawn(move || {
            while !stop.load(Ordering::Relaxed) {
                std::thread::sleep(Duration::from_millis(100));
                let s = started.load(Ordering::Relaxed);
                let now = epoch.elapsed().as_millis() as u64;
                if s != u64::MAX && now.saturating_sub(s) > budget.as_millis() as u64 {
                    eprintln!(
                        "\nHANG: over {budget:?} on {}",
                        label.lock().map(|l| l.clone()).unwrap_or_default()
                    );
                    std::process::abort();
                }
            }
        });
        w
    }

    /// Note that `label` starts now.
    pub fn begin(&self, label: &str) {
        *self.label.lock().unwrap_or_else(|p| p.into_inner()) = label.to_string();
        alloc::set_label(label);
        self.started_ms
            .store(self.epoch.elapsed().as_millis() as u64, Ordering::Relaxed);
    }

    /// Note that the current file is done.
    pub fn end(&self) {
        self.started_ms.store(u64::MAX, Ordering::Relaxed);
    }
}

impl Drop for Watchdog {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
    }
}

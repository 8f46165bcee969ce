//! Sub-aperture part files: seeds written by a small real `subaps` job through the library
//! (a 16x16 px map in 4x4 px sub-apertures, one shard and two), structure-aware mutants of
//! them, and their judgement through the resume path (`run_into_dir` on a directory holding
//! the mutant) and `subaps-merge`'s (`merge_into_dir`).
//!
//! What each mutant allows:
//! - a part cut after its header, short of lines, or with its records in another order: the
//!   resume must resume it (`Kept`: recompute what is missing, same records).
//! - every line mutant in a merge, and the others in a resume (the header dropped, moved or
//!   cut, lines repeated, flipped bits, blank, CRLF, BOM, long and random lines), and
//!   records edited without fixing their line checksum: `Same`. Every
//!   line is bound by a checksum (the header by `binding_blake3`), so an Ok must give the
//!   seed's records and binding: a resume may recompute a dropped or torn sub-aperture (the
//!   job is deterministic), a merge may reorder; anything else must be refused.
//! - a header field of the binding edited without fixing `binding_blake3`: `Refused`.
//!   Fields outside the binding (`map_source`, `subaps_in_shard`, `shard`, `format`, the
//!   checksum itself): `Same`.
//! - a binding field edited and `binding_blake3` recomputed (a forgery): the resume must
//!   refuse it (the job's own options differ); a merge cannot tell (`Any`).
//! - a record edited and its line checksum recomputed: `Same` for its index (the shard and
//!   duplicate checks must catch it); for its grid cell `Same` in a merge (the layout's
//!   checksum must catch it), `Any` in the resume of a shard (which does not merge);
//!   `Any` for its values (the line checksum guards against damage, not forgery).

use std::path::{Path, PathBuf};

use detnoise::calib::{Map, Unit};
use detnoise::effective::{Precision, Status};
use detnoise::montecarlo::SimConfig;
use detnoise::progress::Silent;
use detnoise::subaps::{
    merge_into_dir, read_part, run_into_dir, DirTarget, Geometry, GridSpec, PartHeader, PartRecord,
    Shard, SubapsJob,
};
use serde_json::Value;

use super::expect::{caught, verdict, Case, Expect, Seen};
use super::lines::{self, Op};
use super::{fixtures, Mutant, Rng};

/// Starting iterations of every sub-aperture: enough for a value, little enough that a
/// resume recomputing all 16 takes milliseconds.
const ITERS: u64 = 200;

/// The job every seed was written by.
pub struct PartJob {
    map: Map,
    geometry: Geometry,
}

impl PartJob {
    /// A 16x16 px cut of the bundled sCMOS read-noise map, 4x4 px sub-apertures.
    pub fn new() -> PartJob {
        let data = fixtures::crop(
            "data-synthetic/scmos-darks-64x64.truth-rms_e.fits",
            1,
            (16, 16),
        );
        PartJob {
            map: Map::new(16, 16, data[0].clone(), Unit::Electrons).with_source("map.fits"),
            geometry: Geometry {
                grid: GridSpec::parse("4").unwrap(),
                mask: None,
            },
        }
    }

    fn job(&self) -> SubapsJob<'_> {
        SubapsJob {
            map: &self.map,
            geometry: &self.geometry,
            config: SimConfig {
                iters: ITERS,
                ..SimConfig::paper(4)
            },
            precision: Precision::fixed(ITERS),
            centroider: Default::default(),
        }
    }

    fn run(&self, shard: Shard, out: &Path) -> detnoise::Result<()> {
        let target = DirTarget {
            out,
            force: false,
            inputs: &[],
        };
        run_into_dir(&self.job(), shard, &target, &Silent).map(|_| ())
    }
}

/// A seed part file, with what its judgement compares against.
pub struct PartSeed {
    /// `part-1of1` or `part-1of2`.
    pub name: &'static str,
    /// The shard it holds.
    pub shard: Shard,
    /// Its bytes.
    pub bytes: Vec<u8>,
    /// The other shards' parts (merged beside the mutant).
    pub others: Vec<PathBuf>,
    /// Its own records' lines, by index.
    own: Vec<String>,
    /// Every record's line of the job, by index.
    all: Vec<String>,
    /// The binding as JSON.
    binding: String,
    /// `subaps.csv` of the whole job.
    csv: Vec<u8>,
}

fn record_lines(records: &[PartRecord]) -> Vec<String> {
    let mut r: Vec<&PartRecord> = records.iter().collect();
    r.sort_by_key(|r| r.index);
    r.iter().map(|r| r.line()).collect()
}

fn binding_json(h: &PartHeader) -> String {
    serde_json::to_string(&h.binding).unwrap()
}

/// The seeds, written into `dir` by the job (one shard; two shards).
pub fn seeds(job: &PartJob, dir: &Path) -> Vec<PartSeed> {
    let (one, two) = (dir.join("one"), dir.join("two"));
    job.run(Shard::ALL, &one).expect("the seed job runs");
    for k in 1..=2 {
        job.run(Shard { k, n: 2 }, &two)
            .expect("the seed shards run");
    }
    let whole = read_part(&one.join(Shard::ALL.file_name())).unwrap();
    let all = record_lines(&whole.records);
    let binding = binding_json(&whole.header);
    let csv = std::fs::read(one.join("subaps.csv")).unwrap();
    let seed = |name, shard: Shard, path: PathBuf, others| {
        let content = read_part(&path).unwrap();
        assert_eq!(binding_json(&content.header), binding, "one job");
        PartSeed {
            name,
            shard,
            bytes: std::fs::read(&path).unwrap(),
            others,
            own: record_lines(&content.records),
            all: all.clone(),
            binding: binding.clone(),
            csv: csv.clone(),
        }
    };
    let half = Shard { k: 1, n: 2 };
    vec![
        seed(
            "part-1of1",
            Shard::ALL,
            one.join(Shard::ALL.file_name()),
            vec![],
        ),
        seed(
            "part-1of2",
            half,
            two.join(half.file_name()),
            vec![two.join(Shard { k: 2, n: 2 }.file_name())],
        ),
    ]
}

/// A part mutant: what the resume and the merge allow.
pub struct PartCase {
    /// The mutant and what the resume allows.
    pub case: Case,
    /// What the merge allows.
    pub merge: Expect,
}

/// `n` mutants of `seed`.
pub fn mutants(seed: &PartSeed, rng: &mut Rng, n: usize) -> Vec<PartCase> {
    (0..n)
        .map(|_| match rng.below(20) {
            0..=8 => {
                let (op, m) = lines::mutant(&seed.bytes, rng);
                PartCase {
                    case: Case::new(m, resume_expect(op)),
                    merge: Expect::Same,
                }
            }
            9..=13 => header_edit(&seed.bytes, rng, false),
            14..=15 => header_edit(&seed.bytes, rng, true),
            _ => record_edit(&seed.bytes, rng),
        })
        .collect()
}

/// What the resume allows of a line mutant: a part cut anywhere after its header, short of
/// lines or with its lines in another order is a run killed or finished in another order,
/// to resume (`Kept`); the rest must be refused or give the seed's records.
fn resume_expect(op: Op) -> Expect {
    match op {
        Op::TruncateByte { header: false }
        | Op::Drop { header: false }
        | Op::Swap { header: false }
        | Op::NoFinalNewline => Expect::Kept,
        Op::TruncateLine { keep } if keep >= 1 => Expect::Kept,
        _ => Expect::Same,
    }
}

/// Every leaf of a JSON value, as its path of keys.
fn leaves(v: &Value, path: &mut Vec<String>, out: &mut Vec<Vec<String>>) {
    match v {
        Value::Object(m) => {
            for (k, v) in m {
                path.push(k.clone());
                leaves(v, path, out);
                path.pop();
            }
        }
        Value::Array(a) => {
            for (i, v) in a.iter().enumerate() {
                path.push(i.to_string());
                leaves(v, path, out);
                path.pop();
            }
        }
        _ => out.push(path.clone()),
    }
}

fn at<'a>(v: &'a mut Value, path: &[String]) -> &'a mut Value {
    path.iter().fold(v, |v, k| match v {
        Value::Array(a) => &mut a[k.parse::<usize>().unwrap()],
        other => &mut other[k.as_str()],
    })
}

/// A new value for a JSON leaf `old`, different from it.
fn new_value(old: &Value, rng: &mut Rng) -> Value {
    let choices: Vec<Value> = match old {
        Value::Number(n) => {
            let f = n.as_f64().unwrap_or(0.0);
            vec![
                serde_json::json!(f + 1.0),
                serde_json::json!(f * 10.0),
                serde_json::json!(0),
                serde_json::json!(-1),
                serde_json::json!(1.5),
                serde_json::json!(1e308),
                serde_json::json!(u64::MAX),
                serde_json::json!(18_446_744_073_709_551_616.0),
                serde_json::json!(format!("{f}")),
                Value::Null,
            ]
        }
        Value::String(s) => vec![
            serde_json::json!(""),
            serde_json::json!(format!("{s}x")),
            serde_json::json!(s.chars().rev().collect::<String>()),
            serde_json::json!("x".repeat(10_000)),
            serde_json::json!(7),
            Value::Null,
        ],
        _ => vec![
            serde_json::json!("00"),
            serde_json::json!(0),
            serde_json::json!(blake3::hash(b"x").to_hex().to_string()),
        ],
    };
    let fresh: Vec<Value> = choices.into_iter().filter(|v| v != old).collect();
    rng.pick(&fresh).clone()
}

/// A mutant with one field of the header (first line) edited; with `fix`, the binding's
/// checksum recomputed when the edited header still decodes.
fn header_edit(seed: &[u8], rng: &mut Rng, fix: bool) -> PartCase {
    let header: Value = serde_json::from_slice(&lines::split(seed)[0]).expect("JSON header");
    let mut paths = Vec::new();
    leaves(&header, &mut Vec::new(), &mut paths);
    // The binding's fields three times as often as the others: they carry the meaning.
    let path = loop {
        let p = rng.pick(&paths).clone();
        if p[0] == "binding" || rng.below(3) == 0 {
            break p;
        }
    };
    let mut header = header;
    let new = new_value(at(&mut header, &path), rng);
    edit_header(seed, &path, new, fix)
}

/// A mutant with the header field at `path` set to `new`; with `fix`, the binding's
/// checksum recomputed when the edited header still decodes.
fn edit_header(seed: &[u8], path: &[String], new: Value, fix: bool) -> PartCase {
    let mut ls = lines::split(seed);
    let mut header: Value = serde_json::from_slice(&ls[0]).expect("the seed's header is JSON");
    let v = at(&mut header, path);
    let old = v.clone();
    *v = new;
    let label = format!("header {} = {} (was {old})", path.join("."), short(v));
    let in_binding = path[0] == "binding";
    let forged = if fix {
        serde_json::from_value::<PartHeader>(header.clone())
            .ok()
            .map(|mut h| {
                h.binding_blake3 = h.binding.digest();
                serde_json::to_string(&h).unwrap()
            })
    } else {
        None
    };
    let (text, expect, merge) = match forged {
        Some(t) if in_binding => (t, Expect::Refused, Expect::Any),
        Some(t) => (t, Expect::Same, Expect::Same),
        None if in_binding => (header.to_string(), Expect::Refused, Expect::Refused),
        None => (header.to_string(), Expect::Same, Expect::Same),
    };
    let fixed = if fix && expect == Expect::Refused && merge == Expect::Any {
        ", binding_blake3 recomputed"
    } else {
        ""
    };
    ls[0] = format!("{text}\n").into_bytes();
    PartCase {
        case: Case::new(
            Mutant::new(format!("{label}{fixed}"), lines::join(&ls)),
            expect,
        ),
        merge,
    }
}

/// Forged headers (the binding's checksum recomputed) whose geometry overflows a window's
/// arithmetic or claims more sub-apertures than a map can hold: a merge must refuse them or
/// merge them, without a panic, a hang or a huge allocation.
pub fn forged_geometry(seed: &PartSeed) -> Vec<PartCase> {
    let mut out = Vec::new();
    for field in ["size_px", "pitch_px", "x0_px", "y0_px"] {
        for v in [u64::MAX, 1 << 40] {
            let path = ["binding".to_string(), "grid".into(), field.into()];
            out.push(edit_header(&seed.bytes, &path, v.into(), true));
        }
    }
    for (field, i) in [
        ("grid_shape", Some("0")),
        ("grid_shape", Some("1")),
        ("subaps", None),
        ("map_shape", Some("1")),
    ] {
        let mut path = vec!["binding".to_string(), field.into()];
        path.extend(i.map(String::from));
        out.push(edit_header(&seed.bytes, &path, u64::MAX.into(), true));
    }
    out
}

fn short(v: &Value) -> String {
    let s = v.to_string();
    if s.len() > 40 {
        format!("{}... ({} chars)", &s[..20], s.len())
    } else {
        s
    }
}

/// A mutant with one field of one record edited, its line checksum recomputed or not.
fn record_edit(seed: &[u8], rng: &mut Rng) -> PartCase {
    let mut ls = lines::split(seed);
    let i = 1 + rng.below(ls.len() - 1);
    let text = String::from_utf8(ls[i].clone()).unwrap();
    let mut f: Vec<String> = text
        .trim_end_matches('\n')
        .split('\t')
        .map(str::to_string)
        .collect();
    let j = rng.below(f.len() - 1);
    let old = f[j].clone();
    let whole = |rng: &mut Rng, old: &str| {
        let v: u64 = old.parse().unwrap_or(0);
        rng.pick(&[
            (v + 1).to_string(),
            v.saturating_sub(1).to_string(),
            (v + 2).to_string(),
            "99".into(),
            u64::MAX.to_string(),
            "18446744073709551616".into(),
            "-1".into(),
            "1.0".into(),
            String::new(),
        ])
        .clone()
    };
    let new = match j {
        0..=2 | 7 | 13 => whole(rng, &old),
        3 => {
            let mut s: Vec<String> = Status::ALL.iter().map(|s| s.label().to_string()).collect();
            s.extend(["OK".into(), String::new(), "ok ".into()]);
            rng.pick(&s).clone()
        }
        _ => {
            let v: f64 = old.parse().unwrap_or(1.0);
            rng.pick(&[
                "NaN".to_string(),
                "inf".into(),
                "-inf".into(),
                "-1".into(),
                "0".into(),
                "1e308".into(),
                (v * 2.0).to_string(),
                (v + 1.0).to_string(),
                "-".into(),
                "x".into(),
            ])
            .clone()
        }
    };
    let new = if new == old { format!("{old}0") } else { new };
    f[j] = new.clone();
    let fix = rng.below(2) == 0;
    if fix {
        let body = f[..f.len() - 1].join("\t");
        let last = f.len() - 1;
        f[last] = blake3::hash(body.as_bytes()).to_hex()[..16].to_string();
    }
    ls[i] = format!("{}\n", f.join("\t")).into_bytes();
    // A forged grid cell is the merge's to catch (the layout's checksum); a shard's resume
    // need not.
    let (expect, merge) = match (fix, j) {
        (false, _) | (true, 0) => (Expect::Same, Expect::Same),
        (true, 1 | 2) => (Expect::Any, Expect::Same),
        _ => (Expect::Any, Expect::Any),
    };
    let label = format!(
        "line {} field {j} = {new:?} (was {old:?}){}",
        i + 1,
        if fix {
            ", line checksum recomputed"
        } else {
            ""
        }
    );
    PartCase {
        case: Case::new(Mutant::new(label, lines::join(&ls)), expect),
        merge,
    }
}

/// The failures of one part mutant (written into `scratch`) through the resume and the
/// merge.
pub fn judge(job: &PartJob, seed: &PartSeed, c: &PartCase, scratch: &Path) -> Vec<String> {
    let name = seed.shard.file_name();
    let mut bad = Vec::new();
    // The resume: the mutant in an output directory of its own.
    let out = scratch.join("resume");
    let _ = std::fs::remove_dir_all(&out);
    std::fs::create_dir_all(&out).unwrap();
    let part = out.join(&name);
    std::fs::write(&part, &c.case.bytes).unwrap();
    let r = caught(|| job.run(seed.shard, &out));
    bad.extend(verdict("resume", c.case.expect, &part, r, |_| {
        let mut s = Seen::default();
        match read_part(&part) {
            Err(e) => s.differs = Some(format!("the resumed part is unreadable: {e}")),
            Ok(p) if binding_json(&p.header) != seed.binding => {
                s.differs = Some("the resumed part's binding differs".into())
            }
            Ok(p) if record_lines(&p.records) != seed.own => {
                s.differs = Some("the resumed part's records differ".into())
            }
            Ok(_)
                if seed.shard == Shard::ALL
                    && std::fs::read(out.join("subaps.csv")).ok().as_ref() != Some(&seed.csv) =>
            {
                s.differs = Some("subaps.csv differs".into())
            }
            Ok(_) => {}
        }
        s
    }));
    // The merge: the mutant beside the other shards' parts, into a new directory.
    let dir = scratch.join("parts");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let part = dir.join(&name);
    std::fs::write(&part, &c.case.bytes).unwrap();
    let merged = scratch.join("merged");
    let _ = std::fs::remove_dir_all(&merged);
    let mut parts = vec![part.clone()];
    parts.extend(seed.others.iter().cloned());
    let r = caught(|| merge_into_dir(&parts, &merged, false));
    bad.extend(verdict("merge", c.merge, &part, r, |(m, _)| Seen {
        differs: if binding_json(&m.header) != seed.binding {
            Some("the merged binding differs".into())
        } else if record_lines(&m.records) != seed.all {
            Some("the merged records differ".into())
        } else {
            None
        },
        wrong: None,
    }));
    bad
}

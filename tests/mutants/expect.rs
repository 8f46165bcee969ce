//! What a mutant of an input file may do to an entry point, and the judgement of one outcome
//! against it: a panic, an error that does not name the file, or an Ok that the mutant's
//! meaning forbids is a failure.

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::Path;

use detnoise::Error;

/// The outcomes a mutant allows (besides an error naming the file, always allowed).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Expect {
    /// The mutant keeps the file's meaning in a way the format allows (a byte-order mark, a
    /// reordered table, a torn last line of a part): it must be read, with the seed's result.
    Kept,
    /// The mutant keeps the file's meaning, or breaks it in a way the reader can recover
    /// from (a torn line recomputed): Ok must give the seed's result.
    Same,
    /// The mutant changes the meaning (a value out of range, an edit its checksum does not
    /// cover): Ok is a silent wrong answer.
    Refused,
    /// The mutant may be a valid file of another meaning that nothing can tell from the
    /// seed's (a digit changed in a table, a forged checksum): Ok with any result.
    Any,
}

/// One mutant and what it allows.
pub struct Case {
    /// What was changed.
    pub label: String,
    /// The mutated file.
    pub bytes: Vec<u8>,
    /// What it allows.
    pub expect: Expect,
}

impl Case {
    /// A case from a mutant.
    pub fn new(m: super::Mutant, expect: Expect) -> Case {
        Case {
            label: m.label,
            bytes: m.bytes,
            expect,
        }
    }
}

/// What an Ok result is, against the seed's.
#[derive(Default)]
pub struct Seen {
    /// How it differs from the seed's result (None: the same).
    pub differs: Option<String>,
    /// Why no file may give it at all (e.g. a map of two frames used as one), whatever the
    /// mutant: always a failure.
    pub wrong: Option<String>,
}

/// Run `f`, a panic caught as its message.
pub fn caught<T>(f: impl FnOnce() -> T) -> Result<T, String> {
    catch_unwind(AssertUnwindSafe(f)).map_err(|payload| {
        payload
            .downcast_ref::<String>()
            .cloned()
            .or_else(|| payload.downcast_ref::<&str>().map(|s| s.to_string()))
            .unwrap_or_else(|| "non-string panic".into())
    })
}

/// The failure, if any, of entry point `entry` on the mutant at `path` allowing `expect`:
/// `outcome` is its result (a panic as Err(message)); `seen` judges an Ok result.
pub fn verdict<T>(
    entry: &str,
    expect: Expect,
    path: &Path,
    outcome: Result<Result<T, Error>, String>,
    seen: impl FnOnce(&T) -> Seen,
) -> Option<String> {
    match outcome {
        Err(panic) => Some(format!("{entry}: PANIC: {panic}")),
        Ok(Err(e)) => {
            let text = e.to_string();
            if !text.contains(&path.display().to_string()) {
                Some(format!("{entry}: error does not name the file: {text}"))
            } else if expect == Expect::Kept {
                Some(format!(
                    "{entry}: refused a mutant that keeps the meaning: {text}"
                ))
            } else {
                None
            }
        }
        Ok(Ok(v)) => {
            let s = seen(&v);
            if let Some(w) = s.wrong {
                return Some(format!("{entry}: accepted: {w}"));
            }
            match (expect, s.differs) {
                (Expect::Refused, d) => Some(format!(
                    "{entry}: accepted a mutant that changes the meaning{}",
                    d.map(|d| format!(" ({d})")).unwrap_or_default()
                )),
                (Expect::Same | Expect::Kept, Some(d)) => {
                    Some(format!("{entry}: silent wrong answer: {d}"))
                }
                _ => None,
            }
        }
    }
}

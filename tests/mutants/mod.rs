//! Shared machinery of the hostile-file tests (`tests/mutation.rs`, `tests/hostile_files.rs`):
//! an allocation guard, a seeded generator, small fixtures written from the bundled data,
//! structure-aware mutators for FITS, TIFF and EXR, and the library entry points of
//! `darks`, `emgain` and `fit-pdf` run on one file; and for `tests/mutation_inputs.rs`,
//! mutants of part files, RTS tables, masks and maps with the outcomes each allows.
#![allow(dead_code)]

pub mod alloc;
pub mod bytes;
pub mod expect;
pub mod exr;
pub mod fits;
pub mod fixtures;
pub mod images;
pub mod lines;
pub mod part;
pub mod rts;
pub mod run;
pub mod tiff;

/// SplitMix64: a tiny seeded generator, so the mutants are the same on every run.
pub struct Rng(u64);

impl Rng {
    /// A generator from `seed`.
    pub fn new(seed: u64) -> Rng {
        Rng(seed)
    }

    /// The next 64 random bits.
    pub fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in 0..n (n > 0).
    pub fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }

    /// One element of `xs`.
    pub fn pick<'a, T>(&mut self, xs: &'a [T]) -> &'a T {
        &xs[self.below(xs.len())]
    }

    /// Keep `n` of `items` in a random order (all of them if there are fewer).
    pub fn sample<T>(&mut self, mut items: Vec<T>, n: usize) -> Vec<T> {
        for i in (1..items.len()).rev() {
            let j = self.below(i + 1);
            items.swap(i, j);
        }
        items.truncate(n);
        items
    }
}

/// A mutated file: what was changed, and the bytes.
pub struct Mutant {
    /// Human-readable description of the mutation, e.g. `HDU 2 ZTILE1 = 0`.
    pub label: String,
    /// The mutated file.
    pub bytes: Vec<u8>,
}

impl Mutant {
    /// A mutant from a label and bytes.
    pub fn new(label: impl Into<String>, bytes: Vec<u8>) -> Mutant {
        Mutant {
            label: label.into(),
            bytes,
        }
    }
}

/// Mutations every format gets: truncations and random byte changes, split between the
/// structural part of the file (`head`, e.g. the headers) and the rest.
pub fn generic(seed: &[u8], head: std::ops::Range<usize>, rng: &mut Rng, n: usize) -> Vec<Mutant> {
    let len = seed.len();
    let mut out = Vec::new();
    for _ in 0..n {
        let mut b = seed.to_vec();
        let label = match rng.below(6) {
            0 => {
                let at = rng.below(len);
                b.truncate(at);
                format!("truncated at {at}")
            }
            1 | 2 => {
                let at = head.start + rng.below(head.len().max(1)).min(len - 1 - head.start);
                let bit = rng.below(8);
                b[at] ^= 1 << bit;
                format!("header bit {bit} of byte {at} flipped")
            }
            3 => {
                let k = 1 + rng.below(4);
                let mut at = Vec::new();
                for _ in 0..k {
                    let i = head.start + rng.below(head.len().max(1)).min(len - 1 - head.start);
                    b[i] = rng.next() as u8;
                    at.push(i);
                }
                format!("header bytes {at:?} randomised")
            }
            4 => {
                let at = rng.below(len);
                let run = (1 + rng.below(64)).min(len - at);
                let v = *rng.pick(&[0x00u8, 0xff, 0x7f, 0x80]);
                b[at..at + run].iter_mut().for_each(|x| *x = v);
                format!("{run} bytes at {at} set to {v:#04x}")
            }
            _ => {
                let k = 1 + rng.below(16);
                for _ in 0..k {
                    let i = rng.below(len);
                    b[i] = rng.next() as u8;
                }
                format!("{k} random bytes randomised (seeded)")
            }
        };
        out.push(Mutant::new(label, b));
    }
    out
}

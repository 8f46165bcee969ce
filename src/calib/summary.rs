//! Shared pieces of calibration summaries: distribution figures and input provenance.

use std::path::PathBuf;

use rayon::slice::ParallelSliceMut;
use serde::Serialize;

use crate::error::Result;
pub use crate::io::{checksum_file, Checksum};
use crate::io::{hash_stack_while, ByteTap, FrameStack};
use crate::stats::percentile_sorted as percentile;
use crate::stats::{from_total_order_key, total_order_key};

/// Distribution figures of a map's finite values (in the map's unit).
#[derive(Clone, Debug, Serialize)]
pub struct Distribution {
    /// Number of finite values.
    pub count: usize,
    /// Mean.
    pub mean: f64,
    /// Median.
    pub median: f64,
    /// Root mean square sqrt(mean(x^2)).
    pub rms: f64,
    /// Percentiles 1, 5, 25, 75, 95, 99, 99.9.
    pub p01: f64,
    #[allow(missing_docs)]
    pub p05: f64,
    #[allow(missing_docs)]
    pub p25: f64,
    #[allow(missing_docs)]
    pub p75: f64,
    #[allow(missing_docs)]
    pub p95: f64,
    #[allow(missing_docs)]
    pub p99: f64,
    #[allow(missing_docs)]
    pub p999: f64,
    /// Fraction of values above 3 x the median.
    pub frac_above_3x_median: f64,
}

impl Distribution {
    /// Figures of `values` (non-finite values are skipped).
    pub fn of(values: &[f64]) -> Distribution {
        let v = sorted_finite(values);
        let n = v.len().max(1) as f64;
        let median = percentile(&v, 50.0);
        Distribution {
            count: v.len(),
            mean: v.iter().sum::<f64>() / n,
            median,
            rms: (v.iter().map(|x| x * x).sum::<f64>() / n).sqrt(),
            p01: percentile(&v, 1.0),
            p05: percentile(&v, 5.0),
            p25: percentile(&v, 25.0),
            p75: percentile(&v, 75.0),
            p95: percentile(&v, 95.0),
            p99: percentile(&v, 99.0),
            p999: percentile(&v, 99.9),
            frac_above_3x_median: v.iter().filter(|x| **x > 3.0 * median).count() as f64 / n,
        }
    }
}

/// The finite values of `values` in ascending order (of `f64::total_cmp`, so -0 before +0),
/// sorted as integer keys that order like the values (integer comparisons, not
/// `total_cmp`'s).
fn sorted_finite(values: &[f64]) -> Vec<f64> {
    let mut keys: Vec<u64> = values
        .iter()
        .filter(|x| x.is_finite())
        .map(|&x| total_order_key(x))
        .collect();
    keys.par_sort_unstable();
    keys.into_iter().map(from_total_order_key).collect()
}

/// One input file with its checksum.
#[derive(Clone, Debug, Serialize)]
pub struct InputFile {
    /// Path as given.
    pub path: PathBuf,
    /// BLAKE3 of the file's bytes (hex, as `b3sum` prints it); None unless BLAKE3 was chosen.
    pub blake3: Option<String>,
    /// SHA-256 of the file's bytes (hex, as `sha256sum` prints it); None unless SHA-256 was
    /// chosen.
    pub sha256: Option<String>,
    /// Frames read from it.
    pub frames: usize,
    /// Format.
    pub format: crate::io::StackFormat,
    /// Stored sample type.
    pub sample_type: crate::io::SampleType,
}

/// Input records of a stack's files, with the given `algorithm` digests (one per file, in
/// order).
fn records(
    stack: &FrameStack,
    algorithm: Option<Checksum>,
    digests: impl IntoIterator<Item = Option<String>>,
) -> Vec<InputFile> {
    stack
        .sources
        .iter()
        .zip(digests)
        .map(|(s, digest)| InputFile {
            path: s.path.clone(),
            blake3: digest
                .clone()
                .filter(|_| algorithm == Some(Checksum::Blake3)),
            sha256: digest.filter(|_| algorithm == Some(Checksum::Sha256)),
            frames: s.frames,
            format: s.format,
            sample_type: s.sample_type,
        })
        .collect()
}

/// Input records of every file of a stack with their `algorithm` digests.
pub fn inputs(stack: &FrameStack, algorithm: Checksum) -> Result<Vec<InputFile>> {
    Ok(with_inputs_hashed(stack, algorithm, |_| Ok(()))?.1)
}

/// Input records without checksums.
pub fn unhashed(stack: &FrameStack) -> Vec<InputFile> {
    records(stack, None, std::iter::repeat(None))
}

/// Run `work` while the stack's files are hashed with `algorithm` on another thread; returns
/// both results.
/// `work` may hand the tap to the stack reader
/// ([`read_batches`](crate::io::read_batches)) so that the frames it reads are hashed from
/// memory rather than read twice.
pub fn with_inputs_hashed<T>(
    stack: &FrameStack,
    algorithm: Checksum,
    work: impl FnOnce(&ByteTap) -> Result<T>,
) -> Result<(T, Vec<InputFile>)> {
    let (value, digests) = hash_stack_while(stack, algorithm, work)?;
    Ok((
        value,
        records(stack, Some(algorithm), digests.into_iter().map(Some)),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sorted_keys_give_the_order_of_total_cmp() {
        let mut values = crate::stats::AWKWARD.to_vec();
        values.extend((0..500).map(|i| ((i * 7919) % 1013) as f64 * 0.37 - 150.0));
        let mut want: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
        want.sort_by(f64::total_cmp);
        let got = sorted_finite(&values);
        assert_eq!(
            got.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
            want.iter().map(|x| x.to_bits()).collect::<Vec<_>>()
        );
    }
}

//! Checksums (BLAKE3 by default, or SHA-256) of a stack's files on a thread of their own.
//! Bytes that the stack's reader has read already (raw frames, shared through a [`ByteTap`])
//! are hashed from memory; the rest (headers, padding, files whose frames a decoding library
//! reads) the thread reads itself. Each file is still hashed as one sequence of its bytes, so
//! the digests are those of the files (`b3sum`, `sha256sum`).
//!
//! SHA-256 of one file cannot be split across cores: at ~2 GB/s on one core (SHA-NI) it bounds
//! any calibration that records it. BLAKE3 hashes ~6 GB/s on one core (AVX-512) and keeps the
//! calibration, not the checksum, the bound; hence the default.

use std::fs::File;
use std::os::unix::fs::FileExt;
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{mpsc, Arc};

use serde::Serialize;
use sha2::{Digest, Sha256};

use super::frame::FrameData;
use super::stack::FrameStack;
use super::stream::SharedBatch;
use crate::error::{Error, Result};

/// A checksum algorithm of the inputs' records.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
pub enum Checksum {
    /// BLAKE3 (256-bit, hex; `b3sum` prints the same).
    Blake3,
    /// SHA-256 (hex; `sha256sum` prints the same).
    Sha256,
}

impl Checksum {
    /// The algorithm's name, as the key of its digest in summary.json.
    pub fn label(self) -> &'static str {
        match self {
            Checksum::Blake3 => "blake3",
            Checksum::Sha256 => "sha256",
        }
    }
}

/// A running digest of one algorithm.
enum Hasher {
    Blake3(Box<blake3::Hasher>),
    Sha256(Sha256),
}

impl Hasher {
    fn new(algorithm: Checksum) -> Self {
        match algorithm {
            Checksum::Blake3 => Hasher::Blake3(Box::new(blake3::Hasher::new())),
            Checksum::Sha256 => Hasher::Sha256(Sha256::new()),
        }
    }

    fn update(&mut self, bytes: &[u8]) {
        match self {
            Hasher::Blake3(h) => {
                h.update(bytes);
            }
            Hasher::Sha256(h) => h.update(bytes),
        }
    }

    /// Feed bytes another core has just read (SHA-256 with prefetching, see
    /// [`update_prefetched`]; BLAKE3 streams them fast enough as they are).
    fn update_shared(&mut self, bytes: &[u8]) {
        match self {
            Hasher::Sha256(h) => update_prefetched(h, bytes),
            other => other.update(bytes),
        }
    }

    fn hex(self) -> String {
        match self {
            Hasher::Blake3(h) => h.finalize().to_hex().to_string(),
            Hasher::Sha256(h) => h.finalize().iter().map(|b| format!("{b:02x}")).collect(),
        }
    }
}

/// Bytes read per call where the hashing thread reads a file itself: small enough to stay in
/// the core's L2 cache between the read and the hash.
const READ_CHUNK: usize = 256 << 10;

/// Batches that may wait for the hashing thread before the reader blocks (bounds memory).
const QUEUED_BATCHES: usize = 1;

/// Hands the batches a stack reader has read to the hashing thread of
/// [`hash_stack_while`].
#[derive(Debug)]
pub struct ByteTap {
    tx: mpsc::SyncSender<Arc<SharedBatch>>,
    algorithm: Checksum,
}

impl ByteTap {
    /// Queue `batch` for hashing (waits while the thread is a batch behind). A hashing thread
    /// that has stopped (on an error, reported by [`hash_stack_while`]) is ignored.
    pub(crate) fn send(&self, batch: Arc<SharedBatch>) {
        let _ = self.tx.send(batch);
    }

    /// Whether the hashing keeps a core busy for as long as the reading takes (SHA-256, ~2
    /// GB/s), so that the work should leave it one; BLAKE3 (~6 GB/s) needs a fraction of one.
    pub fn needs_a_core(&self) -> bool {
        self.algorithm == Checksum::Sha256
    }
}

/// Feed `bytes` to `sha`, prefetching a little ahead: the bytes were read by another core,
/// and SHA-256 waits on every cache line it misses (measured: about 1.2 GB/s from memory
/// without the prefetch, 1.9 GB/s with it, as fast as from L1).
fn update_prefetched(sha: &mut Sha256, bytes: &[u8]) {
    const PIECE: usize = 1024;
    const AHEAD: usize = 4096;
    for (i, piece) in bytes.chunks(PIECE).enumerate() {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
            let start = i * PIECE + AHEAD;
            for line in (start..(start + PIECE).min(bytes.len())).step_by(64) {
                // SAFETY: a prefetch is a hint that never faults, and `line` is inside
                // `bytes`.
                unsafe { _mm_prefetch::<_MM_HINT_T0>(bytes.as_ptr().add(line).cast()) };
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = i;
        sha.update(piece);
    }
}

/// The digest of one file in progress: bytes before `pos` are hashed.
struct FileHash<'a> {
    path: &'a Path,
    sha: Hasher,
    pos: u64,
    file: Option<File>,
    done: bool,
}

impl<'a> FileHash<'a> {
    fn new(path: &'a Path, algorithm: Checksum) -> Self {
        FileHash {
            path,
            sha: Hasher::new(algorithm),
            pos: 0,
            file: None,
            done: false,
        }
    }

    /// Read and hash the file's bytes from `pos` up to `end` (to the end of the file when
    /// None), unless `abort` is raised.
    fn read_to(&mut self, end: Option<u64>, buf: &mut [u8], abort: &AtomicBool) -> Result<()> {
        if self.file.is_none() {
            self.file = Some(File::open(self.path).map_err(|e| Error::io(self.path, e))?);
        }
        let file = self.file.as_ref().expect("opened above");
        while end.is_none_or(|e| self.pos < e) && !abort.load(Ordering::Relaxed) {
            let want = end.map_or(buf.len(), |e| buf.len().min((e - self.pos) as usize));
            let n = match file.read_at(&mut buf[..want], self.pos) {
                Ok(0) if end.is_none() => return Ok(()),
                Ok(0) => {
                    let e = std::io::Error::from(std::io::ErrorKind::UnexpectedEof);
                    return Err(Error::io(self.path, e));
                }
                Ok(n) => n,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
                Err(e) => return Err(Error::io(self.path, e)),
            };
            self.sha.update(&buf[..n]);
            self.pos += n as u64;
        }
        Ok(())
    }

    /// Hash `bytes`, found at `offset` in the file, after the bytes before them. Bytes
    /// hashed already (the file was finished from disk) are skipped.
    fn add(&mut self, offset: u64, bytes: &[u8], buf: &mut [u8], abort: &AtomicBool) -> Result<()> {
        if self.done || offset < self.pos {
            return Ok(());
        }
        self.read_to(Some(offset), buf, abort)?;
        self.sha.update_shared(bytes);
        self.pos = offset + bytes.len() as u64;
        Ok(())
    }

    /// Hash the rest of the file.
    fn finish(&mut self, buf: &mut [u8], abort: &AtomicBool) -> Result<()> {
        if !self.done {
            self.read_to(None, buf, abort)?;
            self.done = true;
            self.file = None;
        }
        Ok(())
    }

    fn hex(self) -> String {
        self.sha.hex()
    }
}

/// The `algorithm` digest of a file (hex).
pub fn checksum_file(path: &Path, algorithm: Checksum) -> Result<String> {
    let mut h = FileHash::new(path, algorithm);
    h.finish(&mut vec![0u8; READ_CHUNK], &AtomicBool::new(false))?;
    Ok(h.hex())
}

/// Hash every file of `stack` in order, taking the bytes of raw frames from the batches
/// received; stops early (with an error nobody reports) when `abort` is raised.
fn hash_stack(
    stack: &FrameStack,
    algorithm: Checksum,
    rx: mpsc::Receiver<Arc<SharedBatch>>,
    abort: &AtomicBool,
) -> Result<Vec<String>> {
    let mut files: Vec<FileHash> = stack
        .sources
        .iter()
        .map(|s| FileHash::new(&s.path, algorithm))
        .collect();
    let mut buf = vec![0u8; READ_CHUNK];
    // Files before `next` are hashed completely.
    let mut next = 0;
    for batch in rx {
        for (frame, origin) in batch.frames().iter().zip(batch.origins()) {
            while next < origin.source {
                files[next].finish(&mut buf, abort)?;
                next += 1;
            }
            let file = &mut files[origin.source];
            match (origin.offset, frame) {
                (Some(offset), FrameData::Raw(bytes, _)) => {
                    file.add(offset, bytes, &mut buf, abort)?
                }
                // Decoded by a library: the thread reads the whole file, alongside it.
                _ => file.finish(&mut buf, abort)?,
            }
        }
        if abort.load(Ordering::Relaxed) {
            return Err(Error::Numeric("checksums abandoned".into()));
        }
    }
    for f in &mut files[next..] {
        f.finish(&mut buf, abort)?;
    }
    Ok(files.into_iter().map(FileHash::hex).collect())
}

/// Raises the abort flag when dropped, unless disarmed (an error or a panic of the work
/// stops the hashing thread early).
struct AbortGuard<'a>(&'a AtomicBool, bool);

impl Drop for AbortGuard<'_> {
    fn drop(&mut self) {
        if self.1 {
            self.0.store(true, Ordering::Relaxed);
        }
    }
}

/// Run `work` while every file of `stack` is hashed with `algorithm` on another thread; returns
/// both results, the digest (hex) of each file in `stack.sources` order. `work` may pass the tap to
/// the stack reader ([`read_batches`](super::read_batches)) so that the raw frames it reads
/// are hashed from memory; everything else the thread reads itself. The work's error comes
/// first; the hashing stops early when the work fails.
pub fn hash_stack_while<T>(
    stack: &FrameStack,
    algorithm: Checksum,
    work: impl FnOnce(&ByteTap) -> Result<T>,
) -> Result<(T, Vec<String>)> {
    let abort = AtomicBool::new(false);
    let (tx, rx) = mpsc::sync_channel(QUEUED_BATCHES);
    std::thread::scope(|s| {
        let hasher = std::thread::Builder::new()
            .name(format!("detnoise-{}", algorithm.label()))
            .spawn_scoped(s, || hash_stack(stack, algorithm, rx, &abort))
            .map_err(|e| Error::Numeric(format!("cannot start the hashing thread: {e}")))?;
        let mut guard = AbortGuard(&abort, true);
        let tap = ByteTap { tx, algorithm };
        let result = work(&tap);
        // Closing the tap tells the thread that no more batches come.
        drop(tap);
        guard.1 = result.is_err();
        drop(guard);
        let hashes = hasher
            .join()
            .map_err(|_| Error::Numeric("hashing thread panicked".into()));
        let value = result?;
        Ok((value, hashes??))
    })
}

/// The `algorithm` digest of a file's bytes in one call of the hash crates' own one-shot
/// functions, independent of this module's streaming: the reference of the tests.
#[cfg(test)]
pub(crate) fn one_shot_digest(path: &Path, algorithm: Checksum) -> String {
    let bytes = std::fs::read(path).expect("a readable test file");
    match algorithm {
        Checksum::Sha256 => format!("{:x}", Sha256::digest(bytes)),
        Checksum::Blake3 => blake3::hash(&bytes).to_hex().to_string(),
    }
}

#[cfg(test)]
mod tests;

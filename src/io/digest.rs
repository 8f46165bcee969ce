//! Checksums (BLAKE3 by default, or SHA-256) of a stack's files on a thread of their own.
//! Bytes that the stack's reader has read already (raw frames, shared through a [`ByteTap`])
//! are hashed from memory; the rest (headers, padding, files whose frames a decoding library
//! reads) the thread reads itself. With BLAKE3 the reading thread hashes each raw frame it
//! has just read itself, while the bytes are in its core's cache (the thread then skips
//! them): on the 1 GiB benchmark cube that took ~0.1 CPU-s less than hashing the batches
//! from memory on the thread. Each file is still hashed as one sequence of its bytes, under
//! one lock, so the digests are those of the files (`b3sum`, `sha256sum`).
//!
//! SHA-256 of one file cannot be split across cores: at ~2 GB/s on one core (SHA-NI) it bounds
//! any calibration that records it. BLAKE3 hashes ~6 GB/s on one core (AVX-512) and keeps the
//! calibration, not the checksum, the bound; hence the default.

use std::fs::File;
use std::os::unix::fs::FileExt;
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{mpsc, Arc, Mutex};

use serde::Serialize;
use sha2::{Digest, Sha256};

use super::frame::{FrameData, FrameOrigin};
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

/// Hands the frames a stack reader has read to the hashing of [`hash_stack_while`]: each
/// batch to its thread, and with BLAKE3 each frame, as soon as it is read, to the reading
/// thread's own hash (`ByteTap::hash_read_frame`).
pub struct ByteTap<'t, 's> {
    tx: mpsc::SyncSender<Arc<SharedBatch>>,
    algorithm: Checksum,
    state: &'t Mutex<StackHash<'s>>,
    abort: &'t AtomicBool,
}

impl std::fmt::Debug for ByteTap<'_, '_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ByteTap")
            .field("algorithm", &self.algorithm)
            .finish_non_exhaustive()
    }
}

impl ByteTap<'_, '_> {
    /// Queue `batch` for hashing (waits while the thread is a batch behind). A hashing thread
    /// that has stopped (on an error, reported by [`hash_stack_while`]) is ignored.
    pub(crate) fn send(&self, batch: Arc<SharedBatch>) {
        let _ = self.tx.send(batch);
    }

    /// Hash `frame` (from `origin`) on the calling thread, the reader's, right after reading
    /// it, while its bytes are in this core's cache (BLAKE3, ~6 GB/s: a fraction of the
    /// reading's time; SHA-256 keeps a core of its own). Skipped, and left to the hashing
    /// thread, when the frame is not stored bytes or its file is not hashed up to a header's
    /// distance before it; a failure here is left to the thread to meet and report.
    pub(crate) fn hash_read_frame(&self, origin: &FrameOrigin, frame: &FrameData) {
        if self.algorithm != Checksum::Blake3 || !is_stored(origin, frame) {
            return;
        }
        // The thread holds the state for one frame at a time (or, rarely, for a file with
        // stored and library-decoded frames both, the file).
        if let Ok(mut state) = self.state.lock() {
            state.inline(origin, frame, self.abort);
        }
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
    /// The file's length, looked up once (by [`FileHash::left`]).
    len: Option<u64>,
}

impl<'a> FileHash<'a> {
    fn new(path: &'a Path, algorithm: Checksum) -> Self {
        FileHash {
            path,
            sha: Hasher::new(algorithm),
            pos: 0,
            file: None,
            done: false,
            len: None,
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

    /// Bytes of the file not hashed yet (unknown, taken as all, when it cannot be read). The
    /// length is looked up once: the reader asks for every frame while the file is unfinished.
    fn left(&mut self) -> u64 {
        if self.done {
            return 0;
        }
        let path = self.path;
        let len = *self
            .len
            .get_or_insert_with(|| std::fs::metadata(path).map_or(u64::MAX, |m| m.len()));
        len.saturating_sub(self.pos)
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

/// The digests of a stack's files in progress, shared by the hashing thread and the reader.
pub(crate) struct StackHash<'a> {
    files: Vec<FileHash<'a>>,
    /// Files before `next` are hashed completely.
    next: usize,
    buf: Vec<u8>,
}

/// Most bytes of a file before a frame that the reader reads and hashes itself to hash the
/// frame inline (a FITS header; the frame before, not yet hashed, is left to the thread).
const INLINE_GAP: u64 = 1 << 16;

impl<'a> StackHash<'a> {
    fn new(stack: &'a FrameStack, algorithm: Checksum) -> Self {
        StackHash {
            files: stack
                .sources
                .iter()
                .map(|s| FileHash::new(&s.path, algorithm))
                .collect(),
            next: 0,
            buf: vec![0u8; READ_CHUNK],
        }
    }

    /// Hash `frame` from `origin` after every file before its own and the bytes before it:
    /// stored bytes from memory, a frame decoded by a library by reading its whole file.
    fn add(&mut self, origin: &FrameOrigin, frame: &FrameData, abort: &AtomicBool) -> Result<()> {
        while self.next < origin.source {
            self.files[self.next].finish(&mut self.buf, abort)?;
            self.next += 1;
        }
        let file = &mut self.files[origin.source];
        match (origin.offset, frame) {
            (Some(offset), FrameData::Raw(bytes, _)) => {
                file.add(offset, bytes, &mut self.buf, abort)
            }
            // Decoded by a library: the whole file is read, alongside it.
            _ => file.finish(&mut self.buf, abort),
        }
    }

    /// [`Self::add`] for a frame the reader has just read, when it is stored bytes that follow
    /// what its file has hashed within [`INLINE_GAP`] bytes (errors are left to `add`).
    fn inline(&mut self, origin: &FrameOrigin, frame: &FrameData, abort: &AtomicBool) {
        let (Some(offset), true) = (origin.offset, is_stored(origin, frame)) else {
            return;
        };
        let file = &self.files[origin.source];
        let near = !file.done && offset >= file.pos && offset - file.pos <= INLINE_GAP;
        // The files before it must be finished first: inline only when little of them is left
        // (a raw FITS file's padding after its last frame).
        if near
            && self.files[self.next..origin.source]
                .iter_mut()
                .all(|f| f.left() <= INLINE_GAP)
        {
            let _ = self.add(origin, frame, abort);
        }
    }

    /// Hash what is left of every file; the digests (hex), in stack order.
    fn finish(mut self, abort: &AtomicBool) -> Result<Vec<String>> {
        for f in &mut self.files[self.next..] {
            f.finish(&mut self.buf, abort)?;
        }
        Ok(self.files.into_iter().map(FileHash::hex).collect())
    }
}

/// The error of a checksum state left by a thread that panicked while holding it.
fn poisoned() -> Error {
    Error::Numeric("the checksum state was poisoned (a hashing thread panicked)".into())
}

/// Whether `frame` is a file's stored bytes (at a known offset), which can be hashed from
/// memory.
fn is_stored(origin: &FrameOrigin, frame: &FrameData) -> bool {
    origin.offset.is_some() && matches!(frame, FrameData::Raw(..))
}

/// Hash every file of the stack in order, taking the bytes of raw frames from the batches
/// received (those the reader has not hashed); stops early (with an error nobody reports)
/// when `abort` is raised.
fn hash_stack(
    state: &Mutex<StackHash>,
    rx: mpsc::Receiver<Arc<SharedBatch>>,
    abort: &AtomicBool,
) -> Result<()> {
    for batch in rx {
        for (frame, origin) in batch.frames().iter().zip(batch.origins()) {
            state
                .lock()
                .map_err(|_| poisoned())?
                .add(origin, frame, abort)?;
        }
        if abort.load(Ordering::Relaxed) {
            return Err(Error::Numeric("checksums abandoned".into()));
        }
    }
    Ok(())
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
    let state = Mutex::new(StackHash::new(stack, algorithm));
    let (tx, rx) = mpsc::sync_channel(QUEUED_BATCHES);
    let result = std::thread::scope(|s| {
        let hasher = std::thread::Builder::new()
            .name(format!("detnoise-{}", algorithm.label()))
            .spawn_scoped(s, || hash_stack(&state, rx, &abort))
            .map_err(|e| Error::Numeric(format!("cannot start the hashing thread: {e}")))?;
        let mut guard = AbortGuard(&abort, true);
        let tap = ByteTap {
            tx,
            algorithm,
            state: &state,
            abort: &abort,
        };
        let result = work(&tap);
        // Closing the tap tells the thread that no more batches come.
        drop(tap);
        guard.1 = result.is_err();
        drop(guard);
        let hashed = hasher
            .join()
            .map_err(|_| Error::Numeric("hashing thread panicked".into()));
        let value = result?;
        hashed??;
        Ok(value)
    })?;
    let state = state.into_inner().map_err(|_| poisoned())?;
    Ok((result, state.finish(&abort)?))
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

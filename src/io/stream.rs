//! A stack's frames read on a thread of their own, a batch at a time, while the caller uses
//! the previous batch. Frames can be handed to the checksums (a [`ByteTap`]): each one as it
//! is read (hashed by the reading thread, BLAKE3) and each batch (to the checksum thread), so
//! the bytes read for the statistics are hashed from memory instead of read again; a batch's
//! buffers return to a pool when the last user drops it, so no frame buffer is allocated
//! (and faulted in) per frame.

use std::ops::Deref;
use std::sync::{mpsc, Arc, Mutex};

use super::digest::ByteTap;
use super::frame::{FrameData, FrameOrigin};
use super::stack::FrameStack;
use crate::error::{Error, Result};

/// Bytes read per batch of frames delivered as values (8 per value). A batch is one sweep
/// of the caller over its per-pixel accumulators, so bigger batches move less accumulator
/// state through the caches; a few batches are in flight at once (being read, used and
/// hashed), which bounds the memory at about four times this.
pub const BATCH_BYTES: usize = 8 << 20;

/// Bytes read per batch of frames delivered as stored bytes (integers). Half of
/// [`BATCH_BYTES`]: the dark statistics of 512 x 512 uint16 frames (1 GiB, page cache, AMD
/// Zen 4 with 32 MiB of L3) took 4-8 % less wall time with 8 frames per batch than with 16
/// (the per-pixel sums, 21 MB when measured and 16 MB since, and the batches being read and
/// used then fit in L3, and the reading thread's copy from the page cache slowed less), the
/// same with 12, 30 % more with 4 (medians of 8-10 alternated runs).
pub const RAW_BATCH_BYTES: usize = 4 << 20;

/// Most frames per batch (small frames).
pub const MAX_BATCH: usize = 32;

/// Frames read together, in stack order, with their origins.
#[derive(Debug, Default)]
pub struct FrameBatch {
    /// Frame buffers; the first `origins.len()` hold this batch (the rest are spare).
    frames: Vec<FrameData>,
    origins: Vec<FrameOrigin>,
}

impl FrameBatch {
    /// The frames of the batch.
    pub fn frames(&self) -> &[FrameData] {
        &self.frames[..self.origins.len()]
    }

    /// Where each frame came from.
    pub fn origins(&self) -> &[FrameOrigin] {
        &self.origins
    }

    /// Number of frames.
    pub fn len(&self) -> usize {
        self.origins.len()
    }

    /// Whether the batch holds no frame.
    pub fn is_empty(&self) -> bool {
        self.origins.is_empty()
    }
}

/// Batches whose users have all finished, ready to be filled again.
type Pool = Arc<Mutex<Vec<FrameBatch>>>;

/// A batch shared between the caller and the checksum thread; it goes back to its pool when
/// the last holder drops it.
#[derive(Debug)]
pub struct SharedBatch {
    batch: FrameBatch,
    pool: Pool,
}

impl Deref for SharedBatch {
    type Target = FrameBatch;

    fn deref(&self) -> &FrameBatch {
        &self.batch
    }
}

impl Drop for SharedBatch {
    fn drop(&mut self) {
        if let Ok(mut free) = self.pool.lock() {
            free.push(std::mem::take(&mut self.batch));
        }
    }
}

/// Frames per batch for frames like `f`.
fn batch_frames(f: &FrameData) -> usize {
    let (budget, bytes) = match f {
        FrameData::Values(v) => (BATCH_BYTES, v.len() * 8),
        FrameData::Raw(b, _) => (RAW_BATCH_BYTES, b.len()),
    };
    (budget / bytes.max(1)).clamp(2, MAX_BATCH)
}

/// Fill `batch` with the next frames of `reader`, each offered to `tap` as it is read;
/// returns the number read (0 at the end).
fn fill(
    reader: &mut super::StackReader<'_>,
    batch: &mut FrameBatch,
    tap: Option<&ByteTap>,
) -> Result<usize> {
    batch.origins.clear();
    let mut want = MAX_BATCH;
    while batch.origins.len() < want {
        let i = batch.origins.len();
        if batch.frames.len() <= i {
            batch.frames.push(FrameData::Values(Vec::new()));
        }
        match reader.next_frame_data(&mut batch.frames[i])? {
            Some(origin) => {
                if let Some(tap) = tap {
                    tap.hash_read_frame(&origin, &batch.frames[i]);
                }
                batch.origins.push(origin)
            }
            None => break,
        }
        if i == 0 {
            want = batch_frames(&batch.frames[0]);
        }
    }
    Ok(batch.origins.len())
}

/// Run `consume` on the frames of `stack` in order, a batch at a time, read on a separate
/// thread (one batch is read while the previous one is used). With a `tap`, every batch is
/// also handed to the checksum thread. Stops at the first error of either side.
pub fn read_batches(
    stack: &FrameStack,
    tap: Option<&ByteTap>,
    mut consume: impl FnMut(&FrameBatch) -> Result<()>,
) -> Result<()> {
    let pool: Pool = Arc::default();
    let (tx, rx) = mpsc::sync_channel::<Result<Arc<SharedBatch>>>(0);
    std::thread::scope(|s| {
        let reader_pool = pool.clone();
        let reader = std::thread::Builder::new().name("detnoise-read".into());
        let spawned = reader.spawn_scoped(s, move || {
            let mut reader = stack.reader();
            loop {
                let free = reader_pool.lock().ok().and_then(|mut p| p.pop());
                let mut batch = free.unwrap_or_default();
                match fill(&mut reader, &mut batch, tap) {
                    Err(e) => {
                        let _ = tx.send(Err(e));
                        return;
                    }
                    Ok(0) => return,
                    Ok(_) => {}
                }
                let shared = Arc::new(SharedBatch {
                    batch,
                    pool: reader_pool.clone(),
                });
                if tx.send(Ok(shared.clone())).is_err() {
                    return;
                }
                if let Some(tap) = tap {
                    tap.send(shared);
                }
            }
        });
        if let Err(e) = spawned {
            return Err(Error::Numeric(format!(
                "cannot start the reading thread: {e}"
            )));
        }
        // Returning (at the end or on an error) drops `rx`, which stops the reader.
        for msg in rx {
            let batch = msg?;
            consume(&batch)?;
        }
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::RawKind;

    #[test]
    fn batches_hold_a_few_megabytes_of_frames() {
        // 512 x 512 uint16 frames (512 KiB stored): 8 per batch; as f64 values (2 MiB): 4;
        // frames bigger than a batch still go two at a time; tiny frames: at most MAX_BATCH.
        assert_eq!((BATCH_BYTES, RAW_BATCH_BYTES), (8 << 20, 4 << 20));
        let layout = crate::io::RawLayout {
            kind: RawKind::I16,
            big_endian: true,
            scale: 1.0,
            zero: 32768.0,
        };
        let raw = |n: usize| FrameData::Raw(vec![0; n], layout);
        let values = |n: usize| FrameData::Values(vec![0.0; n]);
        assert_eq!(batch_frames(&raw(512 * 512 * 2)), 8);
        assert_eq!(batch_frames(&values(512 * 512)), 4);
        assert_eq!(batch_frames(&raw(64 << 20)), 2);
        assert_eq!(batch_frames(&values(16 << 20)), 2);
        assert_eq!(batch_frames(&raw(64 * 64 * 2)), MAX_BATCH);
        assert_eq!(batch_frames(&values(64 * 64)), MAX_BATCH);
    }

    #[test]
    fn a_shared_batch_returns_to_its_pool_when_the_last_holder_drops_it() {
        let pool: Pool = Arc::default();
        let shared = Arc::new(SharedBatch {
            batch: FrameBatch {
                frames: vec![FrameData::Values(vec![1.0; 4])],
                origins: vec![FrameOrigin {
                    index: 0,
                    source: 0,
                    offset: None,
                }],
            },
            pool: pool.clone(),
        });
        let other = shared.clone();
        drop(shared);
        assert!(pool.lock().unwrap().is_empty());
        assert_eq!(other.len(), 1);
        drop(other);
        let free = pool.lock().unwrap();
        assert_eq!(free.len(), 1);
        // The buffer comes back with its capacity, ready to be refilled.
        assert!(matches!(&free[0].frames[0], FrameData::Values(v) if v.len() == 4));
    }
}

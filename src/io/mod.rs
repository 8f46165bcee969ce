//! Frame stacks: sequences of 2-D frames of one shape read one frame at a time from FITS,
//! TIFF or OpenEXR files, given as files, directories or glob patterns; and the writers of
//! stacks and FITS images.
//!
//! Memory is O(frame): a [`StackReader`] holds one open file and the caller's frame buffer.
//! Orientation is rows x columns as the file stores them (FITS NAXIS1 is the column count).
//!
//! Layout: `inputs` expands stack arguments to files, `format` detects a file's format,
//! `file` dispatches to the format's reader (`fits`, `tiff`, `exr`), `stack` checks that the
//! files form one stack, `reader` reads its frames in order as `frame` data, `stream` reads
//! them in batches on a thread of their own and `digest` hashes the stack's files (taking
//! the bytes `stream` has read from memory); `checks` holds the limits and the errors naming
//! file and frame.

mod checks;
mod digest;
pub mod exr;
mod file;
pub mod fits;
mod format;
mod frame;
mod inputs;
mod reader;
mod stack;
mod stream;
pub mod tiff;

pub use checks::{name_file, MAX_EXPANSION, MAX_SAMPLE_ABS};
#[cfg(test)]
pub(crate) use digest::one_shot_digest;
pub use digest::{checksum_file, hash_stack_while, ByteTap, Checksum};
pub use file::{read_image, Image, SourceFile};
pub use format::{SampleType, StackFormat};
pub(crate) use frame::widest;
pub use frame::{FrameData, FrameOrigin, RawKind, RawLayout};
pub use inputs::expand_inputs;
pub use reader::StackReader;
#[cfg(test)]
pub(crate) use stack::named_as_truth_map;
pub use stack::{check_distinct, FrameStack};
pub use stream::{read_batches, FrameBatch};

//! Sequential reading of a stack's frames, one file open at a time: decoded values, or raw
//! integer bytes when the file stores plain integers.

use super::checks::{add_stack_frame, check_samples, prefix_frame};
use super::file::open_file;
use super::frame::{FileFrames, FrameData, FrameOrigin};
use super::stack::FrameStack;
use crate::error::Result;
use std::borrow::Cow;

impl FrameStack {
    /// A sequential reader over all frames.
    pub fn reader(&self) -> StackReader<'_> {
        StackReader::over(Cow::Borrowed(self))
    }

    /// A sequential reader that owns the stack (for a caller that keeps the reader alone,
    /// e.g. a Python iterator over the frames).
    pub fn into_reader(self) -> StackReader<'static> {
        StackReader::over(Cow::Owned(self))
    }
}

impl<'a> StackReader<'a> {
    fn over(stack: Cow<'a, FrameStack>) -> Self {
        StackReader {
            stack,
            file_index: 0,
            local: 0,
            global: 0,
            open: None,
        }
    }
}

/// Sequential reader over the frames of a [`FrameStack`]; holds at most one open file.
pub struct StackReader<'a> {
    stack: Cow<'a, FrameStack>,
    file_index: usize,
    local: usize,
    global: usize,
    open: Option<Box<dyn FileFrames>>,
}

impl StackReader<'_> {
    /// The stack being read.
    pub fn stack(&self) -> &FrameStack {
        &self.stack
    }

    /// Read the next frame into `slot`, as stored integer bytes when the file allows it
    /// (reusing the slot's buffers), else as values. Returns where the frame came from, or
    /// None at the end.
    pub fn next_frame_data(&mut self, slot: &mut FrameData) -> Result<Option<FrameOrigin>> {
        self.skip_finished_files();
        let Some(src) = self.stack.sources.get(self.file_index) else {
            return Ok(None);
        };
        if self.open.is_none() {
            self.open = Some(open_file(src)?);
        }
        let reader = self.open.as_mut().expect("opened above");
        if let Some(layout) = reader.raw_layout(self.local) {
            let mut bytes = match std::mem::replace(slot, FrameData::Values(Vec::new())) {
                FrameData::Raw(b, _) => b,
                FrameData::Values(_) => Vec::new(),
            };
            bytes.resize(self.stack.pixels() * layout.width(), 0);
            let offset = reader
                .read_raw(self.local, &mut bytes)
                .map_err(|e| add_stack_frame(e, self.global))?;
            *slot = FrameData::Raw(bytes, layout);
            let origin = FrameOrigin {
                index: self.global,
                source: self.file_index,
                offset: Some(offset),
            };
            self.local += 1;
            self.global += 1;
            return Ok(Some(origin));
        }
        let mut values = match std::mem::replace(slot, FrameData::Values(Vec::new())) {
            FrameData::Values(v) => v,
            FrameData::Raw(..) => Vec::new(),
        };
        values.resize(self.stack.pixels(), 0.0);
        let source = self.file_index;
        let r = self.next_frame(&mut values);
        *slot = FrameData::Values(values);
        Ok(r?.map(|index| FrameOrigin {
            index,
            source,
            offset: None,
        }))
    }

    fn skip_finished_files(&mut self) {
        while self.file_index < self.stack.sources.len()
            && self.local >= self.stack.sources[self.file_index].frames
        {
            self.file_index += 1;
            self.local = 0;
            self.open = None;
        }
    }

    /// Read the next frame into `out` (rows*cols f64, row-major). Returns the stack frame
    /// index, or None at the end. Non-finite samples are an error naming file and frame.
    pub fn next_frame(&mut self, out: &mut [f64]) -> Result<Option<usize>> {
        self.skip_finished_files();
        let Some(src) = self.stack.sources.get(self.file_index) else {
            return Ok(None);
        };
        assert_eq!(
            out.len(),
            self.stack.pixels(),
            "frame buffer has the wrong length"
        );
        if self.open.is_none() {
            self.open = Some(open_file(src)?);
        }
        let reader = self.open.as_mut().expect("opened above");
        reader
            .read_frame(self.local, out)
            .map_err(|e| add_stack_frame(e, self.global))?;
        if reader.may_be_out_of_range(self.local) {
            check_samples(&src.path, src.shape.1, out, false)
                .map_err(|e| add_stack_frame(prefix_frame(e, self.local), self.global))?;
        }
        let k = self.global;
        self.local += 1;
        self.global += 1;
        Ok(Some(k))
    }
}

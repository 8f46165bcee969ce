//! Reading and writing integers of either byte order in a buffer, and interesting values.

/// Read an unsigned integer of `width` bytes (1, 2, 4, 8) at `at`.
pub fn get(b: &[u8], at: usize, width: usize, big: bool) -> Option<u64> {
    let s = b.get(at..at + width)?;
    let mut v = 0u64;
    for i in 0..width {
        let byte = if big { s[i] } else { s[width - 1 - i] };
        v = (v << 8) | byte as u64;
    }
    Some(v)
}

/// Write the low `width` bytes of `v` at `at` (ignored past the end).
pub fn put(b: &mut [u8], at: usize, width: usize, big: bool, v: u64) {
    if at + width > b.len() {
        return;
    }
    for i in 0..width {
        let shift = 8 * if big { width - 1 - i } else { i };
        b[at + i] = (v >> shift) as u8;
    }
}

/// Values that break size arithmetic: zero, one, powers of two and their neighbours, the
/// limits of each width, and sizes around the file length `len`.
pub fn interesting(len: u64) -> Vec<u64> {
    let mut v = vec![
        0,
        1,
        2,
        3,
        7,
        8,
        15,
        16,
        17,
        255,
        256,
        0x7fff,
        0xffff,
        0x1_0000,
        1 << 24,
        0x7fff_ffff,
        0x8000_0000,
        0xffff_ffff,
        1 << 40,
        (1 << 63) - 1,
        u64::MAX,
    ];
    v.extend([len.saturating_sub(1), len, len + 1, len / 2]);
    v
}

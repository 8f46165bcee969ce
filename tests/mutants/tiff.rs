//! Structure-aware TIFF / BigTIFF mutants: IFD entries (ImageWidth/Length, BitsPerSample,
//! Compression, SampleFormat, StripOffsets/ByteCounts, RowsPerStrip, tiles ...) given other
//! values, counts, types and tags; IFD counts and next-IFD links (cycles, past the end);
//! ImageJ frame counts; truncation and byte flips.

use super::bytes::{get, interesting, put};
use super::{generic, Mutant, Rng};

/// Tags whose entries are mutated.
const TAGS: [u16; 17] = [
    256, // ImageWidth
    257, // ImageLength
    258, // BitsPerSample
    259, // Compression
    262, // PhotometricInterpretation
    270, // ImageDescription
    273, // StripOffsets
    277, // SamplesPerPixel
    278, // RowsPerStrip
    279, // StripByteCounts
    284, // PlanarConfiguration
    317, // Predictor
    322, // TileWidth
    323, // TileLength
    324, // TileOffsets
    325, // TileByteCounts
    339, // SampleFormat
];

/// Layout of a TIFF file: byte order, BigTIFF, and its IFDs.
pub struct Layout {
    /// Big-endian ("MM").
    pub big: bool,
    /// BigTIFF (8-byte offsets).
    pub bigtiff: bool,
    /// Offset of each IFD.
    pub ifds: Vec<usize>,
}

/// One IFD entry.
pub struct Entry {
    /// Offset of the entry.
    pub at: usize,
    /// Tag.
    pub tag: u16,
    /// Field type.
    pub typ: u16,
    /// Value count.
    pub count: u64,
}

impl Layout {
    fn off(&self) -> usize {
        if self.bigtiff {
            8
        } else {
            4
        }
    }

    fn count_width(&self) -> usize {
        if self.bigtiff {
            8
        } else {
            2
        }
    }

    fn entry_len(&self) -> usize {
        if self.bigtiff {
            20
        } else {
            12
        }
    }

    /// Entries of the IFD at `ifd`.
    pub fn entries(&self, b: &[u8], ifd: usize) -> Vec<Entry> {
        let n = get(b, ifd, self.count_width(), self.big).unwrap_or(0) as usize;
        (0..n.min(4096))
            .map(|i| ifd + self.count_width() + i * self.entry_len())
            .filter_map(|at| {
                Some(Entry {
                    at,
                    tag: get(b, at, 2, self.big)? as u16,
                    typ: get(b, at + 2, 2, self.big)? as u16,
                    count: get(b, at + 4, self.off(), self.big)?,
                })
            })
            .collect()
    }

    /// Offset of the next-IFD link of the IFD at `ifd`.
    pub fn next_link(&self, b: &[u8], ifd: usize) -> usize {
        let n = get(b, ifd, self.count_width(), self.big).unwrap_or(0) as usize;
        ifd + self.count_width() + n * self.entry_len()
    }

    /// Offset of the value (or value offset) field of an entry.
    pub fn value_at(&self, e: &Entry) -> usize {
        e.at + 4 + self.off()
    }

    /// Size in bytes of one value of a field type.
    pub fn type_size(typ: u16) -> usize {
        match typ {
            1 | 2 | 6 | 7 => 1,
            3 | 8 => 2,
            4 | 9 | 11 | 13 => 4,
            5 | 10 | 12 | 16 | 17 | 18 => 8,
            _ => 1,
        }
    }

    /// Whether the entry's values are stored in the entry itself.
    pub fn inline(&self, e: &Entry) -> bool {
        (e.count as usize).saturating_mul(Self::type_size(e.typ)) <= self.off()
    }
}

/// The layout of a well-formed TIFF file (at most 64 IFDs).
pub fn parse(b: &[u8]) -> Layout {
    let big = b.starts_with(b"MM");
    let bigtiff = get(b, 2, 2, big) == Some(43);
    let mut l = Layout {
        big,
        bigtiff,
        ifds: Vec::new(),
    };
    let mut ifd = get(b, if bigtiff { 8 } else { 4 }, l.off(), big).unwrap_or(0) as usize;
    while ifd != 0 && ifd < b.len() && l.ifds.len() < 64 && !l.ifds.contains(&ifd) {
        l.ifds.push(ifd);
        let link = l.next_link(b, ifd);
        ifd = get(b, link, l.off(), big).unwrap_or(0) as usize;
    }
    l
}

/// Entry-level and IFD-level mutants (see the module documentation).
pub fn structural(seed: &[u8]) -> Vec<Mutant> {
    let l = parse(seed);
    let len = seed.len() as u64;
    let values = interesting(len);
    let mut out = Vec::new();
    for (k, &ifd) in l.ifds.iter().enumerate() {
        for e in l.entries(seed, ifd) {
            if !TAGS.contains(&e.tag) {
                continue;
            }
            let tag = e.tag;
            let va = l.value_at(&e);
            if l.inline(&e) {
                let w = Layout::type_size(e.typ).min(l.off()).max(1);
                for v in &values {
                    let mut b = seed.to_vec();
                    put(&mut b, va, w, l.big, *v);
                    out.push(Mutant::new(format!("IFD {k} tag {tag} value = {v}"), b));
                }
            } else {
                let w = Layout::type_size(e.typ);
                let ptr = get(seed, va, l.off(), l.big).unwrap_or(0) as usize;
                for v in &values {
                    let mut b = seed.to_vec();
                    put(&mut b, va, l.off(), l.big, *v);
                    out.push(Mutant::new(
                        format!("IFD {k} tag {tag} value offset = {v}"),
                        b,
                    ));
                    for (which, at) in [("first", ptr), ("last", ptr + (e.count as usize - 1) * w)]
                    {
                        let mut b = seed.to_vec();
                        put(&mut b, at, w, l.big, *v);
                        out.push(Mutant::new(
                            format!("IFD {k} tag {tag} {which} value = {v}"),
                            b,
                        ));
                    }
                }
                if tag == 270 {
                    out.extend(imagej_counts(seed, ptr, e.count as usize, k));
                }
            }
            for c in [0u64, 1, 2, 0xffff, 0xffff_ffff, u64::MAX] {
                let mut b = seed.to_vec();
                put(&mut b, e.at + 4, l.off(), l.big, c);
                out.push(Mutant::new(format!("IFD {k} tag {tag} count = {c}"), b));
            }
            for t in [0u16, 1, 2, 3, 4, 5, 7, 11, 12, 13, 16, 17, 99] {
                let mut b = seed.to_vec();
                put(&mut b, e.at + 2, 2, l.big, t as u64);
                out.push(Mutant::new(format!("IFD {k} tag {tag} type = {t}"), b));
            }
            for t in [0u16, 256, 257, 273, 279, 324, 339, 0xffff] {
                let mut b = seed.to_vec();
                put(&mut b, e.at, 2, l.big, t as u64);
                out.push(Mutant::new(format!("IFD {k} tag {tag} renamed {t}"), b));
            }
        }
        let cw = l.count_width();
        for c in [0u64, 1, 0xffff] {
            let mut b = seed.to_vec();
            put(&mut b, ifd, cw, l.big, c);
            out.push(Mutant::new(format!("IFD {k} entry count = {c}"), b));
        }
        let link = l.next_link(seed, ifd);
        for (what, v) in [
            ("itself", ifd as u64),
            ("the first IFD", l.ifds[0] as u64),
            ("the file end", len),
            ("one byte before the end", len - 1),
            ("2^32-1", 0xffff_ffff),
            ("odd offset 1", 1),
        ] {
            let mut b = seed.to_vec();
            put(&mut b, link, l.off(), l.big, v);
            out.push(Mutant::new(format!("IFD {k} next link = {what}"), b));
        }
        for cut in [ifd, ifd + 2, link, link + l.off()] {
            if cut > 0 && (cut as u64) < len {
                out.push(Mutant::new(
                    format!("truncated at {cut} (IFD {k})"),
                    seed[..cut].to_vec(),
                ));
            }
        }
    }
    let mut b = seed.to_vec();
    b[..2].copy_from_slice(if l.big { b"II" } else { b"MM" });
    out.push(Mutant::new("byte order swapped", b));
    let mut b = seed.to_vec();
    put(&mut b, 2, 2, l.big, if l.bigtiff { 42 } else { 43 });
    out.push(Mutant::new("TIFF and BigTIFF magic swapped", b));
    out
}

/// ImageJ descriptions claiming other frame counts (written over the same bytes).
fn imagej_counts(seed: &[u8], at: usize, n: usize, k: usize) -> Vec<Mutant> {
    let Some(desc) = seed.get(at..at + n) else {
        return vec![];
    };
    let Some(i) = desc.windows(7).position(|w| w == b"images=") else {
        return vec![];
    };
    let start = at + i + 7;
    let room = desc[i + 7..].iter().take_while(|c| **c != 0).count();
    ["0", "1", "99999999999", "-5", "18446744073709551615", "x"]
        .iter()
        .filter(|v| v.len() <= room)
        .map(|v| {
            let mut b = seed.to_vec();
            b[start..start + room].fill(b'\n');
            b[start..start + v.len()].copy_from_slice(v.as_bytes());
            Mutant::new(format!("IFD {k} ImageJ images={v}"), b)
        })
        .collect()
}

/// `n` mutants of the TIFF file `seed`: a sample of the structural ones plus random
/// truncations and byte changes (a quarter), the latter mostly in the IFDs.
pub fn mutants(seed: &[u8], rng: &mut Rng, n: usize) -> Vec<Mutant> {
    let l = parse(seed);
    let lo = l.ifds.iter().copied().min().unwrap_or(0);
    let hi = l
        .ifds
        .iter()
        .map(|i| l.next_link(seed, *i) + l.off())
        .max()
        .unwrap_or(seed.len())
        .min(seed.len());
    let mut out = rng.sample(structural(seed), n - n / 4);
    out.extend(generic(seed, lo..hi.max(lo + 1), rng, n / 4));
    out
}

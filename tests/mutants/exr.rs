//! Structure-aware OpenEXR mutants: header attributes (dataWindow, displayWindow, channels,
//! compression, lineOrder, chunkCount, tiles), attribute sizes and types, version flags,
//! chunk offset tables and chunk headers, multi-part (multi-layer) header lists, truncation
//! and byte flips.

use super::bytes::{get, interesting, put};
use super::{generic, Mutant, Rng};

/// One attribute of one header.
pub struct Attr {
    /// Header (part) index.
    pub part: usize,
    /// Attribute name.
    pub name: String,
    /// Attribute type name.
    pub typ: String,
    /// Offset of the type name.
    pub type_at: usize,
    /// Offset of the 4-byte size.
    pub size_at: usize,
    /// Offset and length of the value.
    pub value: (usize, usize),
}

/// Layout of an EXR file.
pub struct Layout {
    /// Attributes of all headers.
    pub attrs: Vec<Attr>,
    /// Offset of the first chunk offset table (the end of the headers).
    pub tables: usize,
    /// Chunk offsets, in table order.
    pub chunks: Vec<u64>,
    /// Multi-part (chunks start with a part number).
    pub multipart: bool,
}

fn cstr(b: &[u8], at: usize) -> Option<(String, usize)> {
    let end = at + b.get(at..)?.iter().position(|c| *c == 0)?;
    Some((String::from_utf8_lossy(&b[at..end]).into_owned(), end + 1))
}

/// Lines per chunk of a scan-line compression.
fn lines_per_chunk(c: u8) -> usize {
    match c {
        0..=2 => 1,
        3 | 5 => 16,
        4 | 6 | 7 | 8 => 32,
        9 => 256,
        _ => 1,
    }
}

/// The layout of a well-formed EXR file.
pub fn parse(b: &[u8]) -> Layout {
    let flags = get(b, 4, 4, false).unwrap_or(0);
    let multipart = flags & 0x1000 != 0;
    let mut attrs = Vec::new();
    let mut at = 8;
    let mut part = 0;
    let mut chunk_counts = Vec::new();
    loop {
        let mut count = None;
        let (mut height, mut comp) = (1usize, 0u8);
        while b.get(at).is_some_and(|c| *c != 0) {
            let Some((name, p)) = cstr(b, at) else { break };
            let Some((typ, p2)) = cstr(b, p) else { break };
            let size = get(b, p2, 4, false).unwrap_or(0) as usize;
            let value = (p2 + 4, size);
            match name.as_str() {
                "chunkCount" => count = get(b, value.0, 4, false).map(|v| v as usize),
                "compression" => comp = b.get(value.0).copied().unwrap_or(0),
                "dataWindow" => {
                    let y0 = get(b, value.0 + 4, 4, false).unwrap_or(0) as i32;
                    let y1 = get(b, value.0 + 12, 4, false).unwrap_or(0) as i32;
                    height = (y1 - y0 + 1).max(1) as usize;
                }
                _ => {}
            }
            attrs.push(Attr {
                part,
                name,
                typ,
                type_at: p,
                size_at: p2,
                value,
            });
            at = value.0 + size;
        }
        at += 1;
        chunk_counts.push(count.unwrap_or(height.div_ceil(lines_per_chunk(comp))));
        part += 1;
        if !multipart || b.get(at).is_none_or(|c| *c == 0) {
            break;
        }
    }
    if multipart {
        at += 1;
    }
    let total: usize = chunk_counts.iter().sum();
    let chunks = (0..total)
        .map_while(|i| get(b, at + 8 * i, 8, false))
        .collect();
    Layout {
        attrs,
        tables: at,
        chunks,
        multipart,
    }
}

/// A copy of `seed` with the little-endian i32 at `at` set to `v`.
fn put_i32(out: &mut Vec<Mutant>, seed: &[u8], label: String, at: usize, v: i64) {
    let mut b = seed.to_vec();
    put(&mut b, at, 4, false, v as u64);
    out.push(Mutant::new(label, b));
}

/// Attribute-, table- and chunk-level mutants (see the module documentation).
pub fn structural(seed: &[u8]) -> Vec<Mutant> {
    let l = parse(seed);
    let len = seed.len() as u64;
    let i32s: [i64; 12] = [
        0,
        -1,
        1,
        3,
        15,
        16,
        65535,
        1 << 24,
        -(1 << 24),
        i32::MAX as i64,
        i32::MIN as i64,
        (1 << 30) + 7,
    ];
    let mut out = Vec::new();
    for a in &l.attrs {
        let (p, name) = (a.part, a.name.as_str());
        let v0 = a.value.0;
        match name {
            "dataWindow" | "displayWindow" => {
                for (i, c) in ["xmin", "ymin", "xmax", "ymax"].iter().enumerate() {
                    for v in i32s {
                        put_i32(
                            &mut out,
                            seed,
                            format!("part {p} {name}.{c} = {v}"),
                            v0 + 4 * i,
                            v,
                        );
                    }
                }
            }
            "channels" => {
                let mut c = v0;
                while c < v0 + a.value.1 && seed[c] != 0 {
                    let Some((ch, q)) = cstr(seed, c) else { break };
                    for v in [0, 1, 2, 3, -1, 255] {
                        put_i32(
                            &mut out,
                            seed,
                            format!("part {p} channel {ch} type = {v}"),
                            q,
                            v,
                        );
                    }
                    for v in [0, -1, 2, 3, 1 << 20, i32::MAX as i64] {
                        put_i32(
                            &mut out,
                            seed,
                            format!("part {p} channel {ch} xSampling = {v}"),
                            q + 8,
                            v,
                        );
                        put_i32(
                            &mut out,
                            seed,
                            format!("part {p} channel {ch} ySampling = {v}"),
                            q + 12,
                            v,
                        );
                    }
                    c = q + 16;
                }
            }
            "chunkCount" => {
                for v in i32s {
                    put_i32(&mut out, seed, format!("part {p} chunkCount = {v}"), v0, v);
                }
            }
            "tiles" => {
                for v in i32s {
                    put_i32(&mut out, seed, format!("part {p} tiles.xSize = {v}"), v0, v);
                    put_i32(
                        &mut out,
                        seed,
                        format!("part {p} tiles.ySize = {v}"),
                        v0 + 4,
                        v,
                    );
                }
            }
            _ => {}
        }
        if matches!(name, "compression" | "lineOrder" | "tiles") {
            let at = if name == "tiles" { v0 + 8 } else { v0 };
            for v in [0u8, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 255] {
                let mut b = seed.to_vec();
                b[at] = v;
                out.push(Mutant::new(format!("part {p} {name} byte = {v}"), b));
            }
        }
        for v in [
            0i64,
            -1,
            a.value.1 as i64 + 1,
            a.value.1 as i64 - 1,
            1 << 30,
            i32::MAX as i64,
        ] {
            put_i32(
                &mut out,
                seed,
                format!("part {p} {name} size = {v}"),
                a.size_at,
                v,
            );
        }
        let mut b = seed.to_vec();
        if let Some(c) = b.get_mut(a.type_at) {
            *c ^= 0x20;
            out.push(Mutant::new(format!("part {p} {name} type name changed"), b));
        }
    }
    for flag in [0x200u64, 0x400, 0x800, 0x1000] {
        let mut b = seed.to_vec();
        let v = get(&b, 4, 4, false).unwrap_or(0) ^ flag;
        put(&mut b, 4, 4, false, v);
        out.push(Mutant::new(format!("version flag {flag:#x} toggled"), b));
    }
    for v in [1u64, 3, 255] {
        let mut b = seed.to_vec();
        b[4] = v as u8;
        out.push(Mutant::new(format!("version number = {v}"), b));
    }
    let mut b = seed.to_vec();
    if l.tables > 9 {
        b.remove(l.tables - 1);
        out.push(Mutant::new("header list terminator removed", b));
    }
    for (i, &off) in l.chunks.iter().enumerate() {
        let at = l.tables + 8 * i;
        for v in interesting(len) {
            let mut b = seed.to_vec();
            put(&mut b, at, 8, false, v);
            out.push(Mutant::new(format!("chunk {i} offset = {v}"), b));
        }
        let off = off as usize;
        if off + 12 > seed.len() {
            continue;
        }
        let (y_at, size_at) = if l.multipart {
            for v in [-1, 1, 99, i32::MAX as i64] {
                put_i32(
                    &mut out,
                    seed,
                    format!("chunk {i} part number = {v}"),
                    off,
                    v,
                );
            }
            (off + 4, off + 8)
        } else {
            (off, off + 4)
        };
        for v in i32s {
            put_i32(&mut out, seed, format!("chunk {i} y = {v}"), y_at, v);
            put_i32(
                &mut out,
                seed,
                format!("chunk {i} data size = {v}"),
                size_at,
                v,
            );
        }
        out.push(Mutant::new(
            format!("truncated in chunk {i}"),
            seed[..off + 6].to_vec(),
        ));
    }
    for cut in [8, l.tables.saturating_sub(1), l.tables, l.tables + 4] {
        if cut > 0 && (cut as u64) < len {
            out.push(Mutant::new(
                format!("truncated at {cut}"),
                seed[..cut].to_vec(),
            ));
        }
    }
    out
}

/// `n` mutants of the EXR file `seed`: a sample of the structural ones plus random
/// truncations and byte changes (a quarter), the latter mostly in the headers.
pub fn mutants(seed: &[u8], rng: &mut Rng, n: usize) -> Vec<Mutant> {
    let l = parse(seed);
    let mut out = rng.sample(structural(seed), n - n / 4);
    out.extend(generic(seed, 0..l.tables.min(seed.len()), rng, n / 4));
    out
}

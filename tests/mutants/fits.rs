//! Structure-aware FITS mutants: header values (NAXISn, BITPIX, BZERO/BSCALE, the
//! tile-compression keywords ZNAXISn, ZTILEn, ZVALn, ZCMPTYPE ...), deleted, duplicated
//! and inserted cards, heap descriptors of tile-compressed images, truncation at HDU
//! boundaries and byte flips; `.fits.gz` files are mutated inside and recompressed.

use super::{generic, Mutant, Rng};

const BLOCK: usize = 2880;
const CARD: usize = 80;

/// Keywords whose values are mutated.
const KEYS: [&str; 33] = [
    "SIMPLE", "BITPIX", "NAXIS", "NAXIS1", "NAXIS2", "NAXIS3", "EXTEND", "BZERO", "BSCALE",
    "BLANK", "XTENSION", "PCOUNT", "GCOUNT", "TFIELDS", "TFORM1", "TTYPE1", "THEAP", "ZIMAGE",
    "ZBITPIX", "ZNAXIS", "ZNAXIS1", "ZNAXIS2", "ZNAXIS3", "ZTILE1", "ZTILE2", "ZTILE3", "ZCMPTYPE",
    "ZVAL1", "ZVAL2", "ZNAME1", "ZQUANTIZ", "ZPCOUNT", "ZGCOUNT",
];

/// Values written into them (as FITS card values).
const VALUES: [&str; 34] = [
    "0",
    "1",
    "-1",
    "2",
    "3",
    "7",
    "8",
    "16",
    "32",
    "64",
    "-32",
    "-64",
    "255",
    "65535",
    "2147483647",
    "2147483648",
    "4294967296",
    "9007199254740993",
    "9223372036854775807",
    "-9223372036854775808",
    "9.2E18",
    "1E300",
    "-1E300",
    "1.5",
    "'RICE_1  '",
    "'GZIP_2  '",
    "'PLIO_1  '",
    "'HCOMPRESS_1'",
    "'BOGUS   '",
    "'BINTABLE'",
    "T",
    "F",
    "''",
    "garbage",
];

/// Keywords inserted before END.
const INSERTS: [(&str, &str); 10] = [
    ("BLANK", "0"),
    ("BSCALE", "0"),
    ("BSCALE", "1E300"),
    ("BZERO", "9.2E18"),
    ("ZTILE1", "0"),
    ("ZTILE3", "0"),
    ("ZVAL1", "0"),
    ("ZVAL2", "0"),
    ("THEAP", "1000000"),
    ("ZNAXIS3", "-1"),
];

/// Heap descriptor columns (offset in a row, width) of a binary table, its row length and
/// row count.
pub type Descriptors = (Vec<(usize, usize)>, usize, usize);

/// One HDU as laid out in the file.
pub struct Hdu {
    /// Offset of its header.
    pub header: usize,
    /// (offset, keyword) of every card before END.
    pub cards: Vec<(usize, String)>,
    /// Offset of the END card.
    pub end: usize,
    /// Offset of the data.
    pub data: usize,
    /// Bytes of data the header declares.
    pub data_len: usize,
    /// Heap descriptors of a binary table.
    pub descriptors: Option<Descriptors>,
}

fn value(card: &[u8]) -> String {
    String::from_utf8_lossy(&card[10..])
        .split('/')
        .next()
        .unwrap_or("")
        .trim()
        .trim_matches('\'')
        .trim()
        .to_string()
}

/// The HDUs of a well-formed FITS file (parsing stops at anything unexpected).
pub fn parse(b: &[u8]) -> Vec<Hdu> {
    let mut out = Vec::new();
    let mut at = 0;
    while at + BLOCK <= b.len() {
        let mut cards = Vec::new();
        let mut end = None;
        let mut p = at;
        while p + CARD <= b.len() {
            let key = String::from_utf8_lossy(&b[p..p + 8]).trim_end().to_string();
            if key == "END" {
                end = Some(p);
                break;
            }
            cards.push((p, key));
            p += CARD;
        }
        let Some(end) = end else { break };
        let get = |k: &str| {
            cards
                .iter()
                .find(|(_, key)| key == k)
                .map(|(o, _)| value(&b[*o..*o + CARD]))
        };
        let num = |k: &str| get(k).and_then(|v| v.parse::<usize>().ok());
        let naxis = num("NAXIS").unwrap_or(0);
        let width = get("BITPIX")
            .and_then(|v| v.parse::<i64>().ok())
            .map_or(1, |v| v.unsigned_abs() as usize / 8);
        let elems: usize = if naxis == 0 {
            0
        } else {
            (1..=naxis)
                .map(|i| num(&format!("NAXIS{i}")).unwrap_or(0))
                .product()
        };
        let data_len = width * (elems + num("PCOUNT").unwrap_or(0));
        let data = (end / BLOCK + 1) * BLOCK;
        let descriptors = (get("XTENSION").as_deref() == Some("BINTABLE")).then(|| {
            let mut cols = Vec::new();
            let mut off = 0;
            for i in 1..=num("TFIELDS").unwrap_or(0) {
                let form = get(&format!("TFORM{i}")).unwrap_or_default();
                let size = match form
                    .trim_start_matches(|c: char| c.is_ascii_digit())
                    .chars()
                    .next()
                {
                    Some('P') => 8,
                    Some('Q') => 16,
                    Some('E' | 'J') => 4,
                    Some('D' | 'K') => 8,
                    Some('I') => 2,
                    _ => 1,
                };
                if size >= 8 && form.contains(['P', 'Q']) {
                    cols.push((off, size));
                }
                off += size;
            }
            (cols, num("NAXIS1").unwrap_or(0), num("NAXIS2").unwrap_or(0))
        });
        out.push(Hdu {
            header: at,
            cards,
            end,
            data,
            data_len,
            descriptors,
        });
        at = data + data_len.div_ceil(BLOCK) * BLOCK;
    }
    out
}

fn set_card(b: &mut [u8], at: usize, key: &str, value: &str) {
    let card = format!("{key:<8}= {value:>20}");
    let mut bytes = card.into_bytes();
    bytes.resize(CARD, b' ');
    b[at..at + CARD].copy_from_slice(&bytes);
}

/// Header-level mutants of every HDU: each listed keyword set to each value, deleted and
/// duplicated; keywords inserted; descriptors of compressed tiles changed; truncation at
/// HDU boundaries.
pub fn structural(seed: &[u8]) -> Vec<Mutant> {
    let hdus = parse(seed);
    let len = seed.len();
    let mut out = Vec::new();
    for (h, hdu) in hdus.iter().enumerate() {
        let h = h + 1;
        for (at, key) in &hdu.cards {
            if !KEYS.contains(&key.as_str()) {
                continue;
            }
            for v in VALUES {
                let mut b = seed.to_vec();
                set_card(&mut b, *at, key, v);
                out.push(Mutant::new(format!("HDU {h} {key} = {v}"), b));
            }
            let mut b = seed.to_vec();
            b[*at..*at + CARD].fill(b' ');
            out.push(Mutant::new(format!("HDU {h} {key} deleted"), b));
            if *at + 2 * CARD <= hdu.end {
                let mut b = seed.to_vec();
                b.copy_within(*at..*at + CARD, *at + CARD);
                out.push(Mutant::new(
                    format!("HDU {h} {key} duplicated over the next card"),
                    b,
                ));
            }
        }
        if hdu.end % BLOCK + CARD < BLOCK {
            for (key, v) in INSERTS {
                let mut b = seed.to_vec();
                b.copy_within(hdu.end..hdu.end + CARD, hdu.end + CARD);
                set_card(&mut b, hdu.end, key, v);
                out.push(Mutant::new(format!("HDU {h} {key} = {v} inserted"), b));
            }
        }
        let mut b = seed.to_vec();
        b[hdu.end..hdu.end + 3].copy_from_slice(b"ENX");
        out.push(Mutant::new(format!("HDU {h} END card removed"), b));
        if let Some((cols, row, rows)) = &hdu.descriptors {
            for (r, (col, width)) in (0..*rows).flat_map(|r| cols.iter().map(move |c| (r, *c))) {
                let at = hdu.data + r * row + col;
                let half = width / 2;
                for (what, off) in [("count", 0), ("offset", half)] {
                    for v in [0u64, 1, u32::MAX as u64 / 2, u32::MAX as u64, 1 << 20] {
                        let mut b = seed.to_vec();
                        super::bytes::put(&mut b, at + off, half, true, v);
                        out.push(Mutant::new(
                            format!("HDU {h} tile {} descriptor {what} = {v}", r + 1),
                            b,
                        ));
                    }
                }
            }
        }
        for cut in [
            hdu.header,
            hdu.end,
            hdu.data,
            hdu.data + hdu.data_len / 2,
            hdu.data + hdu.data_len,
        ]
        .into_iter()
        .flat_map(|c| [c.saturating_sub(1), c, c + 1])
        .filter(|c| *c > 0 && *c < len)
        {
            out.push(Mutant::new(
                format!("truncated at {cut} (HDU {h})"),
                seed[..cut].to_vec(),
            ));
        }
    }
    if let Some(last) = hdus.last() {
        // A block of another HDU's header appended, and a block of garbage.
        let mut b = seed.to_vec();
        b.extend_from_slice(&seed[last.header..last.header + BLOCK]);
        out.push(Mutant::new("last header block appended", b));
        let mut b = seed.to_vec();
        b.extend(std::iter::repeat_n(b'Z', BLOCK));
        out.push(Mutant::new("a block of garbage appended", b));
    }
    out
}

/// `n` mutants of the FITS file `seed`: a sample of the structural ones plus random
/// truncations and byte changes (a quarter), the latter mostly in the headers.
pub fn mutants(seed: &[u8], rng: &mut Rng, n: usize) -> Vec<Mutant> {
    let hdus = parse(seed);
    let head_end = hdus.first().map_or(seed.len(), |h| h.data);
    let structural = rng.sample(structural(seed), n - n / 4);
    let mut out = structural;
    out.extend(generic(seed, 0..head_end, rng, n / 4));
    out
}

/// `n` mutants of a gzip-compressed FITS file: FITS mutants of its content, recompressed,
/// and mutants of the compressed bytes themselves (a third), including the size trailer.
pub fn gz_mutants(seed: &[u8], rng: &mut Rng, n: usize) -> Vec<Mutant> {
    use std::io::{Read, Write};
    let mut inner = Vec::new();
    flate2::read::GzDecoder::new(seed)
        .read_to_end(&mut inner)
        .expect("the gz seed decompresses");
    let gz = |b: &[u8]| {
        let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
        e.write_all(b).expect("in memory");
        e.finish().expect("in memory")
    };
    let mut out: Vec<Mutant> = mutants(&inner, rng, n - n / 3)
        .into_iter()
        .map(|m| Mutant::new(format!("inside gzip: {}", m.label), gz(&m.bytes)))
        .collect();
    let len = seed.len();
    for v in [0u32, 1, 0x7fff_ffff, 0xffff_ffff] {
        let mut b = seed.to_vec();
        b[len - 4..].copy_from_slice(&v.to_le_bytes());
        out.push(Mutant::new(format!("gzip size trailer = {v}"), b));
    }
    out.extend(generic(seed, 0..len, rng, n / 3 - 4));
    out
}

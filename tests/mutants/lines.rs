//! Mutants of line-structured text (part files, CSV tables): whole lines dropped, duplicated,
//! swapped, blanked or made very long, line ends changed, a byte-order mark, truncation and
//! flipped bits. Each mutant says which operation made it, so that the caller decides what
//! the mutant means for its format (e.g. a dropped row of a table is a smaller valid table,
//! a dropped line of a part file a sub-aperture to recompute).

use super::{Mutant, Rng};

/// What a line mutant did; `header` says whether the first line was touched.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Op {
    /// One bit of one byte flipped.
    FlipBit { header: bool },
    /// Cut at a byte (maybe inside a line).
    TruncateByte { header: bool },
    /// Cut after a whole line (the first `keep` lines kept).
    TruncateLine { keep: usize },
    /// One line removed.
    Drop { header: bool },
    /// One line repeated elsewhere.
    Duplicate { header: bool },
    /// Two lines exchanged.
    Swap { header: bool },
    /// An empty or whitespace-only line inserted (never before the header).
    Blank,
    /// Every `\n` made `\r\n`.
    Crlf,
    /// A UTF-8 byte-order mark before the first line.
    Bom,
    /// A line of 64 KiB inserted after the header.
    Long,
    /// A line of random bytes (maybe not UTF-8) inserted after the header.
    Garbage,
    /// The file's last newline removed.
    NoFinalNewline,
}

/// The lines of `text`, each with its `\n` (the last one may lack it).
pub fn split(text: &[u8]) -> Vec<Vec<u8>> {
    text.split_inclusive(|&b| b == b'\n')
        .map(<[u8]>::to_vec)
        .collect()
}

/// Lines joined back.
pub fn join(lines: &[Vec<u8>]) -> Vec<u8> {
    lines.concat()
}

/// Offset of line `i`'s first byte.
fn offset(lines: &[Vec<u8>], i: usize) -> usize {
    lines[..i].iter().map(Vec::len).sum()
}

/// One line mutant of `seed` (at least two lines, the first a header).
pub fn mutant(seed: &[u8], rng: &mut Rng) -> (Op, Mutant) {
    let mut lines = split(seed);
    let n = lines.len();
    assert!(n >= 2, "a seed of a header and a line at least");
    // Lines other than the header are picked three times as often.
    let line = |rng: &mut Rng| {
        if rng.below(4) == 0 {
            0
        } else {
            1 + rng.below(n - 1)
        }
    };
    let (op, label, bytes) = match rng.below(12) {
        0 => {
            let i = line(rng);
            let at = offset(&lines, i) + rng.below(lines[i].len());
            let bit = rng.below(8);
            let mut b = seed.to_vec();
            b[at] ^= 1 << bit;
            let label = format!("bit {bit} of byte {at} (line {}) flipped", i + 1);
            (Op::FlipBit { header: i == 0 }, label, b)
        }
        1 => {
            let at = rng.below(seed.len());
            let header = at < lines[0].len();
            let label = format!("truncated at byte {at}");
            (Op::TruncateByte { header }, label, seed[..at].to_vec())
        }
        2 => {
            let keep = rng.below(n);
            let label = format!("only the first {keep} lines kept");
            (Op::TruncateLine { keep }, label, join(&lines[..keep]))
        }
        3 => {
            let i = line(rng);
            lines.remove(i);
            let label = format!("line {} dropped", i + 1);
            (Op::Drop { header: i == 0 }, label, join(&lines))
        }
        4 => {
            let i = line(rng);
            let to = 1 + rng.below(n);
            let copy = lines[i].clone();
            lines.insert(to, with_newline(copy));
            let label = format!("line {} repeated as line {}", i + 1, to + 1);
            (Op::Duplicate { header: i == 0 }, label, join(&lines))
        }
        5 => {
            let (i, j) = (line(rng), 1 + rng.below(n - 1));
            let (i, j) = if i == j {
                (i, (j % (n - 1)) + 1)
            } else {
                (i, j)
            };
            lines = lines.into_iter().map(with_newline).collect();
            lines.swap(i, j);
            let label = format!("lines {} and {} swapped", i + 1, j + 1);
            (
                Op::Swap {
                    header: i == 0 || j == 0,
                },
                label,
                join(&lines),
            )
        }
        6 => {
            let to = 1 + rng.below(n);
            let blank = rng
                .pick(&["\n", " \n", "\t\n", "   \t \n"])
                .as_bytes()
                .to_vec();
            lines = lines.into_iter().map(with_newline).collect();
            lines.insert(to, blank);
            (
                Op::Blank,
                format!("blank line inserted as line {}", to + 1),
                join(&lines),
            )
        }
        7 => {
            let b = seed
                .iter()
                .flat_map(|&c| {
                    if c == b'\n' {
                        vec![b'\r', b'\n']
                    } else {
                        vec![c]
                    }
                })
                .collect();
            (Op::Crlf, "CRLF line ends".into(), b)
        }
        8 => {
            let mut b = b"\xef\xbb\xbf".to_vec();
            b.extend_from_slice(seed);
            (Op::Bom, "UTF-8 byte-order mark".into(), b)
        }
        9 => {
            let fill = *rng.pick(b"7,x\t ");
            let mut long = vec![fill; 64 << 10];
            long.push(b'\n');
            let to = 1 + rng.below(n);
            lines = lines.into_iter().map(with_newline).collect();
            lines.insert(to, long);
            let label = format!("a 64 KiB line of {:?} as line {}", fill as char, to + 1);
            (Op::Long, label, join(&lines))
        }
        10 => {
            let mut g: Vec<u8> = (0..1 + rng.below(200))
                .map(|_| rng.next() as u8)
                .filter(|&c| c != b'\n')
                .collect();
            g.push(b'\n');
            let to = 1 + rng.below(n);
            lines = lines.into_iter().map(with_newline).collect();
            lines.insert(to, g);
            let label = format!("a line of random bytes as line {}", to + 1);
            (Op::Garbage, label, join(&lines))
        }
        _ => {
            let mut b = seed.to_vec();
            if b.last() == Some(&b'\n') {
                b.pop();
            }
            (Op::NoFinalNewline, "last newline removed".into(), b)
        }
    };
    (op, Mutant::new(label, bytes))
}

fn with_newline(mut l: Vec<u8>) -> Vec<u8> {
    if l.last() != Some(&b'\n') {
        l.push(b'\n');
    }
    l
}

//! The mutations the parser fuzzer grows its inputs by, and the shrinker
//! that cuts a failing input down.
//!
//! Mutations work on bytes, so they make what an editor, a spreadsheet or a
//! broken disk makes: flipped bits, lost and doubled bytes, tokens that parse
//! as numbers but are not finite or do not fit (`NaN`, `inf`, `1e309`,
//! `18446744073709551616`), empty cells, cells and columns added or lost,
//! lines doubled (duplicate keys and rows), swapped and spliced in from
//! another valid file, CRLF line ends, a byte order mark, bytes that are
//! not UTF-8, and truncation anywhere.

use rand::Rng;

/// Tokens inserted or put in place of a number.
const TOKENS: &[&[u8]] = &[
    b"NaN",
    b"nan",
    b"inf",
    b"-inf",
    b"+inf",
    b"infinity",
    b"-0",
    b"-0.0",
    b"0",
    b"1e308",
    b"-1e308",
    b"1e309",
    b"-1e309",
    b"4.9e-324",
    b"1.7976931348623157e308",
    b"18446744073709551616",
    b"-9223372036854775809",
    b"9223372036854775807",
    b"4294967296",
    b"4294967295",
    b"-1",
    b"123456789012345678901234567890",
    b"0x1F",
    b"1_000",
    b"1e",
    b".",
    b"",
    b" ",
    b",",
    b",,",
    b";",
    b"\"",
    b"'",
    b"=",
    b"[",
    b"]",
    b"{",
    b"}",
    b"[]",
    b"{}",
    b"\n",
    b"\r\n",
    b"\r",
    b"#",
    b"\t",
    b"\\",
    b"\\u0000",
    b"\\ud800",
    b"\0",
    b"true",
    b"false",
    b"null",
    b"\"\"",
    b"\xef\xbb\xbf",
    b"\xff",
    b"\xc3",
    b"\xed\xa0\x80",
    "é".as_bytes(),
    b"[[joint]]\n",
    b"[[body]]\n",
    b"[collision]\n",
    b"note_x",
    b"pose",
    b"load_kg",
];

/// A random token of [`TOKENS`].
fn token(rng: &mut impl Rng) -> &'static [u8] {
    TOKENS[rng.random_range(0..TOKENS.len())]
}

/// The byte ranges of the lines of `bytes`, each with its `\n`.
fn lines(bytes: &[u8]) -> Vec<std::ops::Range<usize>> {
    let mut out = Vec::new();
    let mut start = 0;
    for (i, &b) in bytes.iter().enumerate() {
        if b == b'\n' {
            out.push(start..i + 1);
            start = i + 1;
        }
    }
    if start < bytes.len() {
        out.push(start..bytes.len());
    }
    out
}

/// The byte ranges of the numbers in `bytes` (runs of digits with their
/// sign, point and exponent).
fn numbers(bytes: &[u8]) -> Vec<std::ops::Range<usize>> {
    let part = |b: u8| b.is_ascii_digit() || matches!(b, b'.' | b'e' | b'E' | b'+' | b'-');
    let mut out = Vec::new();
    let mut i = 0;
    while i < bytes.len() {
        if part(bytes[i]) {
            let start = i;
            while i < bytes.len() && part(bytes[i]) {
                i += 1;
            }
            if bytes[start..i].iter().any(u8::is_ascii_digit) {
                out.push(start..i);
            }
        } else {
            i += 1;
        }
    }
    out
}

/// A random position in `0..=len`.
fn position(rng: &mut impl Rng, len: usize) -> usize {
    rng.random_range(0..=len)
}

/// A random element of `items`, if any.
fn pick<T: Clone>(rng: &mut impl Rng, items: &[T]) -> Option<T> {
    (!items.is_empty()).then(|| items[rng.random_range(0..items.len())].clone())
}

/// `input` after one to four mutations; `donors` are other valid files of
/// the same kind, whose lines may be spliced in.
pub fn mutate(rng: &mut impl Rng, input: &[u8], donors: &[Vec<u8>]) -> Vec<u8> {
    let mut bytes = input.to_vec();
    for _ in 0..rng.random_range(1..=4) {
        mutate_once(rng, &mut bytes, donors);
    }
    bytes
}

/// One mutation of `bytes`, in place.
fn mutate_once(rng: &mut impl Rng, bytes: &mut Vec<u8>, donors: &[Vec<u8>]) {
    match rng.random_range(0..16) {
        // Bit flip.
        0 if !bytes.is_empty() => {
            let i = rng.random_range(0..bytes.len());
            bytes[i] ^= 1 << rng.random_range(0..8);
        }
        // Delete a few bytes.
        1 if !bytes.is_empty() => {
            let i = rng.random_range(0..bytes.len());
            let end = (i + rng.random_range(1..=8)).min(bytes.len());
            bytes.drain(i..end);
        }
        // Insert a token anywhere.
        2 => {
            let i = position(rng, bytes.len());
            bytes.splice(i..i, token(rng).iter().copied());
        }
        // A number replaced by a token, or emptied (an empty cell or value).
        3..=5 => {
            if let Some(r) = pick(rng, &numbers(bytes)) {
                let with = if rng.random_bool(0.2) {
                    &[][..]
                } else {
                    token(rng)
                };
                bytes.splice(r, with.iter().copied());
            }
        }
        // A line doubled, next to itself (a duplicate key or row) or anywhere.
        6 => {
            if let Some(r) = pick(rng, &lines(bytes)) {
                let line = bytes[r.clone()].to_vec();
                let i = if rng.random_bool(0.5) {
                    r.end
                } else {
                    position(rng, bytes.len())
                };
                bytes.splice(i..i, line);
            }
        }
        // A line deleted.
        7 => {
            if let Some(r) = pick(rng, &lines(bytes)) {
                bytes.drain(r);
            }
        }
        // Two lines swapped.
        8 => {
            let all = lines(bytes);
            if let (Some(a), Some(b)) = (pick(rng, &all), pick(rng, &all)) {
                let (a, b) = if a.start <= b.start { (a, b) } else { (b, a) };
                if a.end <= b.start {
                    let mut out = bytes[..a.start].to_vec();
                    out.extend_from_slice(&bytes[b.clone()]);
                    out.extend_from_slice(&bytes[a.end..b.start]);
                    out.extend_from_slice(&bytes[a]);
                    out.extend_from_slice(&bytes[b.end..]);
                    *bytes = out;
                }
            }
        }
        // A line of another valid file spliced in.
        9 => {
            if let Some(donor) = pick(rng, donors)
                && let Some(r) = pick(rng, &lines(&donor))
            {
                let i = pick(rng, &lines(bytes)).map_or(0, |l| l.start);
                bytes.splice(i..i, donor[r].iter().copied());
            }
        }
        // An extra cell at the end of a line (an extra column).
        10 => {
            if let Some(r) = pick(rng, &lines(bytes)) {
                let end = if bytes[r.end - 1] == b'\n' {
                    r.end - 1
                } else {
                    r.end
                };
                let mut cell = vec![b','];
                cell.extend_from_slice(token(rng));
                bytes.splice(end..end, cell);
            }
        }
        // A cell removed from a line (a missing column).
        11 => {
            if let Some(r) = pick(rng, &lines(bytes)) {
                let commas: Vec<usize> = r.clone().filter(|&i| bytes[i] == b',').collect();
                if let Some(c) = pick(rng, &commas) {
                    let end = (c + 1..r.end)
                        .find(|&i| bytes[i] == b',' || bytes[i] == b'\n')
                        .unwrap_or(r.end);
                    bytes.drain(c..end);
                }
            }
        }
        // CRLF line ends.
        12 => {
            let mut out = Vec::with_capacity(bytes.len() + bytes.len() / 16);
            for &b in bytes.iter() {
                if b == b'\n' {
                    out.push(b'\r');
                }
                out.push(b);
            }
            *bytes = out;
        }
        // A byte order mark.
        13 => {
            bytes.splice(0..0, "\u{feff}".bytes());
        }
        // Truncated anywhere.
        14 => {
            let i = position(rng, bytes.len());
            bytes.truncate(i);
        }
        // A stretch of bytes repeated.
        _ if !bytes.is_empty() => {
            let i = rng.random_range(0..bytes.len());
            let end = (i + rng.random_range(1..=32)).min(bytes.len());
            let chunk = bytes[i..end].to_vec();
            let j = position(rng, bytes.len());
            bytes.splice(j..j, chunk);
        }
        _ => {}
    }
}

/// The smallest input found that still `fails`: whole lines dropped first,
/// then runs of bytes, halving the run length down to one byte, until
/// nothing more can go.
pub fn shrink(input: &[u8], mut fails: impl FnMut(&[u8]) -> bool) -> Vec<u8> {
    let mut best = input.to_vec();
    loop {
        let before = best.len();
        // Lines.
        let mut i = 0;
        loop {
            let all = lines(&best);
            let Some(r) = all.get(i).cloned() else { break };
            let mut trial = best.clone();
            trial.drain(r);
            if fails(&trial) {
                best = trial;
            } else {
                i += 1;
            }
        }
        // Bytes.
        let mut chunk = best.len().div_ceil(2).max(1);
        while chunk >= 1 && !best.is_empty() {
            let mut at = 0;
            while at < best.len() {
                let mut trial = best.clone();
                trial.drain(at..(at + chunk).min(best.len()));
                if fails(&trial) {
                    best = trial;
                } else {
                    at += chunk;
                }
            }
            chunk /= 2;
        }
        if best.len() == before {
            return best;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn lines_and_numbers_are_found() {
        let text = b"a = -1.5e3\nb,2,x\nlast";
        assert_eq!(lines(text), [0..11, 11..17, 17..21]);
        let found: Vec<&[u8]> = numbers(text).into_iter().map(|r| &text[r]).collect();
        assert_eq!(found, [&b"-1.5e3"[..], b"2"]);
    }

    #[test]
    fn mutations_are_seeded_and_change_the_input() {
        let input = b"pose,q1_deg\n1,2.5\n2,3.5\n".to_vec();
        let run = |seed| {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            (0..50)
                .map(|_| mutate(&mut rng, &input, std::slice::from_ref(&input)))
                .collect::<Vec<_>>()
        };
        let a = run(3);
        assert_eq!(a, run(3));
        assert_ne!(a, run(4));
        assert!(a.iter().filter(|m| **m != input).count() > 40);
    }

    #[test]
    fn shrinking_keeps_the_failure_and_drops_the_rest() {
        let input = b"header\nfine line\nbad X here\nmore\n";
        let small = shrink(input, |b| b.contains(&b'X'));
        assert_eq!(small, b"X");
    }
}

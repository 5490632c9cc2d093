//! Hostile variants of valid files, for the readers' fuzz tests (feature `fuzz`).
//!
//! Arbitrary bytes mostly fail at the first character; the bugs that hurt users sit one step
//! further, in a file that is nearly right. So a valid file is taken and edited a few times:
//! a number becomes 1e308, NaN, -1 or 2^64, a line is repeated or lost, the text is cut short,
//! bytes are flipped, structure characters are inserted.

use proptest::prelude::*;

/// How many cases each reader's properties run in CI: thousands, each on a small file, so a
/// reader's whole run stays within seconds.
pub const CASES: u32 = 2_000;

/// Values that have broken readers before: out of every range, not finite, not numbers,
/// or sized to make an allocation fail.
const HOSTILE: &[&str] = &[
    "1e308",
    "-1e308",
    "1e309",
    "NaN",
    "nan",
    "inf",
    "-inf",
    "Infinity",
    "-1",
    "-0",
    "0",
    "1e-320",
    "4294967295",
    "4294967296",
    "18446744073709551615",
    "99999999999999999999",
    "9e18",
    "1.5",
    "null",
    "true",
    "\"\"",
    "\"x\"",
    "[]",
    "{}",
    "[",
    "]",
    "{",
    "}",
    ",",
    ":",
    "\"",
    "\n",
    "\t",
    "#",
    "=",
    " ",
    "\u{feff}",
    "é",
    "\u{0}",
];

/// One edit of a file's bytes; positions are taken modulo the length at the time.
#[derive(Debug, Clone)]
pub enum Edit {
    /// Replace the `n`th number of the text by a hostile value.
    Number(usize, usize),
    /// Insert a hostile token.
    Insert(usize, usize),
    /// Delete up to `len` bytes.
    Delete(usize, usize),
    /// Set one byte.
    Byte(usize, u8),
    /// Repeat the line around a position.
    RepeatLine(usize),
    /// Cut the file there.
    Truncate(usize),
}

fn edit() -> impl Strategy<Value = Edit> {
    prop_oneof![
        4 => (any::<usize>(), 0..HOSTILE.len()).prop_map(|(n, t)| Edit::Number(n, t)),
        2 => (any::<usize>(), 0..HOSTILE.len()).prop_map(|(at, t)| Edit::Insert(at, t)),
        1 => (any::<usize>(), 1usize..40).prop_map(|(at, len)| Edit::Delete(at, len)),
        1 => (any::<usize>(), any::<u8>()).prop_map(|(at, b)| Edit::Byte(at, b)),
        1 => any::<usize>().prop_map(Edit::RepeatLine),
        1 => any::<usize>().prop_map(Edit::Truncate),
    ]
}

/// Byte ranges of the numbers in `text` (an optional sign, digits, a fraction, an exponent).
fn numbers(text: &[u8]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < text.len() {
        let starts =
            text[i].is_ascii_digit() || (text[i] == b'-' && text.get(i + 1).is_some_and(u8::is_ascii_digit));
        if !starts {
            i += 1;
            continue;
        }
        let start = i;
        i += 1;
        while i < text.len()
            && (text[i].is_ascii_digit() || matches!(text[i], b'.' | b'e' | b'E' | b'+' | b'-'))
        {
            i += 1;
        }
        out.push((start, i));
    }
    out
}

/// Applies `edits` to `valid`, in order.
pub fn apply(valid: &[u8], edits: &[Edit]) -> Vec<u8> {
    let mut t = valid.to_vec();
    for e in edits {
        let at = |p: usize, t: &Vec<u8>| if t.is_empty() { 0 } else { p % (t.len() + 1) };
        match *e {
            Edit::Number(n, k) => {
                let found = numbers(&t);
                if let Some(&(a, b)) = found.get(n % found.len().max(1)) {
                    t.splice(a..b, HOSTILE[k].bytes());
                }
            }
            Edit::Insert(p, k) => {
                let p = at(p, &t);
                t.splice(p..p, HOSTILE[k].bytes());
            }
            Edit::Delete(p, len) => {
                let p = at(p, &t);
                let end = (p + len).min(t.len());
                t.drain(p..end);
            }
            Edit::Byte(p, b) => {
                if !t.is_empty() {
                    let p = p % t.len();
                    t[p] = b;
                }
            }
            Edit::RepeatLine(p) => {
                let p = at(p, &t);
                let start = t[..p].iter().rposition(|&c| c == b'\n').map_or(0, |i| i + 1);
                let end = t[p..]
                    .iter()
                    .position(|&c| c == b'\n')
                    .map_or(t.len(), |i| p + i + 1);
                let line = t[start..end].to_vec();
                t.splice(end..end, line);
            }
            Edit::Truncate(p) => {
                let p = at(p, &t);
                t.truncate(p);
            }
        }
    }
    t
}

/// One to four edits of `valid`, as bytes.
pub fn mutated_bytes(valid: Vec<u8>) -> impl Strategy<Value = Vec<u8>> {
    prop::collection::vec(edit(), 1..5).prop_map(move |edits| apply(&valid, &edits))
}

/// One to four edits of `valid`, as text (bytes that are not UTF-8 are replaced, as a reader
/// that takes text never sees them).
pub fn mutated(valid: &str) -> impl Strategy<Value = String> {
    mutated_bytes(valid.as_bytes().to_vec()).prop_map(|b| String::from_utf8_lossy(&b).into_owned())
}

/// Arbitrary text: printable, with line breaks, or any bytes read lossily.
pub fn arbitrary_text() -> impl Strategy<Value = String> {
    prop_oneof![
        "(\\PC|\n){0,300}",
        prop::collection::vec(any::<u8>(), 0..300).prop_map(|b| String::from_utf8_lossy(&b).into_owned()),
    ]
}

/// The proptest settings of a fuzz property: [`CASES`] cases (or `SKIN_FUZZ_CASES`, for a
/// longer search by hand), no regression files written into the source tree by CI.
pub fn config() -> ProptestConfig {
    let cases = std::env::var("SKIN_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(CASES);
    ProptestConfig {
        cases,
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}

#[test]
fn edits_do_what_they_say() {
    let valid = b"a 12 -3.5e2\nb 4\n";
    assert_eq!(apply(valid, &[Edit::Number(1, 0)]), b"a 12 1e308\nb 4\n");
    assert_eq!(apply(valid, &[Edit::Number(2, 3)]), b"a 12 -3.5e2\nb NaN\n");
    assert_eq!(apply(valid, &[Edit::RepeatLine(14)]), b"a 12 -3.5e2\nb 4\nb 4\n");
    assert_eq!(apply(valid, &[Edit::Truncate(4)]), b"a 12");
    assert_eq!(apply(valid, &[Edit::Delete(0, 2)]), b"12 -3.5e2\nb 4\n");
    assert_eq!(apply(b"", &[Edit::Byte(3, b'x'), Edit::Number(0, 0)]), b"");
}

//! The words of an OBJ line and the numbers in them: a byte cursor (no
//! UTF-8 check on the hot path), decimal floats read exactly without the
//! general parser where they are short (what exporters write), and face
//! corners.

/// The whitespace-separated words of a line.
pub(super) struct Words<'a> {
    rest: &'a [u8],
}

impl<'a> Words<'a> {
    pub(super) fn new(line: &'a [u8]) -> Self {
        Self { rest: line }
    }

    fn skip_whitespace(&mut self) {
        let start = self
            .rest
            .iter()
            .position(|b| !b.is_ascii_whitespace())
            .unwrap_or(self.rest.len());
        self.rest = &self.rest[start..];
    }

    /// The next word read as a number (None: no words left), in one pass
    /// over it where it is a short decimal.
    #[inline]
    pub(super) fn next_number(&mut self, what: &str) -> Option<Result<f32, String>> {
        self.skip_whitespace();
        if let Some((value, len)) = short_decimal(self.rest) {
            if self.rest.get(len).is_none_or(u8::is_ascii_whitespace) {
                self.rest = &self.rest[len..];
                return Some(Ok(value));
            }
        }
        self.next().map(|word| number(word, what))
    }

    /// The next word read as a face corner (None: no words left).
    #[inline]
    pub(super) fn next_corner(&mut self) -> Option<Result<[i64; 3], String>> {
        self.skip_whitespace();
        if let Some((corner, len)) = corner_at(self.rest) {
            self.rest = &self.rest[len..];
            return Some(Ok(corner));
        }
        self.next().map(|word| Err(bad_corner(word)))
    }
}

impl<'a> Iterator for Words<'a> {
    type Item = &'a [u8];

    #[inline]
    fn next(&mut self) -> Option<&'a [u8]> {
        self.skip_whitespace();
        if self.rest.is_empty() {
            return None;
        }
        let end = self
            .rest
            .iter()
            .position(|b| b.is_ascii_whitespace())
            .unwrap_or(self.rest.len());
        let (word, rest) = self.rest.split_at(end);
        self.rest = rest;
        Some(word)
    }
}

/// Powers of ten exactly representable in f64.
const POW10: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
    1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
];

/// A number of a `v`, `vt` or `vn` line, correctly rounded to f32.
pub(super) fn number(word: &[u8], what: &str) -> Result<f32, String> {
    if let Some((x, len)) = short_decimal(word) {
        if len == word.len() {
            return Ok(x);
        }
    }
    std::str::from_utf8(word)
        .ok()
        .and_then(|s| s.parse().ok())
        .ok_or_else(|| {
            format!(
                "`{what}`: `{}` is not a number",
                String::from_utf8_lossy(&word[..word.len().min(40)])
            )
        })
}

/// `[±]digits[.digits]` at the start of `text`, with at most 15
/// significant digits and 22 decimals, as f32, and its length; None for
/// anything else (the general parser decides). The digits as an integer
/// m < 2⁵³ and 10^k are both exact in f64, so m / 10^k is the f64 nearest
/// the value. Rounding that to f32 is exact unless it lies on a halfway
/// point between two f32s (the value may lie on either side): then None.
#[inline]
fn short_decimal(text: &[u8]) -> Option<(f32, usize)> {
    let negative = text.first() == Some(&b'-');
    let mut i = usize::from(negative || text.first() == Some(&b'+'));
    let mut mantissa: u64 = 0;
    let mut count = 0; // digits read, leading zeros included
    let mut point: Option<usize> = None;
    while let Some(&b) = text.get(i) {
        match b {
            b'0'..=b'9' => {
                mantissa = mantissa * 10 + u64::from(b - b'0');
                count += 1;
                if count > 15 {
                    return None;
                }
            }
            b'.' if point.is_none() => point = Some(i),
            _ => break,
        }
        i += 1;
    }
    if count == 0 {
        return None;
    }
    let k = point.map_or(0, |at| i - at - 1);
    let value = mantissa as f64 / *POW10.get(k)?;
    // The low 29 bits of an f64's mantissa are what rounding to f32 drops:
    // exactly half of its last place is a tie the f64 cannot settle.
    if value.to_bits() & 0x1fff_ffff == 0x1000_0000 {
        return None;
    }
    let value = value as f32;
    Some((if negative { -value } else { value }, i))
}

/// A face corner `v`, `v/vt`, `v//vn` or `v/vt/vn` as written (0: none).
pub(super) fn corner(word: &[u8]) -> Result<[i64; 3], String> {
    match corner_at(word) {
        Some((corner, len)) if len == word.len() => Ok(corner),
        _ => Err(bad_corner(word)),
    }
}

/// The face corner at the start of `text` (ending at whitespace or the
/// end) and its length, in one pass over its bytes (a big file has tens of
/// millions): each index nonzero, of 1 to 18 digits, with an optional
/// sign. None where it is not one.
#[inline]
fn corner_at(text: &[u8]) -> Option<([i64; 3], usize)> {
    let mut out = [0i64; 3];
    let mut i = 0;
    for (k, slot) in out.iter_mut().enumerate() {
        let start = i;
        let negative = text.get(i) == Some(&b'-');
        if negative || text.get(i) == Some(&b'+') {
            i += 1;
        }
        let digits = i;
        let mut value = 0i64;
        while let Some(&d) = text.get(i).filter(|d| d.is_ascii_digit()) {
            value = value.wrapping_mul(10).wrapping_add(i64::from(d - b'0'));
            i += 1;
        }
        match i - digits {
            // An empty v, or a sign alone.
            0 if k == 0 || i > start => return None,
            0 => {}
            1..=18 if value != 0 => *slot = if negative { -value } else { value },
            _ => return None,
        }
        match text.get(i) {
            None => return Some((out, i)),
            Some(b) if b.is_ascii_whitespace() => return Some((out, i)),
            Some(b'/') if k < 2 => i += 1,
            Some(_) => return None,
        }
    }
    None
}

fn bad_corner(word: &[u8]) -> String {
    format!(
        "`f`: `{}` is not a face corner (v, v/vt, v//vn or v/vt/vn)",
        String::from_utf8_lossy(&word[..word.len().min(40)])
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn words_split_at_any_whitespace() {
        let words: Vec<&[u8]> = Words::new(b"  v\t1  2 3\x0c").collect();
        assert_eq!(words, [&b"v"[..], b"1", b"2", b"3"]);
        assert_eq!(Words::new(b" \t ").next(), None);
    }

    #[test]
    fn numbers_are_what_the_standard_parser_reads() {
        // Exporters' decimals, and the cases the short path hands on.
        let mut words: Vec<String> = [
            "0",
            "-0",
            "+1",
            "1.",
            ".5",
            "-.5",
            "0.1",
            "3.4028235e38",
            "1e-3",
            "nan",
            "inf",
            "-inf",
            "123456789012345",
            "1234567890123456",
            "0.000000000000000000001",
            "0.0000000000000000000001",
            "16777217",
            "16777219",
            "0.30000001192092896",
        ]
        .map(String::from)
        .to_vec();
        // Random decimals of 1 to 15 digits, with the point anywhere.
        let mut random = crate::test_random::XorShift64(0x9e37_79b9_7f4a_7c15);
        let mut next = || random.next_u64();
        for _ in 0..200_000 {
            let digits = 1 + (next() % 15) as usize;
            let mut s: String = (0..digits)
                .map(|_| char::from(b'0' + (next() % 10) as u8))
                .collect();
            let point = (next() % (digits as u64 + 1)) as usize;
            s.insert(point, '.');
            if next() % 2 == 0 {
                s.insert(0, '-');
            }
            words.push(s);
        }
        let mut short = 0;
        for w in &words {
            let expected: f32 = w.parse().unwrap();
            let got = number(w.as_bytes(), "v").unwrap();
            assert!(
                got.to_bits() == expected.to_bits() || (got.is_nan() && expected.is_nan()),
                "{w}: {got} against {expected}"
            );
            short += usize::from(short_decimal(w.as_bytes()).is_some_and(|s| s.1 == w.len()));
        }
        // Read from a line as the parser does, the same.
        let line = words.join(" \t");
        let mut cursor = Words::new(line.as_bytes());
        for w in &words {
            let expected: f32 = w.parse().unwrap();
            let got = cursor.next_number("v").unwrap().unwrap();
            assert!(got.to_bits() == expected.to_bits() || (got.is_nan() && expected.is_nan()));
        }
        assert!(cursor.next_number("v").is_none());
        let e = Words::new(b" 1.5x 2")
            .next_number("v")
            .unwrap()
            .unwrap_err();
        assert!(e.contains("`1.5x` is not a number"), "{e}");
        // The short path took nearly all of them (not the exponents).
        assert!(short > 199_000, "{short}");
        for bad in ["", "-", ".", "1.2.3", "1,5", "x"] {
            assert!(number(bad.as_bytes(), "v").is_err(), "{bad}");
        }
    }

    #[test]
    fn corners_read_every_form() {
        assert_eq!(corner(b"3").unwrap(), [3, 0, 0]);
        assert_eq!(corner(b"3/-2").unwrap(), [3, -2, 0]);
        assert_eq!(corner(b"3//7").unwrap(), [3, 0, 7]);
        assert_eq!(corner(b"-1/-1/-1").unwrap(), [-1, -1, -1]);
        assert_eq!(corner(b"+3/2/").unwrap(), [3, 2, 0]);
        let mut line = Words::new(b"1/2/3\t-4//5 6 7/x");
        assert_eq!(line.next_corner().unwrap().unwrap(), [1, 2, 3]);
        assert_eq!(line.next_corner().unwrap().unwrap(), [-4, 0, 5]);
        assert_eq!(line.next_corner().unwrap().unwrap(), [6, 0, 0]);
        let e = line.next_corner().unwrap().unwrap_err();
        assert!(e.contains("`7/x` is not a face corner"), "{e}");
        assert!(line.next_corner().is_none());
        assert_eq!(corner(b"3//").unwrap(), [3, 0, 0]);
        assert_eq!(
            corner(b"123456789012345678").unwrap()[0],
            123456789012345678
        );
        for bad in [
            &b"/1"[..],
            b"1/2/3/4",
            b"1/2/3/",
            b"0",
            b"1/0",
            b"1/x",
            b"-",
            b"1/-/2",
            b"1 /2",
            b"1234567890123456789",
        ] {
            assert!(corner(bad).is_err(), "{}", String::from_utf8_lossy(bad));
        }
    }
}

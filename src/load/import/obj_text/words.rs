//! The words of an OBJ line and the numbers in them: a byte cursor (no
//! UTF-8 check on the hot path), decimal floats read exactly without the
//! general parser where they are short (what exporters write), integers
//! and face corners.

/// The whitespace-separated words of a line.
pub(super) struct Words<'a> {
    rest: &'a [u8],
}

impl<'a> Words<'a> {
    pub(super) fn new(line: &'a [u8]) -> Self {
        Self { rest: line }
    }
}

impl<'a> Iterator for Words<'a> {
    type Item = &'a [u8];

    #[inline]
    fn next(&mut self) -> Option<&'a [u8]> {
        let start = self.rest.iter().position(|b| !b.is_ascii_whitespace())?;
        let rest = &self.rest[start..];
        let end = rest
            .iter()
            .position(|b| b.is_ascii_whitespace())
            .unwrap_or(rest.len());
        self.rest = &rest[end..];
        Some(&rest[..end])
    }
}

/// Powers of ten exactly representable in f64.
const POW10: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
    1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
];

/// A number of a `v`, `vt` or `vn` line, correctly rounded to f32.
pub(super) fn number(word: &[u8], what: &str) -> Result<f32, String> {
    if let Some(x) = short_decimal(word) {
        return Ok(x);
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

/// `[±]digits[.digits]` with at most 15 significant digits and 22
/// decimals, as f32, or None for anything else (exponents, more digits):
/// the digits as an integer m < 2⁵³ and 10^k are both exact in f64, so
/// m / 10^k is the f64 nearest the value. Rounding that to f32 is exact
/// unless it lies on a halfway point between two f32s (the value may lie
/// on either side): then None, and the general parser decides.
#[inline]
fn short_decimal(word: &[u8]) -> Option<f32> {
    let (negative, digits) = match word.split_first()? {
        (b'-', rest) => (true, rest),
        (b'+', rest) => (false, rest),
        _ => (false, word),
    };
    let mut mantissa: u64 = 0;
    let mut count = 0; // digits read, leading zeros included
    let mut decimals: Option<usize> = None;
    for (i, &b) in digits.iter().enumerate() {
        match b {
            b'0'..=b'9' => {
                mantissa = mantissa * 10 + u64::from(b - b'0');
                count += 1;
                if count > 15 {
                    return None;
                }
            }
            b'.' if decimals.is_none() => decimals = Some(i),
            _ => return None,
        }
    }
    if count == 0 {
        return None;
    }
    let k = decimals.map_or(0, |at| digits.len() - at - 1);
    let value = mantissa as f64 / *POW10.get(k)?;
    // The low 29 bits of an f64's mantissa are what rounding to f32 drops:
    // exactly half of its last place is a tie the f64 cannot settle.
    if value.to_bits() & 0x1fff_ffff == 0x1000_0000 {
        return None;
    }
    let value = value as f32;
    Some(if negative { -value } else { value })
}

/// A face corner `v`, `v/vt`, `v//vn` or `v/vt/vn` as written (0: none),
/// in one pass over its bytes (a big file has tens of millions): each
/// index as `integer` reads it.
#[inline]
pub(super) fn corner(word: &[u8]) -> Result<[i64; 3], String> {
    let mut out = [0i64; 3];
    let mut i = 0;
    for (k, slot) in out.iter_mut().enumerate() {
        let start = i;
        let negative = word.get(i) == Some(&b'-');
        if negative || word.get(i) == Some(&b'+') {
            i += 1;
        }
        let digits = i;
        let mut value = 0i64;
        while let Some(&d) = word.get(i).filter(|d| d.is_ascii_digit()) {
            value = value.wrapping_mul(10).wrapping_add(i64::from(d - b'0'));
            i += 1;
        }
        match i - digits {
            // An empty v, or a sign alone.
            0 if k == 0 || i > start => return Err(bad_corner(word)),
            0 => {}
            1..=18 if value != 0 => *slot = if negative { -value } else { value },
            _ => return Err(bad_corner(word)),
        }
        match word.get(i) {
            None => return Ok(out),
            Some(b'/') => i += 1,
            Some(_) => return Err(bad_corner(word)),
        }
    }
    Err(bad_corner(word))
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
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
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
            short += usize::from(short_decimal(w.as_bytes()).is_some());
        }
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

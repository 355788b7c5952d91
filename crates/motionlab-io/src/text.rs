//! Shared scanning helpers for the text formats (BVH, ASF/AMC, label files).
//!
//! Written by hand rather than with a parser-combinator crate because the frame sections are
//! the hot path (hundreds of thousands of numbers per file) and need a byte scanner that parses
//! each number in place, with no per-value allocation, while counting lines for error
//! messages. Numbers are parsed with `fast-float2` (`parse_partial`), which both finds the end
//! of the number and converts it in one pass; `benches/parse.rs` compares it with
//! `str::parse::<f64>` on the shipped files.
//!
//! Conventions: `\n` ends a line; `\r`, space and tab are blanks (so CRLF and LF files scan
//! identically); line numbers are 1-based.

use std::path::Path;

use motionlab_core::{Error, ErrorKind, Result};

/// Strips a leading UTF-8 byte-order mark (files read through `read_text` have none already,
/// but the `parse_*` functions accept text from anywhere).
pub(crate) fn strip_bom(text: &str) -> &str {
    text.strip_prefix('\u{feff}').unwrap_or(text)
}

/// The text with every comment line (first non-blank character `#`) emptied but kept, so that
/// a CSV reader's line numbers stay the file's (the csv crate's own comment skipping leaves
/// the skipped lines out of its positions).
pub(crate) fn blank_comment_lines(text: &str) -> String {
    text.split_inclusive('\n')
        .map(|l| {
            if l.trim_start().starts_with('#') {
                if l.ends_with('\n') { "\n" } else { "" }
            } else {
                l
            }
        })
        .collect()
}

/// The 1-based line of `text` where the CSV record at `position` starts: a record's position
/// is where the reader resumed, before the blank (and blanked comment) lines it skips, so
/// those are stepped over first.
pub(crate) fn csv_record_line(text: &str, position: Option<&csv::Position>) -> usize {
    let bytes = text.as_bytes();
    let mut byte = position.map_or(0, |p| p.byte() as usize).min(bytes.len());
    while byte < bytes.len() && (bytes[byte] == b'\n' || bytes[byte] == b'\r') {
        byte += 1;
    }
    bytes[..byte].iter().filter(|&&b| b == b'\n').count() + 1
}

#[inline(always)]
pub(crate) fn is_blank(b: u8) -> bool {
    b == b' ' || b == b'\t' || b == b'\r'
}

#[inline(always)]
fn is_separator(b: u8) -> bool {
    is_blank(b) || b == b'\n'
}

/// How the token after a number ended, for the error message of a value that is not a number.
fn token_at(bytes: &[u8], start: usize) -> &str {
    let end =
        bytes[start..].iter().position(|b| is_separator(*b)).map_or(bytes.len(), |n| start + n);
    // Cut at 40 bytes so a garbage line does not flood the message; back off to a char boundary.
    let mut cut = end.min(start + 40);
    while cut > start && std::str::from_utf8(&bytes[start..cut]).is_err() {
        cut -= 1;
    }
    std::str::from_utf8(&bytes[start..cut]).unwrap_or("")
}

/// 10⁰ … 10²², the powers of ten an f64 holds exactly.
const EXACT_POWERS_OF_TEN: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
    1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
];

/// The common case of a mocap number — `-?digits[.digits][e±digits]` with at most 19
/// significant digits whose value `m · 10^e` has `m ≤ 2⁵³` and `|e| ≤ 22` — parsed in one pass:
/// `m` and `10^|e|` are then exact f64s, so the one multiplication or division rounds
/// correctly, which makes the result bit for bit what any correct parser (`fast-float2`
/// included) returns (Clinger's fast path, which fast-float2 also takes first, after more
/// general checks). Returns the value and the bytes used, or `None` for anything else
/// (a leading `+`, `inf`, `nan`, more digits, a larger exponent), which the caller hands to
/// `fast-float2`. In the AMC/BVH frame sections every number takes this path; it costs about
/// a third of `parse_partial`'s instructions (`benches/README.md`).
#[inline(always)]
fn parse_plain_decimal(bytes: &[u8]) -> Option<(f64, usize)> {
    let negative = bytes.first() == Some(&b'-');
    let mut i = usize::from(negative);
    let mut mantissa: u64 = 0;
    let mut digits = 0usize;
    while let Some(d) = bytes.get(i).map(|b| b.wrapping_sub(b'0')).filter(|d| *d < 10) {
        mantissa = mantissa.wrapping_mul(10).wrapping_add(u64::from(d));
        digits += 1;
        i += 1;
    }
    let mut exponent: i64 = 0;
    if bytes.get(i) == Some(&b'.') {
        i += 1;
        while let Some(d) = bytes.get(i).map(|b| b.wrapping_sub(b'0')).filter(|d| *d < 10) {
            mantissa = mantissa.wrapping_mul(10).wrapping_add(u64::from(d));
            digits += 1;
            exponent -= 1;
            i += 1;
        }
    }
    // 19 digits cannot overflow u64 (< 10^19 < 2^64); more may have wrapped.
    if digits == 0 || digits > 19 {
        return None;
    }
    if matches!(bytes.get(i), Some(b'e' | b'E')) {
        i += 1;
        let negative_exponent = match bytes.get(i) {
            Some(b'-') => {
                i += 1;
                true
            }
            Some(b'+') => {
                i += 1;
                false
            }
            _ => false,
        };
        let mut e: i64 = 0;
        let start = i;
        while let Some(d) = bytes.get(i).map(|b| b.wrapping_sub(b'0')).filter(|d| *d < 10) {
            // Capped so a long exponent cannot overflow; anything this large leaves the fast path.
            e = (e * 10 + i64::from(d)).min(1_000);
            i += 1;
        }
        if i == start {
            return None;
        }
        exponent += if negative_exponent { -e } else { e };
    }
    if mantissa > 1 << 53 {
        return None;
    }
    let m = mantissa as f64;
    let value = match exponent {
        0..=22 => m * EXACT_POWERS_OF_TEN[exponent as usize],
        -22..=-1 => m / EXACT_POWERS_OF_TEN[(-exponent) as usize],
        _ => return None,
    };
    Some((if negative { -value } else { value }, i))
}

/// Bytes of text the line fast path ([`read_plain_line`]) sees at once. A power of two, so an
/// index into the window is masked rather than bounds-checked per byte.
pub(crate) const LINE_WINDOW: usize = 256;

/// How far into the window a token may start: the longest token the fast path accepts
/// (19 digits, sign, point, `e±dddd`) plus a run of blanks still fits before the window ends.
const LINE_WINDOW_TOKEN_LIMIT: usize = LINE_WINDOW - 64;

/// A line's leading word as the fast path compares it: its first 16 bytes (zero-padded) and a
/// mask of the bytes that count. Words longer than 16 bytes never take the fast path.
#[derive(Clone, Copy, Debug)]
pub(crate) struct LineWord {
    bytes: u128,
    mask: u128,
    len: usize,
}

impl LineWord {
    /// `None` for a word the fast path cannot stand for: empty, longer than 16 bytes, or one the
    /// general scanner would not read as a word (blank or newline inside, or a first byte that
    /// makes the line a comment, a header or a number line).
    pub fn new(word: &[u8]) -> Option<Self> {
        let first = *word.first()?;
        if word.len() > 16
            || word.iter().any(|b| is_separator(*b))
            || first == b'#'
            || first == b':'
            || first.is_ascii_digit()
        {
            return None;
        }
        let mut padded = [0u8; 16];
        padded[..word.len()].copy_from_slice(word);
        let mask = if word.len() == 16 { u128::MAX } else { (1u128 << (8 * word.len())) - 1 };
        Some(LineWord { bytes: u128::from_le_bytes(padded), mask, len: word.len() })
    }
}

/// 10⁰ … 10⁸ as integers, to join a number's integer and fraction digits.
const POWERS_OF_TEN_U64: [u64; 9] =
    [1, 10, 100, 1_000, 10_000, 100_000, 1_000_000, 10_000_000, 100_000_000];

/// The 8 window bytes from `i` on (little-endian: byte `i` lowest), `i` ≤ `LINE_WINDOW − 8`.
#[inline(always)]
fn load8(w: &[u8; LINE_WINDOW], i: usize) -> u64 {
    let i = i.min(LINE_WINDOW - 8);
    let mut b = [0u8; 8];
    b.copy_from_slice(&w[i..i + 8]);
    u64::from_le_bytes(b)
}

/// How many of the 8 bytes of `chunk` (lowest first) are ASCII digits before the first
/// non-digit (8: all), and the bytes with `'0'` taken off (a digit byte becomes its value).
#[inline(always)]
fn leading_digits(chunk: u64) -> (usize, u64) {
    const ONES: u64 = 0x0101_0101_0101_0101;
    let t = chunk ^ (ONES * 0x30);
    // Per byte: high bit set iff the byte is not 0–9 (no carries cross bytes: ≤ 0x7F + 0x76).
    let non_digit = (((t & (ONES * 0x7F)) + ONES * 0x76) | t) & (ONES * 0x80);
    ((non_digit.trailing_zeros() / 8) as usize, t)
}

/// The value of the first `n` (1–8) digit bytes of `t` (as [`leading_digits`] returns it),
/// first byte most significant: the dropped high bytes are shifted out and the low bytes that
/// come in act as leading zeros; then three multiply-shift steps (simdjson's eight-digit parse).
#[inline(always)]
fn digits_value(t: u64, n: usize) -> u64 {
    let v = t << (8 * (8 - n));
    let v = ((v & 0x0F0F_0F0F_0F0F_0F0F).wrapping_mul(2561)) >> 8;
    let v = ((v & 0x00FF_00FF_00FF_00FF).wrapping_mul(6_553_601)) >> 16;
    ((v & 0x0000_FFFF_0000_FFFF).wrapping_mul(42_949_672_960_001)) >> 32
}

/// [`plain_decimal_in_window`] for the usual shape `-?d{1,7}(.d{0,7})?` with the digits read
/// eight bytes at a time; anything else is handed to the byte-by-byte version. Same grammar,
/// same mantissa and exponent, same final multiplication or division, so the same bits.
#[inline(always)]
fn plain_decimal_swar(w: &[u8; LINE_WINDOW], start: usize) -> Option<(f64, usize)> {
    let negative = w[start % LINE_WINDOW] == b'-';
    let int_start = start + usize::from(negative);
    let (n_int, t_int) = leading_digits(load8(w, int_start));
    if n_int == 0 || n_int == 8 {
        return plain_decimal_in_window(w, start);
    }
    let mut i = int_start + n_int;
    let mut mantissa = digits_value(t_int, n_int);
    let mut exponent: i64 = 0;
    if w[i % LINE_WINDOW] == b'.' {
        i += 1;
        let (n_frac, t_frac) = leading_digits(load8(w, i));
        if n_frac == 8 {
            return plain_decimal_in_window(w, start);
        }
        if n_frac > 0 {
            mantissa = mantissa * POWERS_OF_TEN_U64[n_frac] + digits_value(t_frac, n_frac);
        }
        i += n_frac;
        exponent = -(n_frac as i64);
    }
    if w[i % LINE_WINDOW] | 0x20 == b'e' {
        return plain_decimal_in_window(w, start);
    }
    // At most 14 digits: far below 2⁵³ (so the signed conversion, one instruction where the
    // unsigned one takes several, is exact), and 10^|exponent| ≤ 10⁷ is exact.
    let m = mantissa as i64 as f64;
    let value = if exponent == 0 {
        m * EXACT_POWERS_OF_TEN[0]
    } else {
        m / EXACT_POWERS_OF_TEN[(-exponent) as usize]
    };
    Some((if negative { -value } else { value }, i))
}

/// [`parse_plain_decimal`] on a window, with masked indices: the same grammar, limits and
/// arithmetic (so the same bits), but it gives up (`None`) on more than 19 digits or more than
/// four exponent digits instead of reading on, so it stays inside the window. Returns the
/// value and the index just past it. Kept apart from `parse_plain_decimal` on purpose: one
/// generic body over a byte accessor measured 11 % more instructions in BVH parsing and 3.5 %
/// more in the AMC fast path.
#[inline(always)]
fn plain_decimal_in_window(w: &[u8; LINE_WINDOW], start: usize) -> Option<(f64, usize)> {
    let at = |i: usize| w[i % LINE_WINDOW];
    let negative = at(start) == b'-';
    let mut i = start + usize::from(negative);
    let mut mantissa: u64 = 0;
    let integer_start = i;
    loop {
        let d = at(i).wrapping_sub(b'0');
        if d >= 10 || i - integer_start > 19 {
            break;
        }
        mantissa = mantissa.wrapping_mul(10).wrapping_add(u64::from(d));
        i += 1;
    }
    let mut digits = i - integer_start;
    let mut exponent: i64 = 0;
    if at(i) == b'.' {
        i += 1;
        let fraction_start = i;
        loop {
            let d = at(i).wrapping_sub(b'0');
            if d >= 10 || i - fraction_start > 19 {
                break;
            }
            mantissa = mantissa.wrapping_mul(10).wrapping_add(u64::from(d));
            i += 1;
        }
        digits += i - fraction_start;
        exponent = -((i - fraction_start) as i64);
    }
    if digits == 0 || digits > 19 {
        return None;
    }
    if at(i) | 0x20 == b'e' {
        i += 1;
        let negative_exponent = at(i) == b'-';
        if negative_exponent || at(i) == b'+' {
            i += 1;
        }
        let exponent_start = i;
        let mut e: i64 = 0;
        loop {
            let d = at(i).wrapping_sub(b'0');
            if d >= 10 || i - exponent_start > 4 {
                break;
            }
            e = e * 10 + i64::from(d);
            i += 1;
        }
        if i == exponent_start || i - exponent_start > 4 {
            return None;
        }
        exponent += if negative_exponent { -e } else { e };
    }
    if mantissa > 1 << 53 {
        return None;
    }
    let m = mantissa as f64;
    let value = match exponent {
        0..=22 => m * EXACT_POWERS_OF_TEN[exponent as usize],
        -22..=-1 => m / EXACT_POWERS_OF_TEN[(-exponent) as usize],
        _ => return None,
    };
    Some((if negative { -value } else { value }, i))
}

/// The usual frame line, read in one pass over a [`LINE_WINDOW`]-byte window: `word` (when
/// given), then exactly `out.len()` numbers of the [`parse_plain_decimal`] grammar, blank
/// separated, optional trailing blanks, `\n`; stores `scale[k] × value` into `out[k]`. Returns
/// the bytes used including the `\n`, or `None` for any other line (another word, a different
/// count, a number off the fast path, a line longer than the window), which the caller then
/// reads with the general scanner — which also produces any error — so this path changes
/// speed, never results: each value is the same arithmetic as [`NumberLines::read_line`]'s.
/// `out` may be partly written when it returns `None`.
#[inline(always)]
pub(crate) fn read_plain_line(
    w: &[u8; LINE_WINDOW],
    word: Option<&LineWord>,
    out: &mut [f64],
    scale: &[f64],
) -> Option<usize> {
    let at = |i: usize| w[i % LINE_WINDOW];
    let mut i = 0;
    if let Some(word) = word {
        let head = u128::from_le_bytes(*w.first_chunk::<16>()?);
        if head & word.mask != word.bytes || !is_blank(at(word.len)) {
            return None;
        }
        i = word.len;
    }
    for (slot, s) in out.iter_mut().zip(scale) {
        // A blank before every number but a line's first.
        if i > 0 && !is_blank(at(i)) {
            return None;
        }
        while is_blank(at(i)) && i < LINE_WINDOW_TOKEN_LIMIT {
            i += 1;
        }
        if i >= LINE_WINDOW_TOKEN_LIMIT {
            return None;
        }
        let (value, end) = plain_decimal_swar(w, i)?;
        *slot = value * s;
        i = end;
    }
    while is_blank(at(i)) && i < LINE_WINDOW_TOKEN_LIMIT {
        i += 1;
    }
    (at(i) == b'\n' && i < LINE_WINDOW_TOKEN_LIMIT && out.len() == scale.len()).then_some(i + 1)
}

/// The outcome of scanning one line of numbers with [`NumberLines::read_line`].
pub(crate) struct LineValues {
    /// Values found on the line (all of them, also those beyond the requested count).
    pub count: usize,
    /// The 1-based line they were on.
    pub line: usize,
}

/// A cursor over lines of whitespace-separated numbers (BVH frames, AMC bone lines).
pub(crate) struct NumberLines<'a> {
    bytes: &'a [u8],
    pos: usize,
    /// Line number of the byte at `pos`.
    line: usize,
    origin: &'a Path,
}

impl<'a> NumberLines<'a> {
    pub fn new(bytes: &'a [u8], pos: usize, line: usize, origin: &'a Path) -> Self {
        NumberLines { bytes, pos, line, origin }
    }

    pub fn line(&self) -> usize {
        self.line
    }

    /// Skips blank and empty lines. Returns false at the end of the text.
    pub fn skip_empty_lines(&mut self) -> bool {
        loop {
            while self.pos < self.bytes.len() && is_blank(self.bytes[self.pos]) {
                self.pos += 1;
            }
            match self.bytes.get(self.pos) {
                None => return false,
                Some(b'\n') => {
                    self.pos += 1;
                    self.line += 1;
                }
                Some(_) => return true,
            }
        }
    }

    /// The first blank-separated word of the current line, without consuming it.
    pub fn peek_word(&self) -> &'a [u8] {
        let start = self.pos;
        let mut end = start;
        while end < self.bytes.len() && !is_separator(self.bytes[end]) {
            end += 1;
        }
        &self.bytes[start..end]
    }

    /// The next [`LINE_WINDOW`] bytes from the cursor, `None` near the end of the text.
    #[inline(always)]
    pub fn window(&self) -> Option<&'a [u8; LINE_WINDOW]> {
        self.bytes.get(self.pos..)?.first_chunk::<LINE_WINDOW>()
    }

    /// Consumes one whole line of `used` bytes (its `\n` included), as read by
    /// [`read_plain_line`].
    #[inline(always)]
    pub fn skip_read_line(&mut self, used: usize) {
        self.pos += used;
        self.line += 1;
    }

    /// Consumes the word returned by [`Self::peek_word`].
    pub fn skip_word(&mut self, word: &[u8]) {
        self.pos += word.len();
    }

    /// Consumes the rest of the current line including its `\n`.
    pub fn skip_line(&mut self) {
        match self.bytes[self.pos..].iter().position(|b| *b == b'\n') {
            Some(n) => {
                self.pos += n + 1;
                self.line += 1;
            }
            None => self.pos = self.bytes.len(),
        }
    }

    /// Reads the numbers up to the end of the current line, storing `scale[k] × value` into
    /// `out[k]` for the first `out.len()` of them and counting the rest. Consumes the line's
    /// `\n`. Errors: a token that is not a number (`Syntax`), a NaN or infinite value
    /// (`NonFinite`), both at this line.
    #[inline]
    pub fn read_line(
        &mut self,
        out: &mut [f64],
        scale: &[f64],
        what: impl Fn() -> String,
    ) -> Result<LineValues> {
        let bytes = self.bytes;
        let line = self.line;
        let mut count = 0usize;
        let mut pos = self.pos;
        loop {
            while pos < bytes.len() && is_blank(bytes[pos]) {
                pos += 1;
            }
            if pos >= bytes.len() {
                break;
            }
            if bytes[pos] == b'\n' {
                pos += 1;
                self.line += 1;
                break;
            }
            if let Some((value, used)) = parse_plain_decimal(&bytes[pos..])
                && (pos + used >= bytes.len() || is_separator(bytes[pos + used]))
            {
                if let (Some(slot), Some(s)) = (out.get_mut(count), scale.get(count)) {
                    *slot = value * s;
                }
                count += 1;
                pos += used;
                continue;
            }
            let parsed = fast_float2::parse_partial::<f64, _>(&bytes[pos..]);
            let (value, used) = match parsed {
                Ok((v, n)) if pos + n >= bytes.len() || is_separator(bytes[pos + n]) => (v, n),
                _ => {
                    return Err(Error::at_line(
                        ErrorKind::Syntax,
                        self.origin,
                        line,
                        format!(
                            "{}: value {} is {:?}, expected a number",
                            what(),
                            count + 1,
                            token_at(bytes, pos)
                        ),
                    ));
                }
            };
            if !value.is_finite() {
                return Err(Error::at_line(
                    ErrorKind::NonFinite,
                    self.origin,
                    line,
                    format!(
                        "{}: value {} is {:?}, expected a finite number",
                        what(),
                        count + 1,
                        token_at(bytes, pos)
                    ),
                ));
            }
            if let (Some(slot), Some(s)) = (out.get_mut(count), scale.get(count)) {
                *slot = value * s;
            }
            count += 1;
            pos += used;
        }
        self.pos = pos;
        Ok(LineValues { count, line })
    }
}

/// One blank-separated word of a header, with its line.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Token<'a> {
    pub text: &'a str,
    pub line: usize,
}

/// A word tokenizer for headers (BVH HIERARCHY, ASF sections): small inputs, so clarity over
/// speed. `#` starts a comment to the end of the line when `comments` is set (ASF).
pub(crate) struct Tokens<'a> {
    text: &'a str,
    pos: usize,
    line: usize,
    comments: bool,
}

impl<'a> Tokens<'a> {
    pub fn new(text: &'a str, comments: bool) -> Self {
        Tokens { text, pos: 0, line: 1, comments }
    }

    /// Byte position just after the last consumed token.
    pub fn pos(&self) -> usize {
        self.pos
    }

    /// Line number at [`Self::pos`].
    pub fn line(&self) -> usize {
        self.line
    }

    fn skip_space(&mut self) {
        let bytes = self.text.as_bytes();
        while self.pos < bytes.len() {
            match bytes[self.pos] {
                b'\n' => {
                    self.line += 1;
                    self.pos += 1;
                }
                b if is_blank(b) => self.pos += 1,
                b'#' if self.comments => {
                    while self.pos < bytes.len() && bytes[self.pos] != b'\n' {
                        self.pos += 1;
                    }
                }
                _ => break,
            }
        }
    }

    pub fn peek(&mut self) -> Option<Token<'a>> {
        let (pos, line) = (self.pos, self.line);
        let t = self.next_token();
        self.pos = pos;
        self.line = line;
        t
    }

    pub fn next_token(&mut self) -> Option<Token<'a>> {
        self.skip_space();
        let bytes = self.text.as_bytes();
        if self.pos >= bytes.len() {
            return None;
        }
        let start = self.pos;
        while self.pos < bytes.len()
            && !is_separator(bytes[self.pos])
            && !(self.comments && bytes[self.pos] == b'#')
        {
            self.pos += 1;
        }
        Some(Token { text: &self.text[start..self.pos], line: self.line })
    }

    /// The remaining tokens on the current line (after the last consumed token).
    pub fn rest_of_line(&mut self) -> Vec<Token<'a>> {
        let line = self.line;
        let mut out = Vec::new();
        while let Some(t) = self.peek() {
            if t.line != line {
                break;
            }
            out.push(t);
            self.next_token();
        }
        out
    }
}

/// Parses a whole token as a finite f64; errors name the file, line and what the value is.
pub(crate) fn parse_f64(tok: Token<'_>, origin: &Path, what: &str) -> Result<f64> {
    match fast_float2::parse::<f64, _>(tok.text) {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(_) => Err(Error::at_line(
            ErrorKind::NonFinite,
            origin,
            tok.line,
            format!("{what} is {:?}, expected a finite number", tok.text),
        )),
        Err(_) => Err(Error::at_line(
            ErrorKind::Syntax,
            origin,
            tok.line,
            format!("{what} is {:?}, expected a number", tok.text),
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read(text: &str, n: usize) -> Result<(Vec<f64>, usize, usize)> {
        let mut out = vec![0.0; n];
        let scale = vec![2.0; n];
        let mut c = NumberLines::new(text.as_bytes(), 0, 1, Path::new("t.txt"));
        let lv = c.read_line(&mut out, &scale, || "frame".to_string())?;
        Ok((out, lv.count, c.line()))
    }

    #[test]
    fn reads_a_line_scaled_and_counts_extra_values() {
        let (v, n, line) = read("1 -2.5\t3e1\r\nnext", 3).unwrap();
        assert_eq!((v, n, line), (vec![2.0, -5.0, 60.0], 3, 2));
        let (v, n, _) = read(" 1 2 3 4 5", 2).unwrap();
        assert_eq!((v, n), (vec![2.0, 4.0], 5));
    }

    #[test]
    fn plain_decimals_parse_bit_for_bit_like_fast_float2() {
        // Hand-picked corners, then a deterministic sweep of mantissas, point positions and
        // exponents around the fast path's limits (2^53, 19 digits, |e| = 22).
        let mut cases: Vec<String> = [
            "0",
            "-0",
            "0.0",
            "-0.000",
            "1",
            "-1",
            "1.",
            ".5",
            "-.5",
            "17.3866",
            "-88.1261",
            "1.39149e-015",
            "7.95139e-016",
            "1e22",
            "1e23",
            "1e-22",
            "1e-23",
            "9007199254740992",
            "9007199254740993",
            "1234567890123456789",
            "12345678901234567890",
            "0.1",
            "0.2",
            "0.30000000000000004",
            "2.5E+3",
            "4e",
            "5e+",
            "1.5x",
            "+1",
            "inf",
            "nan",
            "00000000000000000001.5",
            "-",
            ".",
            "e5",
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        let mut x: u64 = 0x9E37_79B9_7F4A_7C15;
        for _ in 0..20_000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let digits = (x % 20 + 1) as usize;
            let m = format!("{:020}", x >> 3);
            let m = &m[m.len() - digits..];
            let point = (x >> 40) as usize % (digits + 1);
            let mut t =
                format!("{}{}.{}", if x & 1 == 0 { "-" } else { "" }, &m[..point], &m[point..]);
            if x & 2 == 0 {
                t.push_str(&format!("e{}", ((x >> 50) % 61) as i64 - 30));
            }
            cases.push(t);
        }
        let mut fast = 0;
        for t in &cases {
            let reference = fast_float2::parse_partial::<f64, _>(t.as_bytes()).ok();
            if let Some((v, n)) = parse_plain_decimal(t.as_bytes()) {
                fast += 1;
                let (rv, rn) = reference.unwrap_or_else(|| {
                    panic!("{t:?}: fast path accepted what fast-float2 refuses")
                });
                assert_eq!((v.to_bits(), n), (rv.to_bits(), rn), "{t:?}: {v} vs {rv}");
            }
        }
        // The sweep must mostly exercise the fast path, not fall back.
        assert!(fast > cases.len() / 2, "{fast} of {}", cases.len());
        // The line fast path (eight digits at a time) agrees with both wherever it accepts a
        // number, and accepts every number of the usual mocap shape.
        let mut line_fast = 0;
        for t in &cases {
            let mut window = [b' '; LINE_WINDOW];
            window[1..=t.len()].copy_from_slice(t.as_bytes());
            window[t.len() + 2] = b'\n';
            let mut out = [0.0];
            if let Some(used) = read_plain_line(&window, None, &mut out, &[1.0]) {
                line_fast += 1;
                assert_eq!(used, t.len() + 3, "{t:?}");
                let (v, _) = parse_plain_decimal(t.as_bytes()).unwrap_or_else(|| {
                    panic!("{t:?}: line path accepted what the scanner refuses")
                });
                assert_eq!(out[0].to_bits(), v.to_bits(), "{t:?}");
            }
        }
        assert!(line_fast > cases.len() / 2, "{line_fast} of {}", cases.len());
        for t in [
            "17.3866",
            "-88.1261",
            "0.17894",
            "1.39149e-015",
            "-0.000001",
            "1234567.1234567",
            "5",
            "-7.",
        ] {
            let mut window = [b' '; LINE_WINDOW];
            window[..t.len()].copy_from_slice(t.as_bytes());
            window[t.len()] = b'\n';
            let mut out = [0.0];
            assert_eq!(
                read_plain_line(&window, None, &mut out, &[1.0]),
                Some(t.len() + 1),
                "{t:?}"
            );
            assert_eq!(
                Some(out[0].to_bits()),
                parse_plain_decimal(t.as_bytes()).map(|(v, _)| v.to_bits()),
                "{t:?}"
            );
        }
        assert!(parse_plain_decimal(b"12345678901234567890").is_none());
        assert!(parse_plain_decimal(b"1e23").is_none());
        assert!(parse_plain_decimal(b"+1").is_none());
    }

    #[test]
    fn rejects_garbage_and_non_finite_values() {
        let e = read("1 2x 3\n", 3).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::Syntax);
        assert!(e.to_string().contains("t.txt:1") && e.to_string().contains("\"2x\""), "{e}");
        let e = read("1 nan 3\n", 3).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::NonFinite);
        let e = read("inf\n", 1).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::NonFinite);
    }

    #[test]
    fn tokens_track_lines_and_skip_comments() {
        let mut t = Tokens::new("a b # c\r\n\n d", true);
        assert_eq!(t.next_token(), Some(Token { text: "a", line: 1 }));
        assert_eq!(t.rest_of_line(), vec![Token { text: "b", line: 1 }]);
        assert_eq!(t.next_token(), Some(Token { text: "d", line: 3 }));
        assert_eq!(t.next_token(), None);
    }
}

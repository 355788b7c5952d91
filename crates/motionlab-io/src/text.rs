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
    let end = bytes[start..].iter().position(|b| is_separator(*b)).map_or(bytes.len(), |n| start + n);
    // Cut at 40 bytes so a garbage line does not flood the message; back off to a char boundary.
    let mut cut = end.min(start + 40);
    while cut > start && std::str::from_utf8(&bytes[start..cut]).is_err() {
        cut -= 1;
    }
    std::str::from_utf8(&bytes[start..cut]).unwrap_or("")
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
    pub fn read_line(&mut self, out: &mut [f64], scale: &[f64], what: impl Fn() -> String) -> Result<LineValues> {
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
            let parsed = fast_float2::parse_partial::<f64, _>(&bytes[pos..]);
            let (value, used) = match parsed {
                Ok((v, n)) if pos + n >= bytes.len() || is_separator(bytes[pos + n]) => (v, n),
                _ => {
                    return Err(Error::at_line(
                        ErrorKind::Syntax,
                        self.origin,
                        line,
                        format!("{}: value {} is {:?}, expected a number", what(), count + 1, token_at(bytes, pos)),
                    ));
                }
            };
            if !value.is_finite() {
                return Err(Error::at_line(
                    ErrorKind::NonFinite,
                    self.origin,
                    line,
                    format!("{}: value {} is {:?}, expected a finite number", what(), count + 1, token_at(bytes, pos)),
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
        while self.pos < bytes.len() && !is_separator(bytes[self.pos]) && !(self.comments && bytes[self.pos] == b'#') {
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
        Err(_) => {
            Err(Error::at_line(ErrorKind::Syntax, origin, tok.line, format!("{what} is {:?}, expected a number", tok.text)))
        }
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

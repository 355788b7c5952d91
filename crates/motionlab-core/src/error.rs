//! The one error type of motionlab.
//!
//! Every error says *where* (file, and line / field / byte offset when known), *what kind*
//! of problem it is (an [`ErrorKind`] that tests can assert on) and *what was expected*, in a
//! single line. Library code never panics on input-derived values: it returns one of these.

use std::fmt;
use std::path::{Path, PathBuf};

/// What kind of problem an [`Error`] reports. Tests assert on this; users read the message.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum ErrorKind {
    /// The operating system refused a read or write (missing file, permissions, disk full).
    Io,
    /// The file does not follow its format's grammar (a bad keyword, an unparsable number).
    Syntax,
    /// The file ends before its header said it would (fewer frames, a cut-off record).
    Truncated,
    /// A record holds a different number of values than the header/skeleton requires.
    WrongValueCount,
    /// A value is not a finite number where one is required (NaN, ±inf).
    NonFinite,
    /// A name refers to nothing declared (bone absent from the ASF, a missing marker).
    UnknownName,
    /// A name is declared twice (duplicate marker or joint).
    DuplicateName,
    /// A value is outside what the format or the algorithm accepts (negative scale, L = 0).
    OutOfRange,
    /// A sequence has no frames, or too few for the stage.
    EmptySequence,
    /// Samples are missing (occlusion gaps) and the stage refuses them.
    MissingData,
    /// An experiment or parameter table names a key nobody reads.
    UnknownKey,
    /// A key holds a value of the wrong type.
    WrongType,
    /// A required key is absent.
    MissingKey,
    /// No plugin is registered under that name.
    UnknownPlugin,
    /// Parameters are individually valid but inconsistent (v_low >= v_high).
    InvalidParameter,
    /// A run-directory or report problem (an existing run would be overwritten, a shard missing).
    Report,
    /// A check on results failed (a merge from shards of different configs).
    Mismatch,
    /// An input is larger than motionlab reads (a file or its decompressed content beyond the
    /// input limit, a program's output beyond its limit).
    TooLarge,
    /// An experiment names a program the user has not allowed motionlab to start.
    NotAllowed,
}

/// Where in an input a problem is.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Location {
    /// The file, as the user named it.
    pub file: Option<PathBuf>,
    /// 1-based line for text formats.
    pub line: Option<usize>,
    /// A field path: a TOML key path (`segmenter[0].v_high`), a C3D parameter (`POINT:SCALE`),
    /// a marker or bone name.
    pub field: Option<String>,
    /// Byte offset for binary formats.
    pub byte_offset: Option<u64>,
}

impl Location {
    pub fn file(file: impl AsRef<Path>) -> Self {
        Location { file: Some(file.as_ref().to_path_buf()), ..Default::default() }
    }
    pub fn line(mut self, line: usize) -> Self {
        self.line = Some(line);
        self
    }
    pub fn field(mut self, field: impl Into<String>) -> Self {
        self.field = Some(field.into());
        self
    }
    pub fn byte_offset(mut self, offset: u64) -> Self {
        self.byte_offset = Some(offset);
        self
    }
    fn is_empty(&self) -> bool {
        self.file.is_none()
            && self.line.is_none()
            && self.field.is_none()
            && self.byte_offset.is_none()
    }
}

impl fmt::Display for Location {
    /// `file:line: field` / `file (byte 1234): field` — the shape compilers use, so editors
    /// can jump to it.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut wrote = false;
        if let Some(file) = &self.file {
            write!(f, "{}", file.display())?;
            wrote = true;
        }
        if let Some(line) = self.line {
            write!(f, ":{line}")?;
            wrote = true;
        }
        if let Some(offset) = self.byte_offset {
            if wrote {
                write!(f, " ")?;
            }
            write!(f, "(byte {offset})")?;
            wrote = true;
        }
        if let Some(field) = &self.field {
            if wrote {
                write!(f, ": ")?;
            }
            write!(f, "{field}")?;
        }
        Ok(())
    }
}

/// A motionlab error: kind + location + a message that says what was found and what was expected.
///
/// Boxed so `Result<T, Error>` stays one pointer wide on the happy path.
#[derive(Debug)]
pub struct Error(Box<Inner>);

#[derive(Debug)]
struct Inner {
    kind: ErrorKind,
    location: Location,
    message: String,
    source: Option<Box<dyn std::error::Error + Send + Sync + 'static>>,
}

pub type Result<T, E = Error> = std::result::Result<T, E>;

impl Error {
    pub fn new(kind: ErrorKind, message: impl Into<String>) -> Self {
        Error(Box::new(Inner {
            kind,
            location: Location::default(),
            message: message.into(),
            source: None,
        }))
    }
    /// Shorthand for the most common case: a text format problem at `file:line`.
    pub fn at_line(
        kind: ErrorKind,
        file: impl AsRef<Path>,
        line: usize,
        message: impl Into<String>,
    ) -> Self {
        Error::new(kind, message).with_location(Location::file(file).line(line))
    }
    pub fn io(file: impl AsRef<Path>, err: std::io::Error) -> Self {
        let message = err.to_string();
        Error(Box::new(Inner {
            kind: ErrorKind::Io,
            location: Location::file(file),
            message,
            source: Some(Box::new(err)),
        }))
    }
    pub fn with_location(mut self, location: Location) -> Self {
        self.0.location = location;
        self
    }
    /// Fill in the file when the code that raised the error did not know it (a parser working
    /// on a byte buffer); an already-known file is kept.
    pub fn in_file(mut self, file: impl AsRef<Path>) -> Self {
        if self.0.location.file.is_none() {
            self.0.location.file = Some(file.as_ref().to_path_buf());
        }
        self
    }
    pub fn with_line(mut self, line: usize) -> Self {
        self.0.location.line = Some(line);
        self
    }
    pub fn with_field(mut self, field: impl Into<String>) -> Self {
        self.0.location.field = Some(field.into());
        self
    }
    /// Prefix the field path (`v_high` inside `segmenter[0]` becomes `segmenter[0].v_high`).
    pub fn under_field(mut self, prefix: impl AsRef<str>) -> Self {
        let prefix = prefix.as_ref();
        self.0.location.field = Some(match self.0.location.field.take() {
            Some(f) if !f.is_empty() => format!("{prefix}.{f}"),
            _ => prefix.to_string(),
        });
        self
    }
    pub fn with_source(mut self, source: impl std::error::Error + Send + Sync + 'static) -> Self {
        self.0.source = Some(Box::new(source));
        self
    }
    pub fn kind(&self) -> ErrorKind {
        self.0.kind
    }
    pub fn location(&self) -> &Location {
        &self.0.location
    }
    pub fn message(&self) -> &str {
        &self.0.message
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.0.location.is_empty() {
            write!(f, "{}", self.0.message)
        } else {
            write!(f, "{}: {}", self.0.location, self.0.message)
        }
    }
}

impl std::error::Error for Error {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        self.0.source.as_deref().map(|e| e as &(dyn std::error::Error + 'static))
    }
}

/// Build an error tersely: `bail!(Syntax, "expected a number, found {tok:?}")`.
#[macro_export]
macro_rules! err {
    ($kind:ident, $($fmt:tt)+) => {
        $crate::Error::new($crate::ErrorKind::$kind, format!($($fmt)+))
    };
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn display_is_one_line_with_file_line_and_field() {
        let e = Error::at_line(
            ErrorKind::WrongValueCount,
            "walk.bvh",
            190,
            "frame has 95 values, expected 96",
        )
        .with_field("MOTION");
        assert_eq!(e.to_string(), "walk.bvh:190: MOTION: frame has 95 values, expected 96");
        assert!(!e.to_string().contains('\n'));
    }

    #[test]
    fn byte_offset_and_field_paths_compose() {
        let e = err!(OutOfRange, "scale factor is 0")
            .with_location(Location::file("a.c3d").byte_offset(512))
            .with_field("SCALE")
            .under_field("POINT");
        assert_eq!(e.to_string(), "a.c3d (byte 512): POINT.SCALE: scale factor is 0");
        assert_eq!(e.kind(), ErrorKind::OutOfRange);
    }

    #[test]
    fn in_file_keeps_a_known_file() {
        let e = err!(Syntax, "x").with_location(Location::file("inner.asf")).in_file("outer.amc");
        assert_eq!(e.location().file.as_deref(), Some(Path::new("inner.asf")));
    }
}

//! The C3D container, below the level of markers and events: the 512-byte header, the
//! parameter section (groups and typed, multi-dimensional parameters), the three processor
//! number formats, and the layout of the data section (point and analog words per frame).
//!
//! Every read is bounds-checked and every failure is an [`Error`] naming the file, the byte
//! offset and, where there is one, the parameter (`POINT:SCALE`) — so a fuzzed or truncated
//! file gives a one-line error, never a panic.
//!
//! Reference: *The C3D File Format User Guide* (Motion Lab Systems, 2008), chapters 2–3.

use std::collections::HashMap;
use std::path::Path;

use motionlab_core::{Error, ErrorKind, Location, Result};

/// The bytes of one 512-byte block; block numbers in C3D are 1-based.
pub const BLOCK: usize = 512;
/// Second byte of every C3D file.
pub const KEY_BYTE: u8 = 0x50;

/// How numbers are stored, from the fourth byte of the parameter section (83 + n).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Processor {
    /// 84: little-endian integers, IEEE-754 floats.
    Intel,
    /// 85: little-endian integers, VAX F_floating floats.
    Dec,
    /// 86: big-endian integers and IEEE-754 floats (SGI/MIPS).
    Mips,
}

impl Processor {
    pub fn from_byte(b: u8) -> Option<Self> {
        match b {
            84 => Some(Processor::Intel),
            85 => Some(Processor::Dec),
            86 => Some(Processor::Mips),
            _ => None,
        }
    }
    pub fn i16(self, b: [u8; 2]) -> i16 {
        match self {
            Processor::Mips => i16::from_be_bytes(b),
            _ => i16::from_le_bytes(b),
        }
    }
    pub fn u16(self, b: [u8; 2]) -> u16 {
        self.i16(b) as u16
    }
    /// A 4-byte float widened (exactly) to f64.
    pub fn f32(self, b: [u8; 4]) -> f64 {
        match self {
            Processor::Intel => f64::from(f32::from_le_bytes(b)),
            Processor::Mips => f64::from(f32::from_be_bytes(b)),
            Processor::Dec => dec_f32(b),
        }
    }
}

/// Decodes a VAX F_floating number as DEC processors wrote it: two little-endian 16-bit words,
/// the first holding sign (bit 15), an 8-bit exponent with bias 128 (bits 14–7) and the top 7
/// fraction bits, the second the low 16 fraction bits. The value is `0.1f × 2^(e−128)` with a
/// hidden leading 1, i.e. `(1 + f/2²³) × 2^(e−129)` — a quarter of the IEEE value of the same
/// bits with the words swapped. Computed in f64, so exact. Exponent 0 is zero, or with the sign
/// set the VAX "reserved operand", returned as NaN.
pub fn dec_f32(b: [u8; 4]) -> f64 {
    let hi = u16::from_le_bytes([b[0], b[1]]);
    let lo = u16::from_le_bytes([b[2], b[3]]);
    let negative = hi & 0x8000 != 0;
    let exponent = i32::from((hi >> 7) & 0xFF);
    if exponent == 0 {
        return if negative { f64::NAN } else { 0.0 };
    }
    let fraction = (u32::from(hi & 0x7F) << 16) | u32::from(lo);
    let magnitude = (1.0 + f64::from(fraction) / f64::from(1u32 << 23)) * 2f64.powi(exponent - 129);
    if negative { -magnitude } else { magnitude }
}

/// Where errors point: the file and the byte offset (and the parameter, when there is one).
#[derive(Clone, Copy)]
pub struct Ctx<'a> {
    pub origin: &'a Path,
}

impl Ctx<'_> {
    pub fn err(&self, kind: ErrorKind, offset: usize, message: impl Into<String>) -> Error {
        Error::new(kind, message)
            .with_location(Location::file(self.origin).byte_offset(offset as u64))
    }
    pub fn param_err(
        &self,
        kind: ErrorKind,
        param: &Param<'_>,
        message: impl Into<String>,
    ) -> Error {
        self.err(kind, param.data_offset, message).with_field(param.key())
    }
}

/// The departures from the C3D letter a reading met and accepted because other readers do
/// (a parameter name with a space, a duplicated parameter, a data section the parameters
/// describe better than the header): one line of text each, for the motion's
/// [`LoadNotes`](motionlab_core::LoadNotes). A strict reading returns the error instead.
#[derive(Clone, Debug, Default)]
pub struct Repairs {
    strict: bool,
    /// The notes so far, in the order made.
    pub notes: Vec<String>,
}

impl Repairs {
    pub fn new(strict: bool) -> Self {
        Repairs { strict, notes: Vec::new() }
    }
    pub fn is_strict(&self) -> bool {
        self.strict
    }
    /// Records `note`, or, reading strictly, fails with `error()`.
    pub fn make(&mut self, note: impl Into<String>, error: impl FnOnce() -> Error) -> Result<()> {
        if self.strict {
            return Err(error());
        }
        self.notes.push(note.into());
        Ok(())
    }
}

/// The fixed header in block 1 (words are 16-bit, numbered from 1 in the C3D guide).
#[derive(Clone, Debug, PartialEq)]
pub struct Header {
    /// Word 1, low byte: the block the parameter section starts at.
    pub parameter_block: u8,
    /// Word 2: number of 3-D points per frame.
    pub point_count: u16,
    /// Word 3: analog measurements per 3-D frame (channels × samples per frame).
    pub analog_per_frame: u16,
    /// Word 4: number of the first frame (1-based).
    pub first_frame: u16,
    /// Word 5: number of the last frame.
    pub last_frame: u16,
    /// Words 7–8: point scale factor; negative means float storage.
    pub scale: f64,
    /// Word 9: the block the data section starts at.
    pub data_start_block: u16,
    /// Word 10: analog samples per 3-D frame.
    pub analog_samples_per_frame: u16,
    /// Words 11–12: 3-D frame rate, Hz.
    pub frame_rate: f64,
}

/// Byte offsets of header fields, for error locations.
pub mod header_offset {
    pub const PARAMETER_BLOCK: usize = 0;
    pub const KEY: usize = 1;
    pub const POINT_COUNT: usize = 2;
    pub const ANALOG_PER_FRAME: usize = 4;
    pub const FIRST_FRAME: usize = 6;
    pub const LAST_FRAME: usize = 8;
    pub const SCALE: usize = 12;
    pub const DATA_START: usize = 16;
    pub const FRAME_RATE: usize = 20;
}

/// A parameter's storage type (the signed type byte of its record).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ParamType {
    Char,
    Byte,
    Int16,
    Float,
}

impl ParamType {
    fn from_byte(b: i8) -> Option<Self> {
        match b {
            -1 => Some(ParamType::Char),
            1 => Some(ParamType::Byte),
            2 => Some(ParamType::Int16),
            4 => Some(ParamType::Float),
            _ => None,
        }
    }
    pub fn size(self) -> usize {
        match self {
            ParamType::Char | ParamType::Byte => 1,
            ParamType::Int16 => 2,
            ParamType::Float => 4,
        }
    }
}

/// One parameter: its raw data, decoded on access so a malformed parameter nobody reads
/// cannot fail a load.
#[derive(Clone, Debug)]
pub struct Param<'a> {
    pub group: String,
    pub name: String,
    pub kind: ParamType,
    /// Dimensions, first varying fastest (a 2 × N `EVENT:TIMES` holds minutes then seconds of
    /// event 0, then of event 1, …). Empty for a scalar.
    pub dims: Vec<usize>,
    pub data: &'a [u8],
    /// File offset of `data`.
    pub data_offset: usize,
    processor: Processor,
}

impl Param<'_> {
    /// `GROUP:NAME`, as errors name it.
    pub fn key(&self) -> String {
        format!("{}:{}", self.group, self.name)
    }
    /// Number of elements (1 for a scalar).
    pub fn len(&self) -> usize {
        self.data.len() / self.kind.size()
    }
    pub fn is_empty(&self) -> bool {
        self.data.is_empty()
    }
    /// Numeric values as f64 (any numeric type; int16 read as signed).
    pub fn floats(&self, ctx: Ctx<'_>) -> Result<Vec<f64>> {
        match self.kind {
            ParamType::Float => Ok(self
                .data
                .chunks_exact(4)
                .map(|c| self.processor.f32([c[0], c[1], c[2], c[3]]))
                .collect()),
            ParamType::Int16 => Ok(self
                .data
                .chunks_exact(2)
                .map(|c| f64::from(self.processor.i16([c[0], c[1]])))
                .collect()),
            ParamType::Byte => Ok(self.data.iter().map(|b| f64::from(*b)).collect()),
            ParamType::Char => Err(ctx.param_err(
                ErrorKind::WrongType,
                self,
                "expected a numeric parameter, found characters",
            )),
        }
    }
    /// Integer values. Int16 is read **unsigned**: the counts and frame numbers C3D stores in
    /// int16 words (`POINT:USED`, `POINT:DATA_START`, `TRIAL:ACTUAL_START_FIELD`) go to 65535
    /// and writers store them that way. A float parameter is accepted when it holds integers.
    pub fn unsigned(&self, ctx: Ctx<'_>) -> Result<Vec<u32>> {
        match self.kind {
            ParamType::Int16 => Ok(self
                .data
                .chunks_exact(2)
                .map(|c| u32::from(self.processor.u16([c[0], c[1]])))
                .collect()),
            ParamType::Byte => Ok(self.data.iter().map(|b| u32::from(*b)).collect()),
            ParamType::Float => self
                .floats(ctx)?
                .into_iter()
                .map(|v| {
                    if v.fract() == 0.0 && (0.0..=f64::from(u32::MAX)).contains(&v) {
                        Ok(v as u32)
                    } else {
                        Err(ctx.param_err(
                            ErrorKind::WrongType,
                            self,
                            format!("expected a non-negative integer, found {v}"),
                        ))
                    }
                })
                .collect(),
            ParamType::Char => Err(ctx.param_err(
                ErrorKind::WrongType,
                self,
                "expected an integer parameter, found characters",
            )),
        }
    }
    /// The first value of a numeric parameter.
    pub fn first_float(&self, ctx: Ctx<'_>) -> Result<f64> {
        self.floats(ctx)?.first().copied().ok_or_else(|| {
            ctx.param_err(
                ErrorKind::WrongValueCount,
                self,
                "expected a value, found an empty array",
            )
        })
    }
    pub fn first_unsigned(&self, ctx: Ctx<'_>) -> Result<u32> {
        self.unsigned(ctx)?.first().copied().ok_or_else(|| {
            ctx.param_err(
                ErrorKind::WrongValueCount,
                self,
                "expected a value, found an empty array",
            )
        })
    }
    /// The strings of a character parameter: the first dimension is the string length, the
    /// others multiply to the number of strings (a 0-D or 1-D array is one string). Each is
    /// trimmed of spaces and NULs at both ends. Non-UTF-8 bytes are an error at their offset.
    pub fn strings(&self, ctx: Ctx<'_>) -> Result<Vec<String>> {
        if self.kind != ParamType::Char {
            return Err(ctx.param_err(
                ErrorKind::WrongType,
                self,
                "expected a character parameter, found numbers",
            ));
        }
        let width = self.dims.first().copied().unwrap_or(1);
        if width == 0 {
            // dims like [0, 7]: seven empty strings (Vicon writes EVENT:DESCRIPTIONS so).
            let count = self.dims.iter().skip(1).product::<usize>();
            return Ok(vec![String::new(); count]);
        }
        let blank = |c: char| c == ' ' || c == '\0';
        self.data
            .chunks(width)
            .enumerate()
            .map(|(i, chunk)| match std::str::from_utf8(chunk) {
                Ok(s) => Ok(s.trim_matches(blank).to_string()),
                Err(e) => Err(ctx
                    .err(
                        ErrorKind::Syntax,
                        self.data_offset + i * width + e.valid_up_to(),
                        format!("string {} is not valid UTF-8; expected text", i + 1),
                    )
                    .with_field(self.key())),
            })
            .collect()
    }
}

/// A parsed C3D file: header and parameters, with the data section still as bytes.
pub struct C3dFile<'a> {
    pub bytes: &'a [u8],
    pub processor: Processor,
    pub header: Header,
    params: HashMap<(String, String), Param<'a>>,
    pub ctx: Ctx<'a>,
    /// What reading the parameter section repaired ([`Repairs`]); its strictness also rules
    /// [`C3dFile::data_layout`].
    pub repairs: Repairs,
}

fn take<const N: usize>(bytes: &[u8], at: usize) -> Option<[u8; N]> {
    bytes.get(at..at.checked_add(N)?)?.try_into().ok()
}

impl<'a> C3dFile<'a> {
    /// Parses the header and the whole parameter section, accepting (and noting in
    /// [`C3dFile::repairs`]) what other readers accept.
    pub fn parse(bytes: &'a [u8], origin: &'a Path) -> Result<Self> {
        Self::parse_with(bytes, origin, Repairs::new(false))
    }

    /// [`C3dFile::parse`], with the strictness (and any notes already made) of `repairs`.
    pub fn parse_with(bytes: &'a [u8], origin: &'a Path, mut repairs: Repairs) -> Result<Self> {
        let ctx = Ctx { origin };
        if bytes.len() < BLOCK {
            return Err(ctx.err(
                ErrorKind::Truncated,
                bytes.len(),
                format!(
                    "file is {} bytes; a C3D file starts with a {BLOCK}-byte header block",
                    bytes.len()
                ),
            ));
        }
        if bytes[header_offset::KEY] != KEY_BYTE {
            return Err(ctx.err(
                ErrorKind::Syntax,
                header_offset::KEY,
                format!("header key byte is 0x{:02X}; expected 0x50 (not a C3D file, or a corrupt header)", bytes[1]),
            ));
        }
        let parameter_block = bytes[header_offset::PARAMETER_BLOCK];
        let param_start = (usize::from(parameter_block).max(1) - 1) * BLOCK;
        if parameter_block < 2 || param_start + 4 > bytes.len() {
            return Err(ctx
                .err(
                    ErrorKind::OutOfRange,
                    header_offset::PARAMETER_BLOCK,
                    match bytes.len().div_ceil(BLOCK) {
                        // A file of the header block alone has no valid pointer to name.
                        n if n < 2 => format!(
                            "parameter block pointer is {parameter_block}, but the file is {} bytes and ends after its header block; expected a parameter section from block 2",
                            bytes.len()
                        ),
                        n => format!(
                            "parameter block pointer is {parameter_block}; expected a block from 2 to {n} (block 1 is the header, the file has {n} blocks)"
                        ),
                    },
                )
                .with_field("header.parameter_block"));
        }
        let processor_byte = bytes[param_start + 3];
        let processor = Processor::from_byte(processor_byte).ok_or_else(|| {
            // 0 is what a writer that never filled the parameter section leaves; ezc3d and
            // py-c3d refuse such a file too, since nothing says how its numbers are stored.
            let unset = if processor_byte == 0 { " (never set: nothing says how the numbers are stored)" } else { "" };
            ctx.err(
                ErrorKind::Syntax,
                param_start + 3,
                format!("processor type is {processor_byte}{unset}; expected 84 (Intel), 85 (DEC) or 86 (MIPS)"),
            )
            .with_field("parameters.processor")
        })?;
        // The header is 512 bytes long (checked above), so these reads cannot fail; `take`
        // keeps them panic-free regardless.
        let w = |at: usize| take::<2>(bytes, at).map(|b| processor.u16(b)).unwrap_or(0);
        let f = |at: usize| take::<4>(bytes, at).map(|b| processor.f32(b)).unwrap_or(f64::NAN);
        let header = Header {
            parameter_block,
            point_count: w(header_offset::POINT_COUNT),
            analog_per_frame: w(header_offset::ANALOG_PER_FRAME),
            first_frame: w(header_offset::FIRST_FRAME),
            last_frame: w(header_offset::LAST_FRAME),
            scale: f(header_offset::SCALE),
            data_start_block: w(header_offset::DATA_START),
            analog_samples_per_frame: w(18),
            frame_rate: f(header_offset::FRAME_RATE),
        };
        let params = parse_parameters(bytes, param_start, processor, ctx, &mut repairs)?;
        Ok(C3dFile { bytes, processor, header, params, ctx, repairs })
    }

    /// A parameter by group and name (case-insensitive, as C3D names are).
    pub fn param(&self, group: &str, name: &str) -> Option<&Param<'a>> {
        self.params.get(&(group.to_ascii_uppercase(), name.to_ascii_uppercase()))
    }

    /// Every parameter, sorted by group then name.
    pub fn params(&self) -> Vec<&Param<'a>> {
        let mut v: Vec<&Param<'a>> = self.params.values().collect();
        v.sort_by(|a, b| (&a.group, &a.name).cmp(&(&b.group, &b.name)));
        v
    }

    /// Points are stored as floats when the scale factor is negative (`POINT:SCALE`, else the
    /// header's). Zero or non-finite cannot say which, so it is an error.
    pub fn point_scale(&self) -> Result<f64> {
        let (scale, located) = match self.param("POINT", "SCALE") {
            Some(p) => (p.first_float(self.ctx)?, Some(p)),
            None => (self.header.scale, None),
        };
        if scale.is_finite() && scale != 0.0 {
            return Ok(scale);
        }
        let msg = format!(
            "point scale factor is {scale}; expected a finite non-zero number (negative = float storage)"
        );
        Err(match located {
            Some(p) => self.ctx.param_err(ErrorKind::OutOfRange, p, msg),
            None => self
                .ctx
                .err(ErrorKind::OutOfRange, header_offset::SCALE, msg)
                .with_field("header.scale"),
        })
    }

    /// Byte offset of the data section (`header` word 9, else `POINT:DATA_START`).
    pub fn data_offset(&self) -> Result<usize> {
        let block = match self.header.data_start_block {
            0 => match self.param("POINT", "DATA_START") {
                Some(p) => p.first_unsigned(self.ctx)? as usize,
                None => 0,
            },
            b => usize::from(b),
        };
        if block < 2 {
            return Err(self
                .ctx
                .err(
                    ErrorKind::OutOfRange,
                    header_offset::DATA_START,
                    format!("data start block is {block}; expected 2 or more"),
                )
                .with_field("header.data_start"));
        }
        Ok((block - 1) * BLOCK)
    }

    /// First and last frame numbers: `TRIAL:ACTUAL_START_FIELD` / `ACTUAL_END_FIELD` (two
    /// 16-bit words, low then high, so files past 65535 frames work) when present, else the
    /// header's words 4 and 5.
    pub fn frame_range(&self) -> Result<(u64, u64)> {
        let field = |name: &str, header_value: u16| -> Result<u64> {
            match self.param("TRIAL", name) {
                Some(p) => {
                    let words = p.unsigned(self.ctx)?;
                    match words.as_slice() {
                        [lo, hi, ..] => Ok(u64::from(*lo) + (u64::from(*hi) << 16)),
                        [lo] => Ok(u64::from(*lo)),
                        [] => Err(self.ctx.param_err(
                            ErrorKind::WrongValueCount,
                            p,
                            "expected two 16-bit words, found none",
                        )),
                    }
                }
                None => Ok(u64::from(header_value)),
            }
        };
        let first = field("ACTUAL_START_FIELD", self.header.first_frame)?;
        let last = field("ACTUAL_END_FIELD", self.header.last_frame)?;
        if last < first {
            // last = first − 1 is a file with no frames (a writer's empty trial), not a corrupt
            // range: reported as an empty sequence.
            let (kind, msg) = if last + 1 == first {
                (
                    ErrorKind::EmptySequence,
                    format!(
                        "no frames: last frame {last} is just before first frame {first}; expected at least one frame"
                    ),
                )
            } else {
                (
                    ErrorKind::OutOfRange,
                    format!(
                        "last frame {last} is before first frame {first}: a negative frame count"
                    ),
                )
            };
            return Err(match self.param("TRIAL", "ACTUAL_END_FIELD") {
                Some(p) => self.ctx.param_err(kind, p, msg),
                None => self
                    .ctx
                    .err(kind, header_offset::LAST_FRAME, msg)
                    .with_field("header.last_frame"),
            });
        }
        Ok((first, last))
    }

    /// The parameters' account of the data section: `POINT:USED` points, `ANALOG:USED`
    /// channels × (`ANALOG:RATE` / `POINT:RATE`) analog words per frame, from block
    /// `POINT:DATA_START`; where a parameter is absent, the header's value. When the rates give
    /// no whole number of analog samples per frame, the header's analog count, and the reason
    /// (to be said).
    fn parameter_account(&self, header: Account) -> Result<(Account, Option<String>)> {
        let ctx = self.ctx;
        let points = match self.param("POINT", "USED") {
            Some(p) => p.first_unsigned(ctx)? as usize,
            None => header.points,
        };
        let start = match self.param("POINT", "DATA_START") {
            Some(p) => match p.first_unsigned(ctx)? as usize {
                block if block >= 2 => (block - 1) * BLOCK,
                _ => header.start,
            },
            None => header.start,
        };
        let mut odd_rate = None;
        let analog_words = match self.param("ANALOG", "USED") {
            None => header.analog_words,
            Some(p) => match p.first_unsigned(ctx)? as usize {
                0 => 0,
                channels => {
                    let analog_rate = match self.param("ANALOG", "RATE") {
                        Some(p) => p.first_float(ctx)?,
                        None => f64::NAN,
                    };
                    let point_rate = match self.param("POINT", "RATE") {
                        Some(p) => p.first_float(ctx)?,
                        None => self.header.frame_rate,
                    };
                    let per_frame = analog_rate / point_rate;
                    let whole = per_frame.round();
                    if per_frame.is_finite()
                        && whole >= 1.0
                        && (per_frame - whole).abs() <= 1e-6 * whole
                    {
                        channels.saturating_mul(whole as usize)
                    } else {
                        if analog_rate.is_finite() {
                            odd_rate = Some(format!(
                                "ANALOG:RATE {analog_rate} Hz is not a whole multiple of POINT:RATE {point_rate} Hz, so the parameters give no analog word count"
                            ));
                        }
                        header.analog_words
                    }
                }
            },
        };
        Ok((Account { points, analog_words, start }, odd_rate))
    }

    /// The layout of the data section: the header's and the parameters' accounts of it
    /// (points, analog words per frame, first block) checked against the file's length.
    ///
    /// When they agree, the file must hold their frames (`Truncated` otherwise; bytes past the
    /// last frame beyond one block's padding are noted). When they differ (writers disagree
    /// with themselves: a header with 16 analog words and `ANALOG:USED` 16 × 7, `POINT:USED`
    /// 12 and a header of 11 points), the account whose frames end at the file's end — at its
    /// last byte, or in its last 512-byte block when the file is whole blocks — is used and
    /// the disagreement noted (both: the header's); when neither does, the file is refused:
    /// reading either would be a silent partial or shifted read. A strict reading
    /// ([`Repairs`]) refuses every disagreement.
    pub fn data_layout(&self) -> Result<DataLayout> {
        let scale = self.point_scale()?;
        let float = scale < 0.0;
        let word = if float { 4 } else { 2 };
        let (first, last) = self.frame_range()?;
        let n_frames = last - first + 1;
        let header = Account {
            points: usize::from(self.header.point_count),
            analog_words: usize::from(self.header.analog_per_frame),
            start: self.data_offset()?,
        };
        let (params, odd_rate) = self.parameter_account(header)?;
        let have = self.bytes.len() as u64;
        // Checked: POINT:USED and the analog rates are whatever the file says.
        let frame_bytes = |a: &Account| {
            a.points
                .checked_mul(4)
                .and_then(|w| w.checked_add(a.analog_words))
                .and_then(|w| w.checked_mul(word))
        };
        let need = |a: &Account| {
            frame_bytes(a)
                .and_then(|f| (f as u64).checked_mul(n_frames))
                .and_then(|b| b.checked_add(a.start as u64))
        };
        // An account fits when its frames end at the file's last byte, or in the file's last
        // block when the file is whole blocks (the C3D padding). Nothing looser: two accounts
        // a few words apart would both "fit" a file that ends anywhere after them.
        let block = BLOCK as u64;
        let fits = |a: &Account| {
            need(a).is_some_and(|n| {
                n == have || (have.is_multiple_of(block) && n <= have && have - n < block)
            })
        };
        let mut repairs = Repairs::new(self.repairs.is_strict());
        let strict_err = |msg: String| {
            self.ctx.err(
                ErrorKind::WrongValueCount,
                header.start,
                format!("{msg} (strict reading)"),
            )
        };
        let chosen = if header == params {
            let Some(n) = need(&header).filter(|n| *n <= have) else {
                return Err(self.truncated(
                    &header,
                    frame_bytes(&header).unwrap_or(usize::MAX),
                    n_frames,
                    need(&header),
                ));
            };
            if let Some(fact) = odd_rate {
                let note = format!(
                    "{fact}; the header's {} words per frame are used",
                    header.analog_words
                );
                repairs.make(note, || strict_err(fact).with_field("ANALOG:RATE"))?;
            }
            if have - n >= BLOCK as u64 {
                let extra = have - n;
                repairs.make(format!("{extra} bytes after the last frame (byte {n}) are not read"), || {
                    strict_err(format!("the file holds {extra} bytes after the last frame (byte {n}); expected at most a block's padding"))
                })?;
            }
            header
        } else {
            let differences = self.account_differences(&header, &params);
            let describe = |a: &Account| match (need(a), frame_bytes(a)) {
                (Some(n), Some(f)) => {
                    format!("{n_frames} frames of {f} bytes from byte {} end at byte {n}", a.start)
                }
                _ => "more bytes than 2^64".to_string(),
            };
            let (chosen, whose) = match (fits(&header), fits(&params)) {
                (true, false) => (header, "the header's"),
                (false, true) => (params, "the parameters'"),
                (true, true) => (header, "both accounts fit; the header's"),
                (false, false) => {
                    let kind = if need(&header).is_none_or(|n| n > have)
                        && need(&params).is_none_or(|n| n > have)
                    {
                        ErrorKind::Truncated
                    } else {
                        ErrorKind::WrongValueCount
                    };
                    return Err(self
                        .ctx
                        .err(
                            kind,
                            header.start,
                            format!(
                                "{differences}, and the data section fits neither account: the header's ({}) nor the parameters' ({}) ends at the file's end (byte {have}, or its last block)",
                                describe(&header),
                                describe(&params)
                            ),
                        )
                        .with_field(self.account_field(&header, &params)));
                }
            };
            let note =
                format!("{differences}: {whose} account fits the file ({have} bytes) and is used");
            repairs.make(note, || {
                strict_err(format!("{differences}; expected the header's and the parameters' accounts of the data section to agree"))
                    .with_field(self.account_field(&header, &params))
            })?;
            chosen
        };
        // `need` fits in the (in-memory) file, so these are usize-safe.
        Ok(DataLayout {
            start: chosen.start,
            float,
            scale,
            n_frames: n_frames as usize,
            first_frame: first,
            points: chosen.points,
            analog_words: chosen.analog_words,
            frame_bytes: frame_bytes(&chosen).unwrap_or(0),
            repairs: repairs.notes,
        })
    }

    /// The parameter naming the first way two accounts differ (for error locations).
    fn account_field(&self, header: &Account, params: &Account) -> &'static str {
        if header.points != params.points {
            "POINT:USED"
        } else if header.analog_words != params.analog_words {
            "ANALOG:USED"
        } else {
            "POINT:DATA_START"
        }
    }

    /// How the header's and the parameters' accounts differ, in words.
    fn account_differences(&self, header: &Account, params: &Account) -> String {
        let mut parts = Vec::new();
        if header.points != params.points {
            parts.push(format!(
                "POINT:USED is {} but the header says {} points per frame",
                params.points, header.points
            ));
        }
        if header.analog_words != params.analog_words {
            let channels = self
                .param("ANALOG", "USED")
                .and_then(|p| p.first_unsigned(self.ctx).ok())
                .unwrap_or(0);
            let from_params = if channels == 0 {
                "ANALOG:USED is 0".to_string()
            } else {
                format!(
                    "ANALOG:USED {channels} × {} samples = {}",
                    params.analog_words / channels as usize,
                    params.analog_words
                )
            };
            parts.push(format!(
                "the header says {} analog words per frame but {from_params}",
                header.analog_words
            ));
        }
        if header.start != params.start {
            parts.push(format!(
                "POINT:DATA_START is block {} but the header says block {}",
                params.start / BLOCK + 1,
                header.start / BLOCK + 1
            ));
        }
        parts.join("; ")
    }

    /// The error of a file shorter than the frames both accounts agree on, pointing at the
    /// first frame that does not fit.
    fn truncated(
        &self,
        a: &Account,
        frame_bytes: usize,
        n_frames: u64,
        need: Option<u64>,
    ) -> Error {
        let have = self.bytes.len() as u64;
        let start = a.start as u64;
        let whole =
            if frame_bytes == 0 { 0 } else { have.saturating_sub(start) / frame_bytes as u64 };
        let at = start + whole * frame_bytes as u64;
        let need_text = need.map_or_else(|| "more than 2^64".to_string(), |n| n.to_string());
        Error::new(
            ErrorKind::Truncated,
            format!(
                "file ends at byte {have} inside frame {} of {n_frames}: {n_frames} frames of {} points and {} analog values ({frame_bytes} bytes each) from byte {start} need {need_text} bytes",
                whole + 1,
                a.points,
                a.analog_words
            ),
        )
        .with_location(Location::file(self.ctx.origin).byte_offset(at))
    }

    /// Analog channel `channel` (0-based) over the whole file, in physical units:
    /// `(stored − ANALOG:OFFSET) × ANALOG:SCALE × ANALOG:GEN_SCALE`. Samples are stored
    /// sample-major within each frame (all channels of sample 1, then of sample 2, …).
    ///
    /// `ANALOG:FORMAT "UNSIGNED"` makes both the 16-bit words and the 16-bit `OFFSET` values
    /// unsigned (an offset of 32768 can only be stored so: as the word −32768 signed), as the
    /// C3D User Guide and py-c3d read them. ezc3d 1.7.2 departs from this twice: it reads
    /// unsigned words as signed and subtracts |OFFSET| (so a negative offset of a signed file
    /// is added); `bench/analog_fixtures.py` pins both differences on hand-made files.
    pub fn analog_channel(&self, layout: &DataLayout, channel: usize) -> Result<Vec<f64>> {
        let used = match self.param("ANALOG", "USED") {
            Some(p) => p.first_unsigned(self.ctx)? as usize,
            None => 0,
        };
        if channel >= used || used == 0 || !layout.analog_words.is_multiple_of(used) {
            return Err(self.ctx.err(
                ErrorKind::OutOfRange,
                header_offset::ANALOG_PER_FRAME,
                format!("analog channel {channel} requested; the file has {used} channels and {} analog values per frame", layout.analog_words),
            ));
        }
        let per_frame = layout.analog_words / used;
        let pick = |name: &str, default: f64| -> Result<f64> {
            match self.param("ANALOG", name) {
                Some(p) => {
                    let v = p.floats(self.ctx)?;
                    Ok(v.get(channel).or(v.first()).copied().unwrap_or(default))
                }
                None => Ok(default),
            }
        };
        let unsigned = match self.param("ANALOG", "FORMAT") {
            Some(p) => {
                p.strings(self.ctx)?.first().is_some_and(|s| s.eq_ignore_ascii_case("UNSIGNED"))
            }
            None => false,
        };
        let offset = match self.param("ANALOG", "OFFSET") {
            Some(p) if unsigned && p.kind == ParamType::Int16 => {
                let v = p.unsigned(self.ctx)?;
                v.get(channel).or(v.first()).map_or(0.0, |&o| f64::from(o))
            }
            _ => pick("OFFSET", 0.0)?,
        };
        let scale = pick("SCALE", 1.0)?;
        let gen_scale = match self.param("ANALOG", "GEN_SCALE") {
            Some(p) => p.first_float(self.ctx)?,
            None => 1.0,
        };
        let word = if layout.float { 4 } else { 2 };
        let mut out = Vec::with_capacity(layout.n_frames * per_frame);
        for frame in 0..layout.n_frames {
            let analog_start = layout.start + frame * layout.frame_bytes + 4 * layout.points * word;
            for s in 0..per_frame {
                let at = analog_start + (s * used + channel) * word;
                let raw = if layout.float {
                    take::<4>(self.bytes, at).map(|b| self.processor.f32(b))
                } else if unsigned {
                    take::<2>(self.bytes, at).map(|b| f64::from(self.processor.u16(b)))
                } else {
                    take::<2>(self.bytes, at).map(|b| f64::from(self.processor.i16(b)))
                };
                let raw = raw.ok_or_else(|| {
                    self.ctx.err(ErrorKind::Truncated, at, "analog sample past the end of the file")
                })?;
                out.push((raw - offset) * scale * gen_scale);
            }
        }
        Ok(out)
    }
}

/// One account of the data section: the header's or the parameters'.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Account {
    points: usize,
    analog_words: usize,
    /// Byte offset of frame 0.
    start: usize,
}

/// Where the frames are and how they are stored.
#[derive(Clone, Debug, PartialEq)]
pub struct DataLayout {
    /// Byte offset of frame 0.
    pub start: usize,
    /// Float storage (scale < 0) or 16-bit integers.
    pub float: bool,
    /// The point scale factor (multiplies integer coordinates and, as |scale|, residuals).
    pub scale: f64,
    pub n_frames: usize,
    /// Frame number of the first stored frame.
    pub first_frame: u64,
    pub points: usize,
    /// Analog words per frame (they follow the points of each frame and are skipped).
    pub analog_words: usize,
    pub frame_bytes: usize,
    /// How the header's and the parameters' accounts of the data section were reconciled,
    /// when they needed to be ([`C3dFile::data_layout`]).
    pub repairs: Vec<String>,
}

/// Parses the parameter section starting at byte `start` (the 4-byte block header, then
/// group and parameter records chained by "offset to next" words until a zero name length, a
/// zero offset, or an offset past the section's end).
///
/// Accepted as other readers accept them, each noted in `repairs`: names with spaces
/// (`Splines Fitted`), a last record whose offset points past the section (SGI/MIPS writers;
/// py-c3d stops at the section's end likewise), and a parameter defined twice in one group
/// (per-subject groups of some writers; the first definition is kept, as ezc3d keeps it).
fn parse_parameters<'a>(
    bytes: &'a [u8],
    start: usize,
    processor: Processor,
    ctx: Ctx<'_>,
    repairs: &mut Repairs,
) -> Result<HashMap<(String, String), Param<'a>>> {
    let truncated = |at: usize, what: &str| {
        ctx.err(
            ErrorKind::Truncated,
            at,
            format!(
                "parameter section ends inside {what}; expected a complete record or an end marker"
            ),
        )
    };
    // The section ends where the data section starts (header word 9), or after the blocks
    // its byte 3 declares if that is later: some writers declare too few (the c3d.org FP1
    // sample's last groups lie past its 3 declared blocks; ezc3d reads them too). With
    // neither (0 blocks and no data start past it), nothing bounds the chain.
    let declared_end =
        bytes.get(start + 2).map_or(0, |&blocks| start + usize::from(blocks) * BLOCK);
    let data_start = take::<2>(bytes, header_offset::DATA_START)
        .map_or(0, |w| (usize::from(processor.u16(w)).max(1) - 1) * BLOCK);
    let section_end = Some(declared_end.max(data_start)).filter(|&end| end > start);
    let mut groups: HashMap<u8, String> = HashMap::new();
    // (group id, param) with the group name filled in once every group record is seen:
    // C3D allows a parameter before its group.
    let mut pending: Vec<(u8, Param<'a>)> = Vec::new();
    let mut spaced: Vec<String> = Vec::new();
    let mut pos = start + 4;
    loop {
        let [name_len, group_id] =
            take::<2>(bytes, pos).ok_or_else(|| truncated(pos, "a record header"))?;
        let name_len = usize::from((name_len as i8).unsigned_abs());
        let group_id = group_id as i8;
        if name_len == 0 {
            break;
        }
        let name_bytes =
            bytes.get(pos + 2..pos + 2 + name_len).ok_or_else(|| truncated(pos + 2, "a name"))?;
        if let Some(k) = name_bytes.iter().position(|b| !(b.is_ascii_graphic() || *b == b' ')) {
            return Err(ctx.err(
                ErrorKind::Syntax,
                pos + 2 + k,
                format!(
                    "byte 0x{:02X} in a group or parameter name; expected printable ASCII (letters, digits, punctuation or spaces) in a name like POINT",
                    name_bytes[k]
                ),
            ));
        }
        // Checked above: every byte is printable ASCII.
        let written = String::from_utf8_lossy(name_bytes).into_owned();
        let name = written.to_ascii_uppercase();
        if written.contains(' ') {
            if repairs.is_strict() {
                return Err(ctx.err(ErrorKind::Syntax, pos + 2, format!("name {written:?} has a space; C3D names are letters, digits and _ (strict reading)")));
            }
            spaced.push(written);
        }
        let next_at = pos + 2 + name_len;
        let next = take::<2>(bytes, next_at)
            .map(|b| processor.i16(b))
            .ok_or_else(|| truncated(next_at, "an offset word"))?;
        let body = next_at + 2;
        let record_end = if group_id < 0 {
            let desc_len = usize::from(
                *bytes.get(body).ok_or_else(|| truncated(body, "a group description"))?,
            );
            let id = group_id.unsigned_abs();
            if let Some(old) = groups.insert(id, name.clone()) {
                return Err(ctx.err(
                    ErrorKind::DuplicateName,
                    pos,
                    format!("group id {id} is defined twice ({old} and {name})"),
                ));
            }
            body + 1 + desc_len
        } else if group_id > 0 {
            let [type_byte, n_dims] =
                take::<2>(bytes, body).ok_or_else(|| truncated(body, "a parameter type"))?;
            let kind = ParamType::from_byte(type_byte as i8).ok_or_else(|| {
                ctx.err(
                    ErrorKind::Syntax,
                    body,
                    format!(
                        "parameter {name}: type byte is {}; expected -1, 1, 2 or 4",
                        type_byte as i8
                    ),
                )
            })?;
            let n_dims = usize::from(n_dims);
            let dims: Vec<usize> = bytes
                .get(body + 2..body + 2 + n_dims)
                .ok_or_else(|| truncated(body + 2, "parameter dimensions"))?
                .iter()
                .map(|d| usize::from(*d))
                .collect();
            // At most 7 dimensions of at most 255: the product fits in u64, and in usize on
            // 64-bit targets; checked anyway.
            let size = dims.iter().try_fold(kind.size(), |acc, d| acc.checked_mul(*d));
            let data_offset = body + 2 + n_dims;
            let data = size
                .and_then(|s| bytes.get(data_offset..data_offset.checked_add(s)?))
                .ok_or_else(|| truncated(data_offset, &format!("the data of parameter {name}")))?;
            let desc_at = data_offset + data.len();
            let desc_len = usize::from(
                *bytes.get(desc_at).ok_or_else(|| truncated(desc_at, "a parameter description"))?,
            );
            pending.push((
                group_id.unsigned_abs(),
                Param {
                    group: String::new(),
                    name: name.clone(),
                    kind,
                    dims,
                    data,
                    data_offset,
                    processor,
                },
            ));
            desc_at + 1 + desc_len
        } else {
            return Err(ctx.err(
                ErrorKind::Syntax,
                pos + 1,
                format!(
                    "record {name} has group id 0; expected a group (< 0) or parameter (> 0) id"
                ),
            ));
        };
        if next == 0 {
            break;
        }
        let next_pos = usize::try_from(next).ok().map(|n| next_at + n);
        match next_pos {
            Some(p) if p >= record_end => {
                if let Some(end) = section_end
                    && p >= end
                {
                    let what = format!("record {name}'s offset to the next record ({next}) points to byte {p}, past the parameter section's end at byte {end}");
                    repairs.make(format!("{what}; read as the last record"), || ctx.err(ErrorKind::Syntax, next_at, format!("{what} (strict reading)")))?;
                    break;
                }
                pos = p;
            }
            // The chain must move forward past this record, or a corrupt file could loop.
            _ => {
                return Err(ctx.err(
                    ErrorKind::Syntax,
                    next_at,
                    format!("record {name}: offset to next record is {next}; expected 0 or a forward offset past the record"),
                ))
            }
        }
    }
    if !spaced.is_empty() {
        let quoted: Vec<String> = spaced.iter().map(|n| format!("{n:?}")).collect();
        repairs
            .notes
            .push(format!("group or parameter names with spaces accepted: {}", quoted.join(", ")));
    }
    let mut params = HashMap::with_capacity(pending.len());
    let mut twice: Vec<String> = Vec::new();
    for (id, mut p) in pending {
        p.group = groups.get(&id).cloned().unwrap_or_else(|| format!("GROUP{id}"));
        let key = (p.group.clone(), p.name.clone());
        if params.contains_key(&key) {
            if repairs.is_strict() {
                return Err(ctx
                    .err(
                        ErrorKind::DuplicateName,
                        p.data_offset,
                        "parameter is defined twice (strict reading)",
                    )
                    .with_field(p.key()));
            }
            twice.push(p.key());
            continue;
        }
        params.insert(key, p);
    }
    if !twice.is_empty() {
        let shown: Vec<&str> = twice.iter().take(5).map(String::as_str).collect();
        let more = if twice.len() > shown.len() {
            format!(" and {} more", twice.len() - shown.len())
        } else {
            String::new()
        };
        repairs.notes.push(format!(
            "{} parameters defined twice, the first definition of each kept: {}{more}",
            twice.len(),
            shown.join(", ")
        ));
    }
    Ok(params)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dec_floats_decode_known_values() {
        // VAX F_floating 1.0 is stored 80 40 00 00 (exponent 129, fraction 0).
        assert_eq!(dec_f32([0x80, 0x40, 0x00, 0x00]), 1.0);
        // −2.5 = −1.25 × 2^1: sign 1, exponent 130 (0x82), fraction 0.25 × 2^23 = 0x200000.
        // hi word = 0x8000 | 0x82 << 7 | 0x20 = 0xC120, lo word 0.
        assert_eq!(dec_f32([0x20, 0xC1, 0x00, 0x00]), -2.5);
        assert_eq!(dec_f32([0, 0, 0, 0]), 0.0);
        assert!(dec_f32([0, 0x80, 0, 0]).is_nan());
        // The known relation: DEC value = IEEE value of the word-swapped bits / 4.
        for v in [0.1f32, 123.456, -9876.5, 1.0e-3, 3.0e7] {
            let ieee = v.to_le_bytes();
            let mut dec = [ieee[2], ieee[3], ieee[0], ieee[1]];
            // Multiply by 4 = add 2 to the exponent (bits 7.. of the first word).
            let hi = u16::from_le_bytes([dec[0], dec[1]]) + (2 << 7);
            dec[0..2].copy_from_slice(&hi.to_le_bytes());
            assert_eq!(dec_f32(dec), f64::from(v), "{v}");
        }
    }

    #[test]
    fn mips_and_intel_byte_orders() {
        assert_eq!(Processor::Mips.f32([0x3F, 0x80, 0, 0]), 1.0);
        assert_eq!(Processor::Intel.f32([0, 0, 0x80, 0x3F]), 1.0);
        assert_eq!(Processor::Mips.i16([0xFF, 0xFE]), -2);
        assert_eq!(Processor::Intel.i16([0xFE, 0xFF]), -2);
        assert_eq!(Processor::Intel.u16([0xFF, 0xFF]), 65535);
    }
}

//! A minimal C3D writer for unit tests: hand-made files with known content, in any processor
//! format and storage, plus hooks to corrupt them. Written from the C3D User Guide layout,
//! independently of the reader's helpers (the DEC encoding is anchored by the known-answer
//! test in `raw.rs`).

use super::raw::{BLOCK, Processor};

/// One parameter record to write: group name, name, type byte, dimensions, raw data bytes.
#[derive(Clone, Debug)]
pub struct RawParam {
    pub group: &'static str,
    pub name: String,
    pub type_byte: i8,
    pub dims: Vec<u8>,
    pub data: Vec<u8>,
}

#[derive(Clone, Debug)]
pub struct C3dSpec {
    pub processor: Processor,
    /// Negative: float storage.
    pub scale: f32,
    pub rate: f32,
    pub first_frame: u16,
    pub labels: Vec<String>,
    /// `frames[f][p] = (x, y, z, residual)`, in file units (integer files store x / scale).
    pub frames: Vec<Vec<[f32; 4]>>,
    /// Analog words per frame (written as a recognisable filler that must be skipped).
    pub analog_per_frame: u16,
    pub units: Option<&'static str>,
    /// (label, context, minutes, seconds)
    pub events: Vec<(&'static str, &'static str, f32, f32)>,
    /// Extra or replacement parameters (a replacement has the same group and name).
    pub extra: Vec<RawParam>,
    /// Leave these standard parameters out.
    pub omit: Vec<&'static str>,
}

impl C3dSpec {
    /// Two markers `a`, `b` over three frames, Intel float storage at 100 Hz, frame 1 first.
    pub fn small() -> Self {
        C3dSpec {
            processor: Processor::Intel,
            scale: -0.1,
            rate: 100.0,
            first_frame: 1,
            labels: vec!["a".into(), "b".into()],
            frames: vec![
                vec![[1.0, 2.0, 3.0, 0.5], [10.0, 20.0, 30.0, 1.0]],
                vec![[1.5, 2.5, 3.5, 0.0], [11.0, 21.0, 31.0, -1.0]],
                vec![[2.0, 3.0, 4.0, 0.2], [12.0, 22.0, 32.0, 0.7]],
            ],
            analog_per_frame: 0,
            units: Some("mm"),
            events: Vec::new(),
            extra: Vec::new(),
            omit: Vec::new(),
        }
    }

    fn i16(&self, v: i16) -> [u8; 2] {
        match self.processor {
            Processor::Mips => v.to_be_bytes(),
            _ => v.to_le_bytes(),
        }
    }

    fn f32(&self, v: f32) -> [u8; 4] {
        match self.processor {
            Processor::Intel => v.to_le_bytes(),
            Processor::Mips => v.to_be_bytes(),
            Processor::Dec => {
                if v == 0.0 {
                    return [0; 4];
                }
                // VAX F = IEEE with the 16-bit words swapped and the exponent raised by 2.
                let bits = v.to_bits();
                let hi = ((bits >> 16) as u16) + (2 << 7);
                let lo = bits as u16;
                let [a, b] = hi.to_le_bytes();
                let [c, d] = lo.to_le_bytes();
                [a, b, c, d]
            }
        }
    }

    fn chars(group: &'static str, name: &str, width: usize, strings: &[&str]) -> RawParam {
        let mut data = Vec::new();
        for s in strings {
            let mut b = s.as_bytes().to_vec();
            b.resize(width, b' ');
            data.extend(b);
        }
        let dims = if strings.len() == 1 {
            vec![width as u8]
        } else {
            vec![width as u8, strings.len() as u8]
        };
        RawParam { group, name: name.to_string(), type_byte: -1, dims, data }
    }

    fn ints(&self, group: &'static str, name: &str, values: &[i16]) -> RawParam {
        let data = values.iter().flat_map(|v| self.i16(*v)).collect();
        let dims = if values.len() == 1 { vec![] } else { vec![values.len() as u8] };
        RawParam { group, name: name.to_string(), type_byte: 2, dims, data }
    }

    fn floats(&self, group: &'static str, name: &str, dims: Vec<u8>, values: &[f32]) -> RawParam {
        let data = values.iter().flat_map(|v| self.f32(*v)).collect();
        RawParam { group, name: name.to_string(), type_byte: 4, dims, data }
    }

    /// The standard parameters for this spec, then `extra` (replacing same-named ones).
    fn params(&self) -> Vec<RawParam> {
        let n_points = self.frames.first().map_or(self.labels.len(), Vec::len);
        let last = self.first_frame as i16 + self.frames.len() as i16 - 1;
        let width = self.labels.iter().map(String::len).max().unwrap_or(1).max(1);
        let labels: Vec<&str> = self.labels.iter().map(String::as_str).collect();
        let mut v = vec![
            self.ints("POINT", "USED", &[n_points as i16]),
            self.floats("POINT", "SCALE", vec![], &[self.scale]),
            self.floats("POINT", "RATE", vec![], &[self.rate]),
            Self::chars("POINT", "LABELS", width, &labels),
            self.ints("POINT", "FRAMES", &[self.frames.len() as i16]),
            self.ints("TRIAL", "ACTUAL_START_FIELD", &[self.first_frame as i16, 0]),
            self.ints("TRIAL", "ACTUAL_END_FIELD", &[last, 0]),
        ];
        if let Some(u) = self.units {
            v.push(Self::chars("POINT", "UNITS", u.len().max(1), &[u]));
        }
        if !self.events.is_empty() {
            let n = self.events.len();
            let lw = self.events.iter().map(|e| e.0.len()).max().unwrap_or(1);
            let cw = self.events.iter().map(|e| e.1.len()).max().unwrap_or(1);
            let labels: Vec<&str> = self.events.iter().map(|e| e.0).collect();
            let contexts: Vec<&str> = self.events.iter().map(|e| e.1).collect();
            let times: Vec<f32> = self.events.iter().flat_map(|e| [e.2, e.3]).collect();
            v.push(self.ints("EVENT", "USED", &[n as i16]));
            let mut l = Self::chars("EVENT", "LABELS", lw, &labels);
            l.dims = vec![lw as u8, n as u8];
            let mut c = Self::chars("EVENT", "CONTEXTS", cw, &contexts);
            c.dims = vec![cw as u8, n as u8];
            v.push(l);
            v.push(c);
            v.push(self.floats("EVENT", "TIMES", vec![2, n as u8], &times));
        }
        v.retain(|p| !self.omit.contains(&format!("{}:{}", p.group, p.name).as_str()));
        for e in &self.extra {
            v.retain(|p| !(p.group == e.group && p.name == e.name));
            v.push(e.clone());
        }
        v
    }

    pub fn raw_ints(&self, group: &'static str, name: &str, values: &[i16]) -> RawParam {
        self.ints(group, name, values)
    }
    pub fn raw_floats(
        &self,
        group: &'static str,
        name: &str,
        dims: Vec<u8>,
        values: &[f32],
    ) -> RawParam {
        self.floats(group, name, dims, values)
    }
    pub fn raw_chars(group: &'static str, name: &str, width: usize, strings: &[&str]) -> RawParam {
        Self::chars(group, name, width, strings)
    }

    /// The file's bytes.
    pub fn build(&self) -> Vec<u8> {
        let params = self.params();
        let mut groups: Vec<&'static str> = Vec::new();
        for p in &params {
            if !groups.contains(&p.group) {
                groups.push(p.group);
            }
        }
        let gid = |g: &str| groups.iter().position(|x| *x == g).map_or(0, |i| i as i8 + 1);
        let mut sec = vec![
            1u8,
            0x50,
            0,
            83 + match self.processor {
                Processor::Intel => 1,
                Processor::Dec => 2,
                Processor::Mips => 3,
            },
        ];
        for g in &groups {
            sec.push(g.len() as u8);
            sec.push((-gid(g)) as u8);
            sec.extend(g.as_bytes());
            sec.extend(self.i16(3)); // offset word + 1 description-length byte
            sec.push(0);
        }
        for p in &params {
            sec.push(p.name.len() as u8);
            sec.push(gid(p.group) as u8);
            sec.extend(p.name.as_bytes());
            let next = 2 + 2 + p.dims.len() + p.data.len() + 1;
            sec.extend(self.i16(next as i16));
            sec.push(p.type_byte as u8);
            sec.push(p.dims.len() as u8);
            sec.extend(&p.dims);
            sec.extend(&p.data);
            sec.push(0);
        }
        sec.extend([0, 0]); // end marker: name length 0
        let param_blocks = sec.len().div_ceil(BLOCK);
        sec[2] = param_blocks as u8;
        sec.resize(param_blocks * BLOCK, 0);
        let data_start = 2 + param_blocks;

        let n_points = self.frames.first().map_or(0, Vec::len);
        let mut header = vec![0u8; BLOCK];
        header[0] = 2;
        header[1] = 0x50;
        let put16 =
            |h: &mut Vec<u8>, at: usize, v: i16| h[at..at + 2].copy_from_slice(&self.i16(v));
        put16(&mut header, 2, n_points as i16);
        put16(&mut header, 4, self.analog_per_frame as i16);
        put16(&mut header, 6, self.first_frame as i16);
        put16(
            &mut header,
            8,
            (self.first_frame as usize + self.frames.len()).saturating_sub(1) as i16,
        );
        header[12..16].copy_from_slice(&self.f32(self.scale));
        put16(&mut header, 16, data_start as i16);
        header[20..24].copy_from_slice(&self.f32(self.rate));

        let mut out = header;
        out.extend(sec);
        for frame in &self.frames {
            for p in frame {
                if self.scale < 0.0 {
                    for v in p {
                        out.extend(self.f32(*v));
                    }
                } else {
                    for v in &p[..3] {
                        out.extend(self.i16((v / self.scale).round() as i16));
                    }
                    out.extend(self.i16(p[3].round() as i16));
                }
            }
            for k in 0..self.analog_per_frame {
                // A filler that would read as huge coordinates if the stride ignored it.
                if self.scale < 0.0 {
                    out.extend(self.f32(9999.0 + f32::from(k)));
                } else {
                    out.extend(self.i16(32000));
                }
            }
        }
        out
    }
}

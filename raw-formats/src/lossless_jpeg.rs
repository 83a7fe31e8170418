//! Lossless JPEG (ITU T.81 process 14: SOF3, Huffman-coded differences of predictions), the
//! compression of most camera DNGs (Compression 7): a decoder and an encoder.
//!
//! The decoder takes what DNG writers produce: predictors 1 to 7, a point transform, restart
//! markers at whole lines, 1 to 4 interleaved components (each sampled 1x1), 2- to 16-bit
//! precision, up to four Huffman tables. It writes the samples in decoding order (line by
//! line, components interleaved), which is how a DNG lays a tile out whatever shape the JPEG
//! frame has (a CFA tile of width W may be a frame W/2 wide with 2 components, or 2W wide and
//! half as tall with 1). Every size is checked before anything is written, and the caller
//! hands in the output buffer, so a hostile header cannot make it allocate.
//!
//! The encoder (one scan, one Huffman table per component built from the data by the
//! procedure of T.81 Annex K.2) exists so camsim can write compressed DNGs and so the decoder
//! is tested on every predictor, depth and layout; it is not tuned for size.
//!
//! ```
//! use raw_formats::lossless_jpeg::{self, Frame};
//! let frame = Frame { precision: 12, lines: 2, samples_per_line: 3, components: 2 };
//! let samples: Vec<u16> = (0..12).map(|i| (i * 331) % 4096).collect();
//! let bytes = lossless_jpeg::encode(&samples, frame, 6, 0, 0).unwrap();
//! let mut out = vec![0u16; 12];
//! assert_eq!(lossless_jpeg::decode(&bytes, &mut out).unwrap(), frame);
//! assert_eq!(out, samples);
//! ```

use crate::error::{FormatError, Result};

/// A lossless JPEG frame's shape (its SOF3 header).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Frame {
    /// Sample precision P in bits, 2..=16.
    pub precision: u8,
    /// Number of lines Y (at least 1: a DNL marker is not supported).
    pub lines: u16,
    /// Samples per line X, per component.
    pub samples_per_line: u16,
    /// Components Nf, 1..=4, interleaved in one scan.
    pub components: u8,
}

impl Frame {
    /// Samples the frame decodes to: lines x samples per line x components.
    pub fn sample_count(&self) -> usize {
        usize::from(self.lines) * usize::from(self.samples_per_line) * usize::from(self.components)
    }
}

fn error(offset: usize, problem: &'static str) -> FormatError {
    FormatError::LosslessJpeg { offset, problem }
}

// T.81 Table B.1's markers, shared with the DCT decoder.
pub(crate) const SOI: u8 = 0xd8;
const EOI: u8 = 0xd9;
const SOF3: u8 = 0xc3;
pub(crate) const DHT: u8 = 0xc4;
pub(crate) const SOS: u8 = 0xda;
pub(crate) const DRI: u8 = 0xdd;
const RST0: u8 = 0xd0;

/// Whether `marker` starts a frame header (SOF0..SOF15; C4, C8 and CC are DHT, JPG and DAC).
pub(crate) fn is_frame_header(marker: u8) -> bool {
    matches!(marker, 0xc0..=0xcf) && !matches!(marker, DHT | 0xc8 | 0xcc)
}

/// Bits the decoding table resolves in one look-up; longer codes take the slow path.
const LOOKUP_BITS: u32 = 10;

/// A Huffman table of T.81 Annex C, with a look-up table for the short codes.
#[derive(Clone)]
pub(crate) struct Huffman {
    /// By the next `LOOKUP_BITS` bits: `length << 8 | value`, or 0 for a longer code.
    lookup: Vec<u16>,
    /// Per code length 1..=16: the largest code of that length (-1 if none), and where its
    /// values start in `values` minus the smallest code.
    max_code: [i32; 17],
    value_offset: [i32; 17],
    values: Vec<u8>,
}

impl Huffman {
    /// From a DHT segment's 16 counts and its values; `at` is the segment's offset for errors.
    pub(crate) fn new(counts: &[u8; 16], values: &[u8], at: usize) -> Result<Self> {
        let mut lookup = vec![0u16; 1 << LOOKUP_BITS];
        let mut max_code = [-1i32; 17];
        let mut value_offset = [0i32; 17];
        let (mut code, mut k) = (0i32, 0usize);
        for len in 1..=16usize {
            let n = usize::from(counts[len - 1]);
            if n > 0 {
                value_offset[len] = k as i32 - code;
                for _ in 0..n {
                    // A code of `len` bits must fit in `len` bits: the table is over-full.
                    if code >= 1 << len {
                        return Err(error(at, "Huffman table has more codes than fit"));
                    }
                    let value = values[k];
                    if len as u32 <= LOOKUP_BITS {
                        let shift = LOOKUP_BITS - len as u32;
                        let first = (code as usize) << shift;
                        for slot in &mut lookup[first..first + (1 << shift)] {
                            *slot = (len as u16) << 8 | u16::from(value);
                        }
                    }
                    code += 1;
                    k += 1;
                }
                max_code[len] = code - 1;
            }
            code <<= 1;
        }
        Ok(Self {
            lookup,
            max_code,
            value_offset,
            values: values.to_vec(),
        })
    }

    /// The next value (a difference category); the reader holds at least 16 bits.
    #[inline(always)]
    pub(crate) fn decode(&self, bits: &mut BitReader) -> Result<u8> {
        let entry = self.lookup[bits.peek(LOOKUP_BITS) as usize];
        if entry != 0 {
            bits.consume(u32::from(entry >> 8));
            return Ok(entry as u8);
        }
        for len in LOOKUP_BITS as usize + 1..=16 {
            let code = bits.peek(len as u32) as i32;
            if code <= self.max_code[len] {
                bits.consume(len as u32);
                let index = (self.value_offset[len] + code) as usize;
                return self
                    .values
                    .get(index)
                    .copied()
                    .ok_or(error(bits.pos, "bad Huffman code"));
            }
        }
        Err(error(bits.pos, "bad Huffman code"))
    }
}

/// Reads entropy-coded bits most significant first, removing stuffed zero bytes (FF 00) and
/// stopping at a marker: past it, it reads zeros and counts them, so running out of data is
/// an error, not a read out of bounds.
pub(crate) struct BitReader<'a> {
    data: &'a [u8],
    pos: usize,
    acc: u64,
    count: u32,
    /// Bytes of zeros fed in past a marker or the end.
    padding: u32,
}

impl<'a> BitReader<'a> {
    pub(crate) fn new(data: &'a [u8], pos: usize) -> Self {
        Self {
            data,
            pos,
            acc: 0,
            count: 0,
            padding: 0,
        }
    }

    /// Tops the buffer up to at least 57 bits.
    #[inline(always)]
    pub(crate) fn refill(&mut self) {
        while self.count <= 56 {
            let mut byte = 0u8;
            match self.data.get(self.pos) {
                Some(0xff) => {
                    if self.data.get(self.pos + 1) == Some(&0) {
                        byte = 0xff;
                        self.pos += 2;
                    } else {
                        self.padding += 1;
                    }
                }
                Some(b) => {
                    byte = *b;
                    self.pos += 1;
                }
                None => self.padding += 1,
            }
            self.acc |= u64::from(byte) << (56 - self.count);
            self.count += 8;
        }
    }

    #[inline(always)]
    fn peek(&self, n: u32) -> u32 {
        (self.acc >> (64 - n)) as u32
    }

    #[inline(always)]
    fn consume(&mut self, n: u32) {
        self.acc <<= n;
        self.count -= n;
    }

    #[inline(always)]
    pub(crate) fn take(&mut self, n: u32) -> u32 {
        if n == 0 {
            return 0;
        }
        let v = self.peek(n);
        self.consume(n);
        v
    }

    /// The byte the reader has read up to.
    pub(crate) fn position(&self) -> usize {
        self.pos
    }

    /// Whether bits past the data's end were consumed: the scan was cut short.
    pub(crate) fn overran(&self) -> bool {
        u64::from(self.padding) * 8 > u64::from(self.count)
    }

    /// At a restart: drops the interval's padding bits and steps over the marker `RSTn`.
    pub(crate) fn restart(&mut self, n: u8) -> Result<()> {
        if self.overran() {
            return Err(error(self.pos, "scan data ends early"));
        }
        // The bytes in the buffer are the interval's padding; the marker follows them.
        let mut at = self.pos;
        while at + 1 < self.data.len() && !(self.data[at] == 0xff && self.data[at + 1] != 0) {
            at += 1;
        }
        while self.data.get(at + 1) == Some(&0xff) {
            at += 1; // fill bytes before the marker
        }
        if self.data.get(at) != Some(&0xff) || self.data.get(at + 1) != Some(&(RST0 + n)) {
            return Err(error(at, "expected restart marker missing"));
        }
        *self = Self::new(self.data, at + 2);
        Ok(())
    }
}

/// The difference coded by category `s` (T.81 H.1.2.2 and F.1.2.1.1): `s` more bits, or
/// 32768 for category 16, which has none.
#[inline(always)]
fn difference(s: u8, bits: &mut BitReader) -> i32 {
    match s {
        0 => 0,
        16 => 32768,
        _ => {
            let s = u32::from(s & 15);
            let v = bits.take(s) as i32;
            if v < 1 << (s - 1) {
                v - (1 << s) + 1
            } else {
                v
            }
        }
    }
}

/// The prediction of T.81 Table H.1 for selection value `P` from the samples left (a),
/// above (b) and above-left (c).
#[inline(always)]
fn predict<const P: u8>(a: i32, b: i32, c: i32) -> i32 {
    match P {
        1 => a,
        2 => b,
        3 => c,
        4 => a + b - c,
        5 => a + ((b - c) >> 1),
        6 => b + ((a - c) >> 1),
        _ => (a + b) >> 1,
    }
}

/// Where the scan's parameters live once the headers are parsed.
struct Scan<'t> {
    tables: [&'t Huffman; 4],
    components: usize,
    /// Prediction of the first sample of the frame and of each restart interval.
    initial: i32,
}

impl Scan<'_> {
    /// Decodes one line (`line.len()` = samples per line x components). `above` is the line
    /// before, or `None` for the first line of the frame or of a restart interval (which
    /// predicts from the left, T.81 H.1.2.1).
    #[inline(always)]
    fn line<const P: u8>(
        &self,
        bits: &mut BitReader,
        above: Option<&[u16]>,
        line: &mut [u16],
    ) -> Result<()> {
        let n = self.components;
        for c in 0..n {
            bits.refill();
            let s = self.tables[c].decode(bits)?;
            let start = match above {
                Some(above) => i32::from(above[c]),
                None => self.initial,
            };
            line[c] = (start + difference(s, bits)) as u16;
        }
        match above {
            None => {
                for i in n..line.len() {
                    bits.refill();
                    let s = self.tables[i % n].decode(bits)?;
                    line[i] = (i32::from(line[i - n]) + difference(s, bits)) as u16;
                }
            }
            Some(above) => {
                for x in (n..line.len()).step_by(n) {
                    for c in 0..n {
                        let i = x + c;
                        bits.refill();
                        let s = self.tables[c].decode(bits)?;
                        let p = predict::<P>(
                            i32::from(line[i - n]),
                            i32::from(above[i]),
                            i32::from(above[i - n]),
                        );
                        line[i] = (p + difference(s, bits)) as u16;
                    }
                }
            }
        }
        Ok(())
    }

    /// Decodes every line into `out`, restarting every `restart_lines` lines (0: never).
    fn lines<const P: u8>(
        &self,
        bits: &mut BitReader,
        out: &mut [u16],
        stride: usize,
        restart_lines: usize,
    ) -> Result<()> {
        let mut restart = 0u8;
        for y in 0..out.len() / stride {
            let first_of_interval = restart_lines > 0 && y % restart_lines == 0;
            if first_of_interval && y > 0 {
                bits.restart(restart)?;
                restart = (restart + 1) % 8;
            }
            let (done, rest) = out.split_at_mut(y * stride);
            let above = if y == 0 || first_of_interval {
                None
            } else {
                Some(&done[(y - 1) * stride..])
            };
            self.line::<P>(bits, above, &mut rest[..stride])?;
        }
        Ok(())
    }
}

/// One marker segment of a JPEG stream.
pub(crate) struct Segment<'a> {
    /// Where its marker is.
    pub(crate) at: usize,
    pub(crate) marker: u8,
    /// What its length covers, after the length.
    pub(crate) body: &'a [u8],
    /// Where the next marker is expected.
    pub(crate) next: usize,
}

/// The marker segment at `at` (after any fill bytes, FF), shared by the lossless and DCT
/// decoders; an error is its offset and problem. An EOI before the scan is an error: every
/// caller wants a scan.
pub(crate) fn segment(
    data: &[u8],
    mut at: usize,
) -> core::result::Result<Segment<'_>, (usize, &'static str)> {
    // Markers may be preceded by fill bytes (FF).
    while data.get(at) == Some(&0xff) && data.get(at + 1) == Some(&0xff) {
        at += 1;
    }
    let (Some(&0xff), Some(&marker)) = (data.get(at), data.get(at + 1)) else {
        return Err((at, "expected a marker"));
    };
    if marker == EOI {
        return Err((at, "no scan before the end of the image"));
    }
    let length = data
        .get(at + 2..at + 4)
        .map(|b| usize::from(u16::from_be_bytes([b[0], b[1]])))
        .ok_or((at, "marker segment cut short"))?;
    let body = data
        .get(at + 4..(at + 2 + length).max(at + 4))
        .filter(|_| length >= 2)
        .ok_or((at, "marker segment cut short"))?;
    Ok(Segment {
        at,
        marker,
        body,
        next: at + 2 + length,
    })
}

/// Reads the frame header without decoding: the shape the decoded samples will have.
pub fn frame(data: &[u8]) -> Result<Frame> {
    parse(data, None).map(|(frame, _)| frame)
}

/// Decodes a lossless JPEG into `out`, which must hold exactly [`Frame::sample_count`] samples
/// (see [`frame`]): lines top to bottom, components interleaved within each line, each sample
/// shifted left by the point transform.
pub fn decode(data: &[u8], out: &mut [u16]) -> Result<Frame> {
    parse(data, Some(out)).map(|(frame, _)| frame)
}

/// Parses markers; with `out`, decodes the scan into it.
fn parse(data: &[u8], out: Option<&mut [u16]>) -> Result<(Frame, usize)> {
    if data.get(..2) != Some(&[0xff, SOI]) {
        return Err(error(0, "no start-of-image marker"));
    }
    let mut at = 2;
    let mut frame: Option<(Frame, [u8; 4], [u8; 4])> = None; // ids and table choices
    let mut tables: [Option<Huffman>; 4] = [None, None, None, None];
    let mut restart_interval = 0usize;
    loop {
        let Segment {
            at: marker_at,
            marker,
            body,
            next,
        } = segment(data, at).map_err(|(at, problem)| error(at, problem))?;
        at = marker_at;
        let length = next - at - 2;
        match marker {
            SOF3 => {
                if body.len() < 6 {
                    return Err(error(at, "frame header too short"));
                }
                let precision = body[0];
                let lines = u16::from_be_bytes([body[1], body[2]]);
                let samples_per_line = u16::from_be_bytes([body[3], body[4]]);
                let components = body[5];
                if !(2..=16).contains(&precision) {
                    return Err(error(at, "precision outside 2..=16 bits"));
                }
                if lines == 0 {
                    return Err(error(at, "zero lines (a DNL marker is not supported)"));
                }
                if samples_per_line == 0 || !(1..=4).contains(&components) {
                    return Err(error(
                        at,
                        "zero samples per line or components outside 1..=4",
                    ));
                }
                if body.len() != 6 + 3 * usize::from(components) {
                    return Err(error(
                        at,
                        "frame header length disagrees with its components",
                    ));
                }
                let mut ids = [0u8; 4];
                for (c, id) in ids.iter_mut().enumerate().take(usize::from(components)) {
                    *id = body[6 + 3 * c];
                    if body[7 + 3 * c] != 0x11 {
                        return Err(error(at, "subsampled components are not supported"));
                    }
                }
                let f = Frame {
                    precision,
                    lines,
                    samples_per_line,
                    components,
                };
                if out.is_none() {
                    return Ok((f, at));
                }
                frame = Some((f, ids, [0; 4]));
            }
            _ if is_frame_header(marker) => {
                return Err(error(at, "not a lossless Huffman JPEG (SOF3)"));
            }
            DHT => {
                let mut rest = body;
                while !rest.is_empty() {
                    if rest.len() < 17 {
                        return Err(error(at, "Huffman table cut short"));
                    }
                    let (class, id) = (rest[0] >> 4, usize::from(rest[0] & 15));
                    if class != 0 || id > 3 {
                        return Err(error(at, "Huffman table class or number outside 0, 0..=3"));
                    }
                    let counts: [u8; 16] = std::array::from_fn(|i| rest[1 + i]);
                    let n: usize = counts.iter().map(|c| usize::from(*c)).sum();
                    let values = rest
                        .get(17..17 + n)
                        .ok_or(error(at, "Huffman table cut short"))?;
                    if values.iter().any(|v| *v > 16) {
                        return Err(error(at, "difference category above 16"));
                    }
                    tables[id] = Some(Huffman::new(&counts, values, at)?);
                    rest = &rest[17 + n..];
                }
            }
            DRI => {
                if body.len() != 2 {
                    return Err(error(at, "restart interval segment is not 2 bytes"));
                }
                restart_interval = usize::from(u16::from_be_bytes([body[0], body[1]]));
            }
            SOS => {
                let Some((f, ids, mut choice)) = frame else {
                    return Err(error(at, "scan before the frame header"));
                };
                let n = usize::from(f.components);
                if body.first().map(|v| usize::from(*v)) != Some(n) || body.len() != 4 + 2 * n {
                    return Err(error(
                        at,
                        "scan does not interleave every component (one scan per frame only)",
                    ));
                }
                for (c, slot) in choice.iter_mut().enumerate().take(n) {
                    if body[1 + 2 * c] != ids[c] {
                        return Err(error(at, "scan components differ from the frame's"));
                    }
                    *slot = body[2 + 2 * c] >> 4;
                }
                let (predictor, point_transform) = (body[1 + 2 * n], body[3 + 2 * n] & 15);
                if !(1..=7).contains(&predictor) {
                    return Err(error(at, "predictor outside 1..=7"));
                }
                if point_transform >= f.precision {
                    return Err(error(at, "point transform not below the precision"));
                }
                let mut chosen = Vec::with_capacity(n);
                for c in choice.iter().take(n) {
                    chosen.push(
                        tables
                            .get(usize::from(*c))
                            .and_then(Option::as_ref)
                            .ok_or(error(at, "scan uses a Huffman table not defined"))?,
                    );
                }
                let stride = usize::from(f.samples_per_line) * n;
                let restart_lines = if restart_interval == 0 {
                    0
                } else if restart_interval.is_multiple_of(usize::from(f.samples_per_line)) {
                    restart_interval / usize::from(f.samples_per_line)
                } else {
                    return Err(error(at, "restart interval is not a whole number of lines"));
                };
                let out = out.ok_or(error(at, "no output"))?;
                if out.len() != f.sample_count() {
                    return Err(FormatError::SizeMismatch {
                        what: "lossless JPEG samples",
                        found: f.sample_count(),
                        expected: out.len(),
                    });
                }
                let scan = Scan {
                    tables: std::array::from_fn(|c| chosen[c.min(n - 1)]),
                    components: n,
                    initial: 1 << (f.precision - point_transform - 1),
                };
                let mut bits = BitReader::new(data, at + 2 + length);
                match predictor {
                    1 => scan.lines::<1>(&mut bits, out, stride, restart_lines),
                    2 => scan.lines::<2>(&mut bits, out, stride, restart_lines),
                    3 => scan.lines::<3>(&mut bits, out, stride, restart_lines),
                    4 => scan.lines::<4>(&mut bits, out, stride, restart_lines),
                    5 => scan.lines::<5>(&mut bits, out, stride, restart_lines),
                    6 => scan.lines::<6>(&mut bits, out, stride, restart_lines),
                    _ => scan.lines::<7>(&mut bits, out, stride, restart_lines),
                }?;
                if bits.overran() {
                    return Err(error(bits.pos, "scan data ends early"));
                }
                if point_transform > 0 {
                    for v in out.iter_mut() {
                        *v <<= point_transform;
                    }
                }
                return Ok((f, at));
            }
            // APPn, COM, DQT, DNL and the like carry nothing a lossless decoder needs.
            _ => {}
        }
        at += 2 + length;
    }
}

/// Category (T.81 Table H.2) of a difference taken modulo 2^16 into -32767..=32768.
fn category(d: i32) -> u8 {
    if d == 32768 {
        16
    } else {
        (32 - d.unsigned_abs().leading_zeros()) as u8
    }
}

/// Code lengths for values 0..=16 by their frequencies, at most 16 bits, no code all ones
/// (T.81 Annex K.2): the number of codes of each length and the values in code order.
fn table_from_frequencies(frequencies: &[u64; 17]) -> ([u8; 16], Vec<u8>) {
    // Index 17 is the reserved symbol that keeps any code from being all ones.
    let mut freq = [0u64; 18];
    freq[..17].copy_from_slice(frequencies);
    freq[17] = 1;
    let mut size = [0usize; 18];
    let mut others = [usize::MAX; 18];
    loop {
        // The two least frequent (ties: the larger value first, as K.2 does).
        let mut v1 = usize::MAX;
        for (v, f) in freq.iter().enumerate() {
            if *f > 0 && (v1 == usize::MAX || *f <= freq[v1]) {
                v1 = v;
            }
        }
        let mut v2 = usize::MAX;
        for (v, f) in freq.iter().enumerate() {
            if *f > 0 && v != v1 && (v2 == usize::MAX || *f <= freq[v2]) {
                v2 = v;
            }
        }
        if v2 == usize::MAX {
            break;
        }
        freq[v1] += freq[v2];
        freq[v2] = 0;
        let mut v = v1;
        size[v] += 1;
        while others[v] != usize::MAX {
            v = others[v];
            size[v] += 1;
        }
        others[v] = v2;
        let mut v = v2;
        size[v] += 1;
        while others[v] != usize::MAX {
            v = others[v];
            size[v] += 1;
        }
    }
    let mut bits = [0usize; 33];
    for s in size {
        if s > 0 {
            bits[s] += 1;
        }
    }
    for i in (17..=32).rev() {
        while bits[i] > 0 {
            let mut j = i - 2;
            while bits[j] == 0 {
                j -= 1;
            }
            bits[i] -= 2;
            bits[i - 1] += 1;
            bits[j + 1] += 2;
            bits[j] -= 1;
        }
    }
    let mut longest = 16;
    while bits[longest] == 0 {
        longest -= 1;
    }
    bits[longest] -= 1; // the reserved symbol's code
    let mut values: Vec<u8> = (0..17u8).filter(|v| size[usize::from(*v)] > 0).collect();
    values.sort_by_key(|v| (size[usize::from(*v)], *v));
    (std::array::from_fn(|i| bits[i + 1] as u8), values)
}

/// Writes bits most significant first with JPEG's byte stuffing.
struct BitWriter {
    out: Vec<u8>,
    acc: u32,
    count: u32,
}

impl BitWriter {
    fn put(&mut self, value: u32, n: u32) {
        for i in (0..n).rev() {
            self.acc = self.acc << 1 | (value >> i & 1);
            self.count += 1;
            if self.count == 8 {
                self.out.push(self.acc as u8);
                if self.acc == 0xff {
                    self.out.push(0);
                }
                self.acc = 0;
                self.count = 0;
            }
        }
    }

    /// Pads the last byte with ones (T.81 F.1.2.3).
    fn flush(&mut self) {
        if self.count > 0 {
            self.put((1 << (8 - self.count)) - 1, 8 - self.count);
        }
    }
}

/// Encodes `samples` (lines top to bottom, components interleaved) as a lossless JPEG with
/// predictor `predictor` (1..=7), point transform `point_transform` (the samples' low bits
/// that many are dropped) and a restart marker every `restart_lines` lines (0: none).
pub fn encode(
    samples: &[u16],
    frame: Frame,
    predictor: u8,
    point_transform: u8,
    restart_lines: u16,
) -> Result<Vec<u8>> {
    let invalid = |problem| error(0, problem);
    if !(2..=16).contains(&frame.precision)
        || frame.lines == 0
        || frame.samples_per_line == 0
        || !(1..=4).contains(&frame.components)
    {
        return Err(invalid(
            "frame needs precision 2..=16, at least one line and sample, 1..=4 components",
        ));
    }
    if !(1..=7).contains(&predictor) || point_transform >= frame.precision {
        return Err(invalid(
            "predictor outside 1..=7 or point transform too large",
        ));
    }
    if samples.len() != frame.sample_count() {
        return Err(FormatError::SizeMismatch {
            what: "samples to encode",
            found: samples.len(),
            expected: frame.sample_count(),
        });
    }
    let interval = usize::from(restart_lines) * usize::from(frame.samples_per_line);
    if interval > 65535 {
        return Err(invalid("restart interval above 65535 samples"));
    }
    let max = (1u32 << frame.precision) - 1;
    if samples.iter().any(|v| u32::from(*v) > max) {
        return Err(invalid("a sample exceeds the precision"));
    }
    let n = usize::from(frame.components);
    let stride = usize::from(frame.samples_per_line) * n;
    let shifted: Vec<i32> = samples
        .iter()
        .map(|v| i32::from(*v >> point_transform))
        .collect();
    let initial = 1 << (frame.precision - point_transform - 1);
    // Differences modulo 2^16, as -32767..=32768, in coding order.
    let mut differences = Vec::with_capacity(samples.len());
    for (i, x) in shifted.iter().enumerate() {
        let (y, col) = (i / stride, i % stride);
        let first_line = y == 0 || (restart_lines > 0 && y % usize::from(restart_lines) == 0);
        let p = if col < n {
            if first_line {
                initial
            } else {
                shifted[i - stride]
            }
        } else if first_line {
            shifted[i - n]
        } else {
            let (a, b, c) = (shifted[i - n], shifted[i - stride], shifted[i - stride - n]);
            match predictor {
                1 => a,
                2 => b,
                3 => c,
                4 => a + b - c,
                5 => a + ((b - c) >> 1),
                6 => b + ((a - c) >> 1),
                _ => (a + b) >> 1,
            }
        };
        let d = (x - p).rem_euclid(65536);
        differences.push(if d > 32768 { d - 65536 } else { d });
    }
    let mut frequencies = vec![[0u64; 17]; n];
    for (i, d) in differences.iter().enumerate() {
        frequencies[i % n][usize::from(category(*d))] += 1;
    }
    let tables: Vec<([u8; 16], Vec<u8>)> = frequencies.iter().map(table_from_frequencies).collect();
    // Code and length per category, canonical order (T.81 Annex C).
    let codes: Vec<[(u32, u32); 17]> = tables
        .iter()
        .map(|(counts, values)| {
            let mut code_of = [(0u32, 0u32); 17];
            let (mut code, mut k) = (0u32, 0usize);
            for (len, count) in counts.iter().enumerate() {
                for _ in 0..*count {
                    code_of[usize::from(values[k])] = (code, len as u32 + 1);
                    code += 1;
                    k += 1;
                }
                code <<= 1;
            }
            code_of
        })
        .collect();

    let mut out = vec![0xff, SOI];
    let segment = |out: &mut Vec<u8>, marker: u8, body: &[u8]| {
        out.extend_from_slice(&[0xff, marker]);
        out.extend_from_slice(&(body.len() as u16 + 2).to_be_bytes());
        out.extend_from_slice(body);
    };
    let mut sof = vec![frame.precision];
    sof.extend_from_slice(&frame.lines.to_be_bytes());
    sof.extend_from_slice(&frame.samples_per_line.to_be_bytes());
    sof.push(frame.components);
    for c in 0..frame.components {
        sof.extend_from_slice(&[c + 1, 0x11, 0]);
    }
    segment(&mut out, SOF3, &sof);
    let mut dht = Vec::new();
    for (c, (counts, values)) in tables.iter().enumerate() {
        dht.push(c as u8);
        dht.extend_from_slice(counts);
        dht.extend_from_slice(values);
    }
    segment(&mut out, DHT, &dht);
    if interval > 0 {
        segment(&mut out, DRI, &(interval as u16).to_be_bytes());
    }
    let mut sos = vec![frame.components];
    for c in 0..frame.components {
        sos.extend_from_slice(&[c + 1, c << 4]);
    }
    sos.extend_from_slice(&[predictor, 0, point_transform]);
    segment(&mut out, SOS, &sos);
    let mut bits = BitWriter {
        out,
        acc: 0,
        count: 0,
    };
    for (i, d) in differences.iter().enumerate() {
        if interval > 0 && i > 0 && i % (interval * n) == 0 {
            bits.flush();
            let k = ((i / (interval * n) - 1) % 8) as u8;
            bits.out.extend_from_slice(&[0xff, RST0 + k]);
        }
        let s = category(*d);
        let (code, len) = codes[i % n][usize::from(s)];
        bits.put(code, len);
        if (1..16).contains(&s) {
            let extra = if *d < 0 { d + (1 << s) - 1 } else { *d };
            bits.put(extra as u32, u32::from(s));
        }
    }
    bits.flush();
    let mut out = bits.out;
    out.extend_from_slice(&[0xff, EOI]);
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A smooth image with noise and a few extremes, `precision` bits.
    fn image(frame: Frame, seed: u64) -> Vec<u16> {
        let max = (1u32 << frame.precision) - 1;
        let mut state = seed | 1;
        (0..frame.sample_count())
            .map(|i| {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                let smooth = (i as u32 * 37) % (max + 1);
                match state % 50 {
                    0 => 0,
                    1 => max,
                    _ => ((smooth + (state % 64) as u32) % (max + 1)) as u16 as u32,
                }
            })
            .map(|v| v as u16)
            .collect()
    }

    #[test]
    fn every_predictor_depth_layout_and_restart_round_trips() {
        for precision in [2u8, 8, 10, 12, 14, 16] {
            for components in 1..=4u8 {
                for predictor in 1..=7u8 {
                    for restart in [0u16, 1, 3] {
                        let frame = Frame {
                            precision,
                            lines: 7,
                            samples_per_line: 5,
                            components,
                        };
                        let samples = image(frame, u64::from(precision) * 131 + 7);
                        let bytes = encode(&samples, frame, predictor, 0, restart).unwrap();
                        let mut out = vec![0; samples.len()];
                        assert_eq!(decode(&bytes, &mut out).unwrap(), frame);
                        assert_eq!(
                            out, samples,
                            "P {precision} Nf {components} predictor {predictor} restart {restart}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn point_transform_keeps_the_high_bits() {
        let frame = Frame {
            precision: 12,
            lines: 4,
            samples_per_line: 6,
            components: 2,
        };
        let samples: Vec<u16> = image(frame, 3).iter().map(|v| v & !3).collect();
        let bytes = encode(&samples, frame, 4, 2, 0).unwrap();
        let mut out = vec![0; samples.len()];
        decode(&bytes, &mut out).unwrap();
        assert_eq!(out, samples);
    }

    #[test]
    fn extreme_differences_use_category_16() {
        // 0 next to 65535 and back: differences of +-32768 and beyond, modulo 2^16.
        let frame = Frame {
            precision: 16,
            lines: 2,
            samples_per_line: 6,
            components: 1,
        };
        let samples = vec![
            0, 32768, 0, 65535, 0, 1, 65535, 32767, 32768, 0, 65535, 65535,
        ];
        for predictor in 1..=7 {
            let bytes = encode(&samples, frame, predictor, 0, 0).unwrap();
            let mut out = vec![0; samples.len()];
            decode(&bytes, &mut out).unwrap();
            assert_eq!(out, samples);
        }
        assert_eq!(category(32768), 16);
        assert_eq!(category(-32767), 15);
        assert_eq!(category(0), 0);
    }

    #[test]
    fn tables_are_at_most_16_bits_and_never_all_ones() {
        // Frequencies as skewed as Fibonacci numbers would make codes longer than 16 bits.
        let mut f = [0u64; 17];
        let (mut a, mut b) = (1u64, 1u64);
        for v in f.iter_mut() {
            *v = a;
            (a, b) = (b, a + b);
        }
        let (counts, values) = table_from_frequencies(&f);
        assert_eq!(counts.iter().map(|c| usize::from(*c)).sum::<usize>(), 17);
        assert_eq!(values.len(), 17);
        // Kraft sum strictly below one: no code is all ones.
        let kraft: f64 = counts
            .iter()
            .enumerate()
            .map(|(i, c)| f64::from(*c) / 2f64.powi(i as i32 + 1))
            .sum();
        assert!(kraft < 1.0, "{kraft}");
        assert!(Huffman::new(&counts, &values, 0).is_ok());
    }

    #[test]
    fn the_wrong_output_size_and_damaged_streams_are_errors() {
        let frame = Frame {
            precision: 12,
            lines: 6,
            samples_per_line: 8,
            components: 2,
        };
        let samples = image(frame, 11);
        let bytes = encode(&samples, frame, 1, 0, 2).unwrap();
        assert_eq!(super::frame(&bytes).unwrap(), frame);
        assert!(decode(&bytes, &mut vec![0; samples.len() - 1]).is_err());
        for n in 0..bytes.len() - 2 {
            assert!(
                decode(&bytes[..n], &mut vec![0; samples.len()]).is_err(),
                "{n}"
            );
        }
        let mut state = 0x2545_f491_4f6c_dd1du64;
        for _ in 0..5000 {
            let mut b = bytes.clone();
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            let i = state as usize % b.len();
            b[i] = (state >> 32) as u8;
            let _ = decode(&b, &mut vec![0; samples.len()]);
        }
        let mut lossy = bytes.clone();
        let sof = lossy.windows(2).position(|w| w == [0xff, SOF3]).unwrap();
        lossy[sof + 1] = 0xc0;
        assert!(matches!(
            decode(&lossy, &mut vec![0; samples.len()]),
            Err(FormatError::LosslessJpeg { .. })
        ));
    }
}

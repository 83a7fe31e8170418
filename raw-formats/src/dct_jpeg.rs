//! Sequential DCT JPEG of one component at 8 or 12 bits (ITU T.81 processes 1 and 2: SOF0 and
//! SOF1, Huffman-coded), the lossy form of DNG's Compression 7 that Blackmagic cameras record
//! as their 3:1 and 4:1 CinemaDNG: a decoder.
//!
//! Such a tile is one greyscale JPEG two CFA rows per JPEG row (a tile W wide and H high is a
//! frame 2W wide and H/2 high), so, as with lossless JPEG, the samples in decoding order are the
//! tile's. The decoder takes what those writers produce: one component sampled 1x1, 8- or
//! 16-bit quantisation tables, up to four Huffman tables of each class, restart intervals, a
//! frame of any size (blocks past its right and bottom edges are decoded and dropped). Every
//! size is checked before anything is written and the caller hands in the output, so a hostile
//! header cannot make it allocate; every code, run and table reference is checked as it is
//! read, so a damaged stream is an error, never a read out of bounds or a hang.
//!
//! The inverse DCT is the separable textbook form in `f32`, `cos(k pi / 16) / 2` with the DC
//! terms scaled by `1 / sqrt 2`, the level shift `2^(P-1)` carried in the DC coefficient and each
//! sample rounded half up and clamped to `0 ..= 2^P - 1` (T.81 A.3.1, which LibRaw leaves out:
//! it keeps the overshoot above `2^P - 1`). It is LibRaw's arithmetic (`ljpeg_idct`), so the
//! two agree to the LSB but for float rounding at a half (tested against LibRaw and
//! libjpeg-turbo on files libjpeg-turbo wrote).
//!
//! ```
//! use raw_formats::dct_jpeg;
//! // Not a DCT JPEG: a lossless one (SOF3).
//! let lossless = raw_formats::lossless_jpeg::encode(
//!     &[1, 2, 3, 4],
//!     raw_formats::lossless_jpeg::Frame { precision: 12, lines: 2, samples_per_line: 2, components: 1 },
//!     1, 0, 0,
//! ).unwrap();
//! assert!(!dct_jpeg::is_dct(&lossless));
//! assert!(dct_jpeg::frame(&lossless).is_err());
//! ```

use crate::error::{FormatError, Result};
use crate::lossless_jpeg::{
    is_frame_header, segment, BitReader, Huffman, Segment, DHT, DRI, SOI, SOS,
};

/// A DCT JPEG frame's shape (its SOF0 or SOF1 header).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Frame {
    /// Sample precision P in bits: 8 or 12.
    pub precision: u8,
    /// Number of lines Y (at least 1).
    pub lines: u16,
    /// Samples per line X (at least 1).
    pub samples_per_line: u16,
}

impl Frame {
    /// Samples the frame decodes to: lines x samples per line.
    pub fn sample_count(&self) -> usize {
        usize::from(self.lines) * usize::from(self.samples_per_line)
    }

    /// 8x8 blocks the frame is coded in (partial blocks at the right and bottom count whole).
    pub fn block_count(&self) -> usize {
        usize::from(self.lines).div_ceil(8) * usize::from(self.samples_per_line).div_ceil(8)
    }
}

fn error(offset: usize, problem: &'static str) -> FormatError {
    FormatError::DctJpeg { offset, problem }
}

const SOF0: u8 = 0xc0;
const SOF1: u8 = 0xc1;
const DQT: u8 = 0xdb;

/// The coefficient at each position of the zig-zag sequence (T.81 Figure A.6), as an index
/// into the block row by row.
const ZIGZAG: [u8; 64] = [
    0, 1, 8, 16, 9, 2, 3, 10, 17, 24, 32, 25, 18, 11, 4, 5, 12, 19, 26, 33, 40, 48, 41, 34, 27, 20,
    13, 6, 7, 14, 21, 28, 35, 42, 49, 56, 57, 50, 43, 36, 29, 22, 15, 23, 30, 37, 44, 51, 58, 59,
    52, 45, 38, 31, 39, 46, 53, 60, 61, 54, 47, 55, 62, 63,
];

/// Whether `data` is a DCT JPEG this module decodes (its first frame header is SOF0 or SOF1),
/// rather than, say, a lossless one (SOF3). Reads markers only.
pub fn is_dct(data: &[u8]) -> bool {
    matches!(first_frame_marker(data), Some(SOF0 | SOF1))
}

/// The marker of the first frame header (SOFn), if the markers before it are well formed.
fn first_frame_marker(data: &[u8]) -> Option<u8> {
    if data.get(..2) != Some(&[0xff, SOI]) {
        return None;
    }
    let mut at = 2;
    loop {
        let s = segment(data, at).ok()?;
        match s.marker {
            m if is_frame_header(m) => return Some(s.marker),
            SOS => return None,
            _ => at = s.next,
        }
    }
}

/// Reads the frame header without decoding: the shape the decoded samples will have.
pub fn frame(data: &[u8]) -> Result<Frame> {
    parse(data, None)
}

/// Decodes a DCT JPEG into `out`, which must hold exactly [`Frame::sample_count`] samples (see
/// [`frame`]): lines top to bottom.
pub fn decode(data: &[u8], out: &mut [u16]) -> Result<Frame> {
    parse(data, Some(out))
}

/// The frame, its tables and the scan's choices as the headers give them.
struct Headers {
    frame: Option<(Frame, u8, usize)>, // the frame, its component's id, its table
    quant: [Option<[u16; 64]>; 4],
    dc: [Option<Huffman>; 4],
    ac: [Option<Huffman>; 4],
    restart_interval: usize,
}

/// Parses markers; with `out`, decodes the scan into it.
fn parse(data: &[u8], out: Option<&mut [u16]>) -> Result<Frame> {
    if data.get(..2) != Some(&[0xff, SOI]) {
        return Err(error(0, "no start-of-image marker"));
    }
    let mut at = 2;
    let mut h = Headers {
        frame: None,
        quant: [None; 4],
        dc: [None, None, None, None],
        ac: [None, None, None, None],
        restart_interval: 0,
    };
    loop {
        let Segment {
            at: marker_at,
            marker,
            body,
            next,
        } = segment(data, at).map_err(|(at, problem)| error(at, problem))?;
        at = marker_at;
        match marker {
            SOF0 | SOF1 => {
                let f = frame_header(body, at)?;
                if out.is_none() {
                    return Ok(f.0);
                }
                if h.frame.is_some() {
                    return Err(error(at, "a second frame header"));
                }
                h.frame = Some(f);
            }
            _ if is_frame_header(marker) => {
                return Err(error(
                    at,
                    "not a sequential Huffman DCT JPEG (SOF0 or SOF1)",
                ));
            }
            DQT => quant_tables(body, at, &mut h.quant)?,
            DHT => huffman_tables(body, at, &mut h)?,
            DRI => {
                if body.len() != 2 {
                    return Err(error(at, "restart interval segment is not 2 bytes"));
                }
                h.restart_interval = usize::from(u16::from_be_bytes([body[0], body[1]]));
            }
            SOS => {
                let out = out.ok_or(error(at, "no output"))?;
                return scan(data, at, body, &h, out);
            }
            // APPn, COM, DNL and the like carry nothing the decoder needs.
            _ => {}
        }
        at = next;
    }
}

/// A SOF0 or SOF1 header: the frame, its one component's id and quantisation table.
fn frame_header(body: &[u8], at: usize) -> Result<(Frame, u8, usize)> {
    if body.len() < 6 {
        return Err(error(at, "frame header too short"));
    }
    let precision = body[0];
    let lines = u16::from_be_bytes([body[1], body[2]]);
    let samples_per_line = u16::from_be_bytes([body[3], body[4]]);
    if precision != 8 && precision != 12 {
        return Err(error(at, "precision is neither 8 nor 12 bits"));
    }
    if lines == 0 || samples_per_line == 0 {
        return Err(error(
            at,
            "zero lines or samples per line (DNL is not supported)",
        ));
    }
    if body[5] != 1 || body.len() != 9 {
        return Err(error(at, "not one component (a CFA tile is greyscale)"));
    }
    if body[7] != 0x11 {
        return Err(error(at, "the component is subsampled"));
    }
    if body[8] > 3 {
        return Err(error(at, "quantisation table number above 3"));
    }
    let frame = Frame {
        precision,
        lines,
        samples_per_line,
    };
    Ok((frame, body[6], usize::from(body[8])))
}

/// A DQT segment's tables (8- or 16-bit entries, in zig-zag order).
fn quant_tables(mut rest: &[u8], at: usize, quant: &mut [Option<[u16; 64]>; 4]) -> Result<()> {
    while let Some(&pq_tq) = rest.first() {
        let (wide, id) = (pq_tq >> 4, usize::from(pq_tq & 15));
        if wide > 1 || id > 3 {
            return Err(error(
                at,
                "quantisation table precision above 1 or number above 3",
            ));
        }
        let size = if wide == 1 { 128 } else { 64 };
        let entries = rest
            .get(1..1 + size)
            .ok_or(error(at, "quantisation table cut short"))?;
        let table: [u16; 64] = std::array::from_fn(|k| match wide {
            1 => u16::from_be_bytes([entries[2 * k], entries[2 * k + 1]]),
            _ => u16::from(entries[k]),
        });
        if table.contains(&0) {
            return Err(error(at, "quantisation table entry of 0"));
        }
        quant[id] = Some(table);
        rest = &rest[1 + size..];
    }
    Ok(())
}

/// A DHT segment's tables, DC (class 0) and AC (class 1).
fn huffman_tables(mut rest: &[u8], at: usize, h: &mut Headers) -> Result<()> {
    while !rest.is_empty() {
        if rest.len() < 17 {
            return Err(error(at, "Huffman table cut short"));
        }
        let (class, id) = (rest[0] >> 4, usize::from(rest[0] & 15));
        if class > 1 || id > 3 {
            return Err(error(at, "Huffman table class above 1 or number above 3"));
        }
        let counts: [u8; 16] = std::array::from_fn(|i| rest[1 + i]);
        let n: usize = counts.iter().map(|c| usize::from(*c)).sum();
        let values = rest
            .get(17..17 + n)
            .ok_or(error(at, "Huffman table cut short"))?;
        let table = Huffman::new(&counts, values, at)
            .map_err(|_| error(at, "Huffman table has more codes than fit"))?;
        if class == 0 {
            // DC difference categories: at most 11 at 8 bits, 15 at 12 (checked per frame).
            if values.iter().any(|v| *v > 15) {
                return Err(error(at, "DC difference category above 15"));
            }
            h.dc[id] = Some(table);
        } else {
            h.ac[id] = Some(table);
        }
        rest = &rest[17 + n..];
    }
    Ok(())
}

/// The scan: its header `body` at `at`, then the entropy-coded blocks into `out`.
fn scan(data: &[u8], at: usize, body: &[u8], h: &Headers, out: &mut [u16]) -> Result<Frame> {
    let Some((f, id, q)) = h.frame else {
        return Err(error(at, "scan before the frame header"));
    };
    if body.len() != 6 || body[0] != 1 || body[1] != id {
        return Err(error(at, "scan is not of the frame's one component"));
    }
    let (td, ta) = (usize::from(body[2] >> 4), usize::from(body[2] & 15));
    if (body[3], body[4], body[5]) != (0, 63, 0) {
        return Err(error(
            at,
            "scan is not sequential (spectral selection 0..=63, no approximation)",
        ));
    }
    let (dc, ac) = (table(&h.dc, td, at)?, table(&h.ac, ta, at)?);
    let quant = h.quant[q].ok_or(error(at, "frame uses a quantisation table not defined"))?;
    if out.len() != f.sample_count() {
        return Err(FormatError::SizeMismatch {
            what: "DCT JPEG samples",
            found: f.sample_count(),
            expected: out.len(),
        });
    }
    let (width, height) = (usize::from(f.samples_per_line), usize::from(f.lines));
    let (blocks_x, blocks_y) = (width.div_ceil(8), height.div_ceil(8));
    let max = (1i32 << f.precision) - 1;
    // The level shift 2^(P-1) as a DC coefficient (the DC term's gain is 1/8).
    let shift = 8i64 << (f.precision - 1);
    let cos = cos_table();
    let mut bits = BitReader::new(data, at + 2 + body.len() + 2);
    // i64: a hostile stream's differences add up over millions of blocks.
    let (mut prediction, mut restart) = (0i64, 0u8);
    let mut block = [0f32; 64];
    let mut samples = [0u16; 64];
    for b in 0..blocks_x * blocks_y {
        if h.restart_interval > 0 && b > 0 && b % h.restart_interval == 0 {
            bits.restart(restart)
                .map_err(|_| error(bits.position(), "expected restart marker missing"))?;
            restart = (restart + 1) % 8;
            prediction = 0;
        }
        block.fill(0.0);
        bits.refill();
        let category = dc
            .decode(&mut bits)
            .map_err(|_| error(bits.position(), "bad Huffman code"))?;
        if i32::from(category) > i32::from(f.precision) + 3 {
            return Err(error(
                bits.position(),
                "DC difference category above the precision's",
            ));
        }
        prediction += i64::from(extend(bits.take(u32::from(category)), category));
        block[0] = (shift + prediction * i64::from(quant[0])) as f32;
        let mut k = 1;
        while k < 64 {
            bits.refill();
            let rs = ac
                .decode(&mut bits)
                .map_err(|_| error(bits.position(), "bad Huffman code"))?;
            let (run, size) = (usize::from(rs >> 4), rs & 15);
            if size == 0 {
                if run == 15 {
                    k += 16; // sixteen zeros
                    continue;
                }
                break; // end of block
            }
            k += run;
            if k > 63 {
                return Err(error(bits.position(), "AC coefficients run past the block"));
            }
            if i32::from(size) > i32::from(f.precision) + 2 {
                return Err(error(
                    bits.position(),
                    "AC coefficient size above the precision's",
                ));
            }
            let coefficient = extend(bits.take(u32::from(size)), size);
            block[usize::from(ZIGZAG[k])] = (coefficient * i32::from(quant[k])) as f32;
            k += 1;
        }
        if k > 64 {
            return Err(error(bits.position(), "AC coefficients run past the block"));
        }
        inverse_dct(&mut block, &cos);
        for (s, v) in samples.iter_mut().zip(&block) {
            // Rounded half up; clamped (T.81 A.3.1).
            *s = ((v + 0.5).floor() as i32).clamp(0, max) as u16;
        }
        let (bx, by) = (b % blocks_x, b / blocks_x);
        for r in 0..8.min(height - 8 * by) {
            let y = 8 * by + r;
            let cols = 8.min(width - 8 * bx);
            out[y * width + 8 * bx..y * width + 8 * bx + cols]
                .copy_from_slice(&samples[8 * r..8 * r + cols]);
        }
    }
    if bits.overran() {
        return Err(error(bits.position(), "scan data ends early"));
    }
    Ok(f)
}

/// Huffman table `t` of one class, if the headers defined it.
fn table(tables: &[Option<Huffman>; 4], t: usize, at: usize) -> Result<&Huffman> {
    tables
        .get(t)
        .and_then(Option::as_ref)
        .ok_or(error(at, "scan uses a Huffman table not defined"))
}

/// The value of `size` extra bits `v` (T.81 F.2.2.1 EXTEND): a negative value when its top bit
/// is clear.
fn extend(v: u32, size: u8) -> i32 {
    if size == 0 {
        return 0;
    }
    let v = v as i32;
    if v < 1 << (size - 1) {
        v - (1 << size) + 1
    } else {
        v
    }
}

/// `cos(k pi / 16) / 2` for `k` in `0..106`, `(2 x + 1) u` at most 105.
fn cos_table() -> [f32; 106] {
    std::array::from_fn(|k| ((k % 32) as f64 * std::f64::consts::PI / 16.0).cos() as f32 / 2.0)
}

/// The 8x8 inverse DCT in place (T.81 A.3.3), rows then columns, in `f32`.
fn inverse_dct(block: &mut [f32; 64], cos: &[f32; 106]) {
    // Scaled in f64 and rounded to f32, as C's `float *= M_SQRT1_2` is.
    let scale = |v: &mut f32| *v = (f64::from(*v) * std::f64::consts::FRAC_1_SQRT_2) as f32;
    block[..8].iter_mut().for_each(scale);
    block.iter_mut().step_by(8).for_each(scale);
    let mut rows = [0f32; 64];
    for i in 0..8 {
        for j in 0..8 {
            let mut sum = 0.0;
            for c in 0..8 {
                sum += block[8 * i + c] * cos[(2 * j + 1) * c];
            }
            rows[8 * i + j] = sum;
        }
    }
    for i in 0..8 {
        for j in 0..8 {
            let mut sum = 0.0;
            for c in 0..8 {
                sum += rows[8 * c + j] * cos[(2 * i + 1) * c];
            }
            block[8 * i + j] = sum;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 12-bit, 24 x 16 JPEG that libjpeg-turbo wrote (16-bit quantisation tables), from the
    /// fuzz seeds.
    const SEED: &[u8] = include_bytes!("../../fuzz/seeds/dct_jpeg/12bit-q90-16x24.jpg");

    /// Where marker `marker`'s segment starts in `SEED`.
    fn segment(marker: u8) -> usize {
        (2..SEED.len() - 1)
            .find(|&i| SEED[i] == 0xff && SEED[i + 1] == marker)
            .unwrap()
    }

    #[test]
    fn a_written_stream_decodes_within_its_precision() {
        let frame = frame(SEED).unwrap();
        assert_eq!(
            frame,
            Frame {
                precision: 12,
                lines: 16,
                samples_per_line: 24
            }
        );
        assert_eq!(frame.block_count(), 6);
        let mut out = vec![0u16; frame.sample_count()];
        decode(SEED, &mut out).unwrap();
        assert!(out.iter().all(|v| *v <= 4095));
        // Column 3 was written clipped at 4095, the rest around 1640 +- 1230.
        assert!(out.iter().skip(3).step_by(24).all(|v| *v > 3600));
        let mean = out.iter().map(|v| f64::from(*v)).sum::<f64>() / out.len() as f64;
        assert!((1400.0..2100.0).contains(&mean), "{mean}");
        assert!(is_dct(SEED));
        assert!(decode(SEED, &mut out[1..]).is_err(), "wrong output size");
    }

    #[test]
    fn what_is_not_supported_is_refused_by_name() {
        let sof = segment(SOF1);
        let refused = |at: usize, value: u8, expected: &str| {
            let mut data = SEED.to_vec();
            data[at] = value;
            let mut out = vec![0u16; 16 * 24];
            let message = decode(&data, &mut out).unwrap_err().to_string();
            assert!(message.contains(expected), "{message}");
        };
        refused(sof + 1, 0xc2, "not a sequential Huffman DCT JPEG");
        refused(sof + 4, 16, "neither 8 nor 12 bits");
        refused(sof + 9, 2, "not one component");
        refused(sof + 11, 0x21, "subsampled");
        let sos = segment(SOS);
        refused(sos + 7, 5, "scan is not sequential");
        refused(sos + 6, 0x22, "Huffman table not defined");
        // Cut short inside the scan.
        let mut out = vec![0u16; 16 * 24];
        let message = decode(&SEED[..sos + 40], &mut out).unwrap_err().to_string();
        assert!(message.contains("ends early"), "{message}");
    }

    #[test]
    fn the_inverse_dct_of_a_dc_block_is_flat() {
        // DC alone: every sample is DC / 8.
        let mut block = [0f32; 64];
        block[0] = 8.0 * 2048.0;
        inverse_dct(&mut block, &cos_table());
        assert!(block.iter().all(|v| (v - 2048.0).abs() < 1e-2), "{block:?}");
        assert_eq!(extend(0, 0), 0);
        assert_eq!((extend(0, 3), extend(3, 3), extend(4, 3)), (-7, -4, 4));
    }
}

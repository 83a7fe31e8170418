//! The common camera pipeline (defect correction, black level, gain, white balance, bilinear
//! or MHC, colour matrix, 8-bit sRGB) on the fixed path, scheduled over planar rows so that
//! every stage but the encoding is a loop over contiguous slices that the compiler
//! vectorises. The arithmetic is the general engine's, step for step; only the layout and
//! the order of the loops differ, so the output is bit-identical (tested).
//!
//! - A prepared mosaic row is held as its even columns, then its odd columns, each with one
//!   reflected sample on either side ([`Halves`]). Within one half every sample has the same
//!   CFA position, so the pointwise stage is one set of constants per half, and a demosaic
//!   filter at every site of a half reads the same offsets: `x - 2`, `x`, `x + 2` of the
//!   site's own half and `x - 1`, `x + 1` of the other half. The padding makes the frame's
//!   reflect-101 border the same loop as the interior.
//! - The demosaiced row is three planes (R, G, B), each even half then odd half; the colour
//!   matrix runs on the planes; the encoding (two byte-table loads per channel) writes the
//!   interleaved output.
//! - The pointwise stage and the colour matrix keep the general engine's `u64`/`i64`
//!   results in `u32`/`i32` lanes by splitting each Q16 constant into its integer and
//!   fraction parts (see [`MulQ16`] and [`CcmSplit`]), which is exact.

use core::ops::Range;

use super::{FixedPipeline, OutputSample, CHUNK, MOSAIC_ROWS};
use crate::demosaic::{reflect, Method};
use crate::dpc;
use crate::frame::{RawFrame, RgbViewMut};
use crate::{CfaColour, CfaPattern, IspError};

/// Narrowest frame the planar schedule takes; the padding reflects within the first and last
/// four columns.
const MIN_WIDTH: usize = 8;

/// Scratch elements the schedule uses: the five padded mosaic rows and one planar RGB row
/// (within [`super::scratch_len`] for every width it takes).
fn scratch_needed(w: usize) -> usize {
    MOSAIC_ROWS * Halves::new(w).len() + 3 * w
}

/// Whether the planar schedule runs `path` on `raw` with output samples `O`: everything the
/// general engine would do is among the stages above.
pub(super) fn takes<O: OutputSample>(path: &FixedPipeline<'_>, raw: &RawFrame<'_>) -> bool {
    let mosaic = raw.mosaic();
    O::BITS == 8
        && matches!(path.method, Method::Bilinear | Method::Mhc)
        && mosaic.width() >= MIN_WIDTH
        && mosaic.height() >= 3
        && path.lsc.is_none()
        && path.distortion.is_none()
        && path.inverse_denoise.is_none()
        && path.highlights.is_none()
        && path.saturation_q.is_none()
        && path.tone_lut.is_none()
        && path.sharpen_q12.is_none()
        && path.encode.max() == 255
}

/// A prepared row's layout: `[E(-1), E(0) .. E(even-1), E(even), O(-1), O(0) .. O(odd-1),
/// O(odd)]`, where `E(i)` is column `2i` and `O(i)` column `2i + 1`, and the outer samples
/// of each half are the columns reflect-101 gives there.
#[derive(Debug, Clone, Copy)]
struct Halves {
    even: usize,
    odd: usize,
}

impl Halves {
    fn new(w: usize) -> Self {
        Self {
            even: w.div_ceil(2),
            odd: w / 2,
        }
    }

    fn len(self) -> usize {
        self.even + self.odd + 4
    }

    /// Index of `O(-1)`.
    fn odd_start(self) -> usize {
        self.even + 2
    }

    /// Index of `E(i)`.
    fn even_at(i: usize) -> usize {
        1 + i
    }

    /// Writes the four reflected samples of a row whose halves are filled (width at least 4).
    fn pad(self, row: &mut [u16]) {
        let (ne, no, o) = (self.even, self.odd, self.odd_start());
        // Column -2 is column 2, column -1 is column 1.
        row[0] = row[Self::even_at(1)];
        row[o] = row[o + 1];
        if ne == no {
            // Even width: column w is w - 2 (even), column w + 1 is w - 3 (odd).
            row[Self::even_at(ne)] = row[Self::even_at(ne - 1)];
            row[o + 1 + no] = row[o + 1 + no - 2];
        } else {
            // Odd width: column w is w - 2 (odd), column w + 1 is w - 3 (even).
            row[o + 1 + no] = row[o + 1 + no - 1];
            row[Self::even_at(ne)] = row[Self::even_at(ne - 2)];
        }
    }

    /// The sites of one column parity: `(same, other, n)`, where `same[i + 1]` is site `i`
    /// (so `same[i]` and `same[i + 2]` are two columns left and right) and `other[i]`,
    /// `other[i + 1]` are the columns left and right of it.
    fn sites(self, row: &[u16], parity: usize) -> (&[u16], &[u16], usize) {
        let o = self.odd_start();
        match parity {
            0 => (&row[..self.even + 2], &row[o..o + self.even + 1], self.even),
            _ => (&row[o..o + self.odd + 2], &row[1..self.odd + 2], self.odd),
        }
    }
}

/// `min(round(v * k / 2^16), 65535)` for a Q16 constant `k < 2^32` and `v < 2^16`, in `u32`
/// lanes: `k = hi * 2^16 + lo` makes it `v * hi + round(v * lo / 2^16)`, every term below
/// 2^32. The same value as the general engine's `u64` form.
#[derive(Debug, Clone, Copy)]
struct MulQ16 {
    hi: u32,
    lo: u32,
}

impl MulQ16 {
    fn new(k: u64) -> Self {
        Self {
            hi: (k >> 16) as u32,
            lo: (k & 0xFFFF) as u32,
        }
    }

    /// Multiplying by 1.0, which is exact and changes nothing.
    const ONE: Self = Self { hi: 1, lo: 0 };

    #[inline(always)]
    fn apply(self, v: u32) -> u32 {
        (v * self.hi + ((v * self.lo + (1 << 15)) >> 16)).min(65535)
    }
}

/// What the pointwise stage does to every sample of one CFA position.
#[derive(Debug, Clone, Copy)]
struct Pointwise {
    black: u16,
    normalise: MulQ16,
    gain: MulQ16,
    wb: MulQ16,
}

impl Pointwise {
    #[inline(always)]
    fn apply(self, raw: u16) -> u16 {
        let d = u32::from(raw.saturating_sub(self.black));
        self.wb.apply(self.gain.apply(self.normalise.apply(d))) as u16
    }
}

/// A Q16 colour matrix split as [`MulQ16`] splits a constant: each coefficient
/// `m = hi * 2^16 + lo` with `lo` in `[0, 2^16)`, so `round(sum m_c v_c / 2^16)` is
/// `sum hi_c v_c` plus the rounded sum of the `lo_c v_c`, whose high and low halves are
/// added apart. Exact: the general engine's `i64` result in `u32` and `i32` lanes.
#[derive(Debug, Clone, Copy)]
struct CcmSplit {
    hi: [[i32; 3]; 3],
    lo: [[u32; 3]; 3],
}

impl CcmSplit {
    fn new(m: &[[i32; 3]; 3]) -> Self {
        Self {
            hi: m.map(|row| row.map(|k| k >> 16)),
            lo: m.map(|row| row.map(|k| (k & 0xFFFF) as u32)),
        }
    }

    /// Output channel `c` of the pixel `v`.
    #[inline(always)]
    fn channel(&self, c: usize, v: [u32; 3]) -> u16 {
        let (hi, lo) = (self.hi[c], self.lo[c]);
        // Coefficients are within [-8, 8), so |hi| <= 8 and these sums stay far from overflow.
        let whole = hi[0] * v[0] as i32 + hi[1] * v[1] as i32 + hi[2] * v[2] as i32;
        let p = [lo[0] * v[0], lo[1] * v[1], lo[2] * v[2]];
        let high = (p[0] >> 16) + (p[1] >> 16) + (p[2] >> 16);
        let low = (p[0] & 0xFFFF) + (p[1] & 0xFFFF) + (p[2] & 0xFFFF);
        let fraction = high + ((low + (1 << 15)) >> 16);
        (whole + fraction as i32).clamp(0, 65535) as u16
    }
}

/// `round(sum / 2^shift)` clamped to `u16`, as [`crate::frame::Sample::scaled_down`] does.
#[inline(always)]
fn scaled_down(sum: i32, shift: u32) -> u16 {
    ((sum + ((1 << shift) >> 1)) >> shift).clamp(0, 65535) as u16
}

/// Row `y`'s sites of one column parity in five rows `rows[k]` = row `y + k - 2`, as
/// `(same, other)` slices of [`Halves::sites`].
type SiteRows<'r> = [(&'r [u16], &'r [u16]); 5];

/// MHC at the green sites of a half: the chroma left and right into `horizontal`, the one
/// above and below into `vertical` (the taps of `demosaic`'s `MHC_CHROMA_HORIZONTAL` and
/// `MHC_CHROMA_VERTICAL`; integer sums, so their order does not matter).
#[inline(always)]
fn mhc_green(rows: SiteRows<'_>, own: &mut [u16], horizontal: &mut [u16], vertical: &mut [u16]) {
    let n = own.len();
    let (horizontal, vertical) = (&mut horizontal[..n], &mut vertical[..n]);
    let s = rows.map(|r| &r.0[..n + 2]);
    let t = rows.map(|r| &r.1[..n + 1]);
    for i in 0..n {
        let v = |r: &[u16], k: usize| i32::from(r[k]);
        let c = i + 1;
        let centre = v(s[2], c);
        let left_right = v(t[2], i) + v(t[2], i + 1);
        let up_down = v(s[1], c) + v(s[3], c);
        let diagonals = v(t[1], i) + v(t[1], i + 1) + v(t[3], i) + v(t[3], i + 1);
        let far_left_right = v(s[2], i) + v(s[2], i + 2);
        let far_up_down = v(s[0], c) + v(s[4], c);
        own[i] = s[2][c];
        horizontal[i] = scaled_down(
            10 * centre + 8 * left_right - 2 * far_left_right - 2 * diagonals + far_up_down,
            4,
        );
        vertical[i] = scaled_down(
            10 * centre + 8 * up_down - 2 * far_up_down - 2 * diagonals + far_left_right,
            4,
        );
    }
}

/// MHC at the red or blue sites of a half: green into `green`, the other chroma into
/// `opposite` (`MHC_G_AT_CHROMA` and `MHC_OPPOSITE`).
#[inline(always)]
fn mhc_chroma(rows: SiteRows<'_>, own: &mut [u16], green: &mut [u16], opposite: &mut [u16]) {
    let n = own.len();
    let (green, opposite) = (&mut green[..n], &mut opposite[..n]);
    let s = rows.map(|r| &r.0[..n + 2]);
    let t = rows.map(|r| &r.1[..n + 1]);
    for i in 0..n {
        let v = |r: &[u16], k: usize| i32::from(r[k]);
        let c = i + 1;
        let centre = v(s[2], c);
        let cross = v(s[1], c) + v(s[3], c) + v(t[2], i) + v(t[2], i + 1);
        let diagonals = v(t[1], i) + v(t[1], i + 1) + v(t[3], i) + v(t[3], i + 1);
        let far = v(s[0], c) + v(s[4], c) + v(s[2], i) + v(s[2], i + 2);
        own[i] = s[2][c];
        green[i] = scaled_down(8 * centre + 4 * cross - 2 * far, 4);
        opposite[i] = scaled_down(12 * centre + 4 * diagonals - 3 * far, 4);
    }
}

/// Bilinear at the green sites of a half (`demosaic`'s `bilinear_row`).
#[inline(always)]
fn bilinear_green(
    rows: SiteRows<'_>,
    own: &mut [u16],
    horizontal: &mut [u16],
    vertical: &mut [u16],
) {
    let n = own.len();
    let (horizontal, vertical) = (&mut horizontal[..n], &mut vertical[..n]);
    let s = rows.map(|r| &r.0[..n + 2]);
    let t = rows.map(|r| &r.1[..n + 1]);
    for i in 0..n {
        let v = |r: &[u16], k: usize| i32::from(r[k]);
        let c = i + 1;
        own[i] = s[2][c];
        horizontal[i] = scaled_down(v(t[2], i) + v(t[2], i + 1), 1);
        vertical[i] = scaled_down(v(s[1], c) + v(s[3], c), 1);
    }
}

/// Bilinear at the red or blue sites of a half.
#[inline(always)]
fn bilinear_chroma(rows: SiteRows<'_>, own: &mut [u16], green: &mut [u16], opposite: &mut [u16]) {
    let n = own.len();
    let (green, opposite) = (&mut green[..n], &mut opposite[..n]);
    let s = rows.map(|r| &r.0[..n + 2]);
    let t = rows.map(|r| &r.1[..n + 1]);
    for i in 0..n {
        let v = |r: &[u16], k: usize| i32::from(r[k]);
        let c = i + 1;
        own[i] = s[2][c];
        let cross = v(s[1], c) + v(s[3], c) + v(t[2], i) + v(t[2], i + 1);
        green[i] = scaled_down(cross, 2);
        let diagonals = v(t[1], i) + v(t[1], i + 1) + v(t[3], i) + v(t[3], i + 1);
        opposite[i] = scaled_down(diagonals, 2);
    }
}

/// Splits `planes` (R, G, B, each `w` long: even half, then odd half) into the half of
/// `parity` of each, ordered as the site kernels want them: the site's own colour, then the
/// two it lacks (horizontal then vertical at green; green then the opposite chroma at red or
/// blue).
fn site_planes(
    planes: &mut [u16],
    halves: Halves,
    parity: usize,
    own: CfaColour,
    horizontal: CfaColour,
) -> [&mut [u16]; 3] {
    let w = halves.even + halves.odd;
    let (r, rest) = planes.split_at_mut(w);
    let (g, b) = rest.split_at_mut(w);
    fn half(p: &mut [u16], parity: usize, even: usize) -> &mut [u16] {
        match parity {
            0 => &mut p[..even],
            _ => &mut p[even..],
        }
    }
    let [r, g, b] = [r, g, &mut b[..w]].map(|p| half(p, parity, halves.even));
    match (own, horizontal) {
        (CfaColour::Green, CfaColour::Red) => [g, r, b],
        (CfaColour::Green, _) => [g, b, r],
        (CfaColour::Red, _) => [r, g, b],
        (CfaColour::Blue, _) => [b, g, r],
    }
}

/// Runs rows `rows` of `raw` through `path` into `out` on the planar schedule; the caller
/// has checked [`takes`], the rows, the output's size and the scratch's length.
#[inline(always)]
pub(super) fn run<O: OutputSample>(
    path: &FixedPipeline<'_>,
    raw: &RawFrame<'_>,
    rows: Range<usize>,
    scratch: &mut [u16],
    out: &mut RgbViewMut<'_, O>,
) -> Result<(), IspError> {
    let mosaic = raw.mosaic();
    let (w, h, pattern) = (mosaic.width(), mosaic.height(), mosaic.pattern());
    let halves = Halves::new(w);
    let row_len = halves.len();
    if scratch.len() < scratch_needed(w) {
        return Err(IspError::BufferTooSmall {
            needed: scratch_needed(w),
            provided: scratch.len(),
        });
    }
    let (ring, rest) = scratch.split_at_mut(MOSAIC_ROWS * row_len);
    let planes = &mut rest[..3 * w];
    let steps = pointwise_steps(path, raw);
    let ccm = path.ccm_q.as_ref().map(CcmSplit::new);
    let mut tags = [usize::MAX; MOSAIC_ROWS];
    for y in rows.clone() {
        for dm in -2..=2isize {
            let my = reflect(y as isize + dm, h);
            let slot = my % MOSAIC_ROWS;
            if tags[slot] != my {
                let row = &mut ring[slot * row_len..(slot + 1) * row_len];
                prepare_row(path, raw, my, steps[my & 1], halves, row);
                tags[slot] = my;
            }
        }
        let ring: &[u16] = ring;
        let source: [&[u16]; 5] = core::array::from_fn(|k| {
            let slot = reflect(y as isize + k as isize - 2, h) % MOSAIC_ROWS;
            &ring[slot * row_len..(slot + 1) * row_len]
        });
        demosaic_row(path.method, source, halves, pattern, y, planes);
        if let Some(m) = &ccm {
            colour_matrix(m, planes, w);
        }
        encode_row(path, planes, halves, out.row_mut(y - rows.start));
    }
    Ok(())
}

/// The pointwise constants of the two CFA positions of each row parity: `[row][column]`.
fn pointwise_steps(path: &FixedPipeline<'_>, raw: &RawFrame<'_>) -> [[Pointwise; 2]; 2] {
    let pattern = raw.mosaic().pattern();
    let black = raw.black_level();
    core::array::from_fn(|ry| {
        core::array::from_fn(|rx| {
            let position = ry * 2 + rx;
            let colour = pattern.colour_at(rx, ry).index();
            Pointwise {
                black: black[position],
                normalise: MulQ16::new(super::recip_q16(raw.white_level() - black[position])),
                gain: path.gain_q16.map_or(MulQ16::ONE, MulQ16::new),
                wb: path
                    .wb_q16
                    .map_or(MulQ16::ONE, |wb| MulQ16::new(wb[colour])),
            }
        })
    })
}

/// Raw row `my` through defect correction and the pointwise stage into the halves of `dst`.
#[inline(always)]
fn prepare_row(
    path: &FixedPipeline<'_>,
    raw: &RawFrame<'_>,
    my: usize,
    steps: [Pointwise; 2],
    halves: Halves,
    dst: &mut [u16],
) {
    let w = halves.even + halves.odd;
    let o = halves.odd_start();
    let mut corrected = [0u16; CHUNK];
    // CHUNK is even, so each chunk starts at an even column.
    for x0 in (0..w).step_by(CHUNK) {
        let n = CHUNK.min(w - x0);
        dpc::correct_span(raw, &path.dpc, my, x0, &mut corrected[..n]);
        let pairs = n / 2;
        let even = &mut dst[1 + x0 / 2..1 + x0 / 2 + pairs];
        for (e, pair) in even.iter_mut().zip(corrected[..2 * pairs].chunks_exact(2)) {
            *e = steps[0].apply(pair[0]);
        }
        let odd = &mut dst[o + 1 + x0 / 2..o + 1 + x0 / 2 + pairs];
        for (d, pair) in odd.iter_mut().zip(corrected[..2 * pairs].chunks_exact(2)) {
            *d = steps[1].apply(pair[1]);
        }
        if n % 2 == 1 {
            // The last column of an odd width.
            dst[1 + (x0 + n - 1) / 2] = steps[0].apply(corrected[n - 1]);
        }
    }
    halves.pad(dst);
}

/// Demosaics row `y` from its five prepared rows into `planes`.
#[inline(always)]
fn demosaic_row(
    method: Method,
    source: [&[u16]; 5],
    halves: Halves,
    pattern: CfaPattern,
    y: usize,
    planes: &mut [u16],
) {
    for parity in 0..2 {
        let rows: SiteRows<'_> = source.map(|r| {
            let (same, other, _) = halves.sites(r, parity);
            (same, other)
        });
        let own = pattern.colour_at(parity, y);
        let horizontal = pattern.colour_at(parity + 1, y);
        let [a, b, c] = site_planes(planes, halves, parity, own, horizontal);
        match (method, own) {
            (Method::Mhc, CfaColour::Green) => mhc_green(rows, a, b, c),
            (Method::Mhc, _) => mhc_chroma(rows, a, b, c),
            (_, CfaColour::Green) => bilinear_green(rows, a, b, c),
            (_, _) => bilinear_chroma(rows, a, b, c),
        }
    }
}

/// The colour matrix on the planes, in place.
#[inline(always)]
fn colour_matrix(m: &CcmSplit, planes: &mut [u16], w: usize) {
    let (r, rest) = planes.split_at_mut(w);
    let (g, b) = rest.split_at_mut(w);
    let (g, b) = (&mut g[..r.len()], &mut b[..r.len()]);
    for ((r, g), b) in r.iter_mut().zip(g.iter_mut()).zip(b.iter_mut()) {
        let v = [u32::from(*r), u32::from(*g), u32::from(*b)];
        *r = m.channel(0, v);
        *g = m.channel(1, v);
        *b = m.channel(2, v);
    }
}

/// Encodes the planes to 8-bit sRGB, interleaving the halves into the output row.
#[inline(always)]
fn encode_row<O: OutputSample>(
    path: &FixedPipeline<'_>,
    planes: &[u16],
    halves: Halves,
    out: &mut [O],
) {
    let w = halves.even + halves.odd;
    let encode = |v: u16| O::from_code(path.encode.lookup8(v));
    let plane = |c: usize| &planes[c * w..(c + 1) * w];
    let [r, g, b] = [plane(0), plane(1), plane(2)];
    let (even, odd) = (halves.even, halves.odd);
    for (i, px) in out[..6 * odd].chunks_exact_mut(6).enumerate() {
        px[0] = encode(r[i]);
        px[1] = encode(g[i]);
        px[2] = encode(b[i]);
        px[3] = encode(r[even + i]);
        px[4] = encode(g[even + i]);
        px[5] = encode(b[even + i]);
    }
    if even > odd {
        let i = even - 1;
        out[3 * (w - 1)] = encode(r[i]);
        out[3 * (w - 1) + 1] = encode(g[i]);
        out[3 * (w - 1) + 2] = encode(b[i]);
    }
}

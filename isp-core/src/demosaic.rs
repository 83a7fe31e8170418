//! Demosaicing: from one CFA sample per pixel to RGB.
//!
//! **Bilinear** fills each missing colour with the rounded mean of the same-colour pixels in the
//! 3x3 neighbourhood: G at R/B sites `(N + S + W + E + 2) >> 2`, the opposite chroma
//! `(NW + NE + SW + SE + 2) >> 2`, and at G sites `(W + E + 1) >> 1` and `(N + S + 1) >> 1`.
//! Integer arithmetic throughout; outputs cannot exceed the inputs, so nothing saturates.
//!
//! **Malvar-He-Cutler** ([`mhc`], Malvar, He and Cutler, ICASSP 2004) adds a gradient correction
//! from the pixel's own channel through fixed 5x5 filters (the paper's coefficients, in
//! sixteenths so they are integers): G at R/B sites, R/B at G sites (one filter for the chroma
//! lying horizontally, its transpose for the one lying vertically), and B at R / R at B. The sum
//! is rounded half up (`(s + 8) >> 4`) and clamped to the sample type's range (0..=255 for `u8`,
//! 0..=65535 for `u16`): the filters overshoot at edges, and integer outputs saturate rather than
//! wrap. Data of fewer bits in a `u16` (12-bit raw, say) can overshoot its own white level; the
//! caller clamps to it. Borders mirror (reflect-101, two pixels deep); frames under 3 pixels wide
//! or high fall back to bilinear.
//!
//! Border modes ([`Border`]):
//! - [`Border::Reflect101`] (default): neighbours outside the frame mirror about the edge pixel
//!   without repeating it (`-1 -> 1`, `w -> w - 2`), which keeps the CFA parity, so every pixel
//!   keeps its own sample. A frame 1 pixel wide or high has no mirror: there each missing colour
//!   is the rounded mean of its in-frame neighbours of that colour, or the pixel's own sample
//!   where the line holds none (a BGGR column has no red at all).
//! - [`Border::OpenCv`]: exactly `cv::cvtColor(..., COLOR_Bayer*2RGB)`: the interior as above,
//!   then column 0 copied from column 1 and the last column from the one before, then row 0 from
//!   row 1 and the last row from the one before (so border pixels lose their own sample). Like
//!   OpenCV, a frame narrower or shorter than 3 pixels comes out all zero.

use crate::frame::{MosaicView, RgbViewMut, Sample};
use crate::{CfaColour, CfaPattern, IspError};

/// How demosaicing treats pixels whose neighbourhood crosses the frame edge.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Border {
    /// Mirror without repeating the edge; keeps CFA parity.
    #[default]
    Reflect101,
    /// OpenCV's rule, for bit-exact comparison with `cvtColor`.
    OpenCv,
}

/// The input's width and height, if the output has the same.
fn same_size<T: Sample>(
    input: &MosaicView<'_, T>,
    output: &RgbViewMut<'_, T>,
) -> Result<(usize, usize), IspError> {
    let (w, h) = (input.width(), input.height());
    if output.width() != w || output.height() != h {
        return Err(IspError::InvalidParameter {
            name: "output",
            allowed: "the same size as the input",
        });
    }
    Ok((w, h))
}

/// Bilinear demosaic of `input` into `output` (same size).
///
/// ```
/// use isp_core::demosaic::{bilinear, Border};
/// use isp_core::frame::{MosaicView, RgbViewMut};
/// use isp_core::CfaPattern;
/// let flat = [100u16; 16];
/// let mosaic = MosaicView::new(&flat, 4, 4, 4, CfaPattern::Rggb).unwrap();
/// let mut rgb = [0u16; 48];
/// let mut out = RgbViewMut::new(&mut rgb, 4, 4, 12).unwrap();
/// bilinear(&mosaic, Border::Reflect101, &mut out).unwrap();
/// assert!(rgb.iter().all(|v| *v == 100)); // a flat field stays flat
/// ```
pub fn bilinear<T: Sample>(
    input: &MosaicView<'_, T>,
    border: Border,
    output: &mut RgbViewMut<'_, T>,
) -> Result<(), IspError> {
    let (w, h) = same_size(input, output)?;
    let pattern = input.pattern();
    match border {
        Border::Reflect101 if w == 1 || h == 1 => {
            // A line: the 3x3 rule's reflected neighbours would fold onto the pixel itself.
            for y in 0..h {
                for x in 0..w {
                    let rgb = line_pixel(input, x, y);
                    output.row_mut(y)[3 * x..3 * x + 3].copy_from_slice(&rgb);
                }
            }
        }
        Border::Reflect101 => {
            for y in 0..h {
                let (up, down) = (reflect(y as isize - 1, h), reflect(y as isize + 1, h));
                let rows = [input.row(up), input.row(y), input.row(down)];
                bilinear_row(
                    rows,
                    y,
                    pattern,
                    |x| (reflect(x as isize - 1, w), reflect(x as isize + 1, w)),
                    output.row_mut(y),
                    0..w,
                );
            }
        }
        Border::OpenCv => {
            if w < 3 || h < 3 {
                for y in 0..h {
                    output.row_mut(y).fill(T::default());
                }
                return Ok(());
            }
            for y in 1..h - 1 {
                let rows = [input.row(y - 1), input.row(y), input.row(y + 1)];
                let out = output.row_mut(y);
                bilinear_row(rows, y, pattern, |x| (x - 1, x + 1), out, 1..w - 1);
                out.copy_within(3..6, 0);
                out.copy_within(3 * (w - 2)..3 * (w - 1), 3 * (w - 1));
            }
            output.copy_row(1, 0);
            output.copy_row(h - 2, h - 1);
        }
    }
    Ok(())
}

/// One pixel of a 1-pixel-wide or -high frame: each missing colour is the rounded mean of the
/// distinct in-frame neighbours of that colour, or the pixel's own sample if there is none.
fn line_pixel<T: Sample>(input: &MosaicView<'_, T>, x: usize, y: usize) -> [T; 3] {
    let pattern = input.pattern();
    let own = pattern.colour_at(x, y);
    let mut sum = [0u32; 3];
    let mut count = [0u32; 3];
    for (dx, dy) in [
        (-1isize, 0isize),
        (1, 0),
        (0, -1),
        (0, 1),
        (-1, -1),
        (1, -1),
        (-1, 1),
        (1, 1),
    ] {
        let (nx, ny) = (x as isize + dx, y as isize + dy);
        if nx < 0 || ny < 0 {
            continue;
        }
        if let Some(v) = input.get(nx as usize, ny as usize) {
            let c = pattern.colour_at(nx as usize, ny as usize).index();
            sum[c] += v.to_u32();
            count[c] += 1;
        }
    }
    let own_value = input.get(x, y).unwrap_or_default();
    let mut rgb = [own_value; 3];
    for c in 0..3 {
        if c != own.index() && count[c] > 0 {
            rgb[c] = T::from_u32((sum[c] + count[c] / 2) / count[c]);
        }
    }
    rgb
}

/// Nearest (superpixel) demosaic, the cheapest preview: each pixel takes R, B and the rounded
/// mean of the two Gs from the 2x2 Bayer window whose top-left corner is the pixel's even-aligned
/// block origin (moved back by one where the frame ends at an odd size). Any 2x2 window of a
/// Bayer mosaic holds one R, one B and two Gs, so the colours come from `colour_at`. A frame 1
/// pixel wide or high has no 2x2 window: it uses bilinear's line rule.
pub fn nearest<T: Sample>(
    input: &MosaicView<'_, T>,
    output: &mut RgbViewMut<'_, T>,
) -> Result<(), IspError> {
    let (w, h) = same_size(input, output)?;
    if w == 1 || h == 1 {
        return bilinear(input, Border::Reflect101, output);
    }
    let pattern = input.pattern();
    let origin = |i: usize, n: usize| (i & !1).min(n - 2);
    for y in 0..h {
        let by = origin(y, h);
        let rows = [input.row(by), input.row(by + 1)];
        let out = output.row_mut(y);
        for x in 0..w {
            let bx = origin(x, w);
            let mut sum = [0u32; 3];
            for (dy, row) in rows.iter().enumerate() {
                for dx in 0..2 {
                    sum[pattern.colour_at(bx + dx, by + dy).index()] += row[bx + dx].to_u32();
                }
            }
            out[3 * x] = T::from_u32(sum[0]);
            out[3 * x + 1] = T::from_u32((sum[1] + 1) >> 1);
            out[3 * x + 2] = T::from_u32(sum[2]);
        }
    }
    Ok(())
}

/// One tap of a 5x5 filter: offset and weight (in sixteenths).
type Tap = (i8, i8, i32);

/// G at R or B sites.
const MHC_G_AT_CHROMA: [Tap; 9] = [
    (0, 0, 8),
    (0, -1, 4),
    (0, 1, 4),
    (-1, 0, 4),
    (1, 0, 4),
    (0, -2, -2),
    (0, 2, -2),
    (-2, 0, -2),
    (2, 0, -2),
];
/// At G sites, the chroma whose samples lie left and right.
const MHC_CHROMA_HORIZONTAL: [Tap; 11] = [
    (0, 0, 10),
    (-1, 0, 8),
    (1, 0, 8),
    (-2, 0, -2),
    (2, 0, -2),
    (-1, -1, -2),
    (1, -1, -2),
    (-1, 1, -2),
    (1, 1, -2),
    (0, -2, 1),
    (0, 2, 1),
];
/// At G sites, the chroma whose samples lie above and below (the transpose).
const MHC_CHROMA_VERTICAL: [Tap; 11] = [
    (0, 0, 10),
    (0, -1, 8),
    (0, 1, 8),
    (0, -2, -2),
    (0, 2, -2),
    (-1, -1, -2),
    (1, -1, -2),
    (-1, 1, -2),
    (1, 1, -2),
    (-2, 0, 1),
    (2, 0, 1),
];
/// B at R sites and R at B sites.
const MHC_OPPOSITE: [Tap; 9] = [
    (0, 0, 12),
    (-1, -1, 4),
    (1, -1, 4),
    (-1, 1, 4),
    (1, 1, 4),
    (0, -2, -3),
    (0, 2, -3),
    (-2, 0, -3),
    (2, 0, -3),
];

/// Malvar-He-Cutler demosaic of `input` into `output` (same size); see the module docs.
pub fn mhc<T: Sample>(
    input: &MosaicView<'_, T>,
    output: &mut RgbViewMut<'_, T>,
) -> Result<(), IspError> {
    let (w, h) = same_size(input, output)?;
    if w < 3 || h < 3 {
        return bilinear(input, Border::Reflect101, output);
    }
    let pattern = input.pattern();
    let max = T::MAX as i32;
    for y in 0..h {
        let rows: [&[T]; 5] =
            core::array::from_fn(|i| input.row(reflect(y as isize + i as isize - 2, h)));
        let out = output.row_mut(y);
        for x in 0..w {
            let cols: [usize; 5] =
                core::array::from_fn(|i| reflect(x as isize + i as isize - 2, w));
            let apply = |taps: &[Tap]| -> T {
                let sum: i32 = taps
                    .iter()
                    .map(|&(dx, dy, k)| {
                        k * rows[(2 + dy) as usize][cols[(2 + dx) as usize]].to_u32() as i32
                    })
                    .sum();
                T::from_u32(((sum + 8) >> 4).clamp(0, max) as u32)
            };
            let own = pattern.colour_at(x, y);
            let mut rgb = [rows[2][x]; 3];
            match own {
                CfaColour::Green => {
                    rgb[pattern.colour_at(x + 1, y).index()] = apply(&MHC_CHROMA_HORIZONTAL);
                    rgb[pattern.colour_at(x, y + 1).index()] = apply(&MHC_CHROMA_VERTICAL);
                }
                chroma => {
                    rgb[1] = apply(&MHC_G_AT_CHROMA);
                    rgb[if chroma == CfaColour::Red { 2 } else { 0 }] = apply(&MHC_OPPOSITE);
                }
            }
            out[3 * x..3 * x + 3].copy_from_slice(&rgb);
        }
    }
    Ok(())
}

/// Index `i` reflected without repeating the edge: valid for `i` up to `n - 1` steps outside
/// `0..n` (one step for bilinear, two for MHC, which needs `n >= 3`); a 1-long line maps to 0.
#[inline]
fn reflect(i: isize, n: usize) -> usize {
    if n == 1 {
        0
    } else if i < 0 {
        (-i) as usize
    } else if i as usize >= n {
        2 * n - 2 - i as usize
    } else {
        i as usize
    }
}

/// Demosaics the pixels `xs` of row `y` from its three source rows (above, itself, below);
/// `horizontal(x)` gives the columns of the left and right neighbours.
fn bilinear_row<T: Sample>(
    rows: [&[T]; 3],
    y: usize,
    pattern: CfaPattern,
    horizontal: impl Fn(usize) -> (usize, usize),
    out: &mut [T],
    xs: core::ops::Range<usize>,
) {
    let [up, mid, down] = rows;
    let v = |row: &[T], x: usize| row[x].to_u32();
    for x in xs {
        let (l, r) = horizontal(x);
        let own = pattern.colour_at(x, y);
        let mut rgb = [0u32; 3];
        rgb[own.index()] = v(mid, x);
        match own {
            CfaColour::Green => {
                // The horizontal neighbours carry one chroma, the vertical ones the other.
                let horizontal_colour = pattern.colour_at(x + 1, y);
                let vertical_colour = pattern.colour_at(x, y + 1);
                rgb[horizontal_colour.index()] = (v(mid, l) + v(mid, r) + 1) >> 1;
                rgb[vertical_colour.index()] = (v(up, x) + v(down, x) + 1) >> 1;
            }
            chroma => {
                let g = v(up, x) + v(down, x) + v(mid, l) + v(mid, r);
                let opposite = v(up, l) + v(up, r) + v(down, l) + v(down, r);
                rgb[1] = (g + 2) >> 2;
                let other = if chroma == CfaColour::Red { 2 } else { 0 };
                rgb[other] = (opposite + 2) >> 2;
            }
        }
        out[3 * x] = T::from_u32(rgb[0]);
        out[3 * x + 1] = T::from_u32(rgb[1]);
        out[3 * x + 2] = T::from_u32(rgb[2]);
    }
}

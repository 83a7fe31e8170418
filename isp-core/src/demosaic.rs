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
//! **Nearest** ([`nearest`]) is the 2x2 superpixel preview.
//!
//! **Directional** ([`directional::directional`]) is the high-quality method: directional
//! colour differences with gradient weights, computed in `f32` over ring buffers of 16 rows in
//! caller scratch (see its module). It needs an 11-pixel window, so the 5-row [`row`] (and
//! [`demosaic`], a loop over it) refuse it; the pipeline runs it through its own ring buffers
//! ([`crate::pipeline`]).
//!
//! Every method works on `u8` and `u16` (integer arithmetic) and on `f32` in `[0, 1]` (the
//! same filters, exact division, clamped to `[0, 1]`): see [`Sample`].
//!
//! **Streaming.** [`row`] demosaics one row from the five source rows around it (already
//! reflected at the frame edges by [`reflect`]); the whole-frame functions are loops over it, so
//! a pipeline holding five rows in a ring buffer gets bit-identical output.
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

pub mod directional;
pub(crate) mod planar;

/// How demosaicing treats pixels whose neighbourhood crosses the frame edge.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Border {
    /// Mirror without repeating the edge; keeps CFA parity.
    #[default]
    Reflect101,
    /// OpenCV's rule, for bit-exact comparison with `cvtColor`.
    OpenCv,
}

/// A demosaicing method: the one list of isp-core's methods. The pipeline runs every one. The
/// first three also run from five rows ([`row`], [`demosaic`]; reflect-101 borders);
/// [`Method::Directional`] is [`directional::directional`] (and its integer twin
/// [`directional::directional_fixed`]) with its own ring buffers, which [`row`] refuses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Method {
    /// 2x2 superpixel replication, the cheapest preview.
    Nearest,
    /// Bilinear interpolation of same-colour neighbours.
    #[default]
    Bilinear,
    /// Malvar-He-Cutler 2004 gradient-corrected 5x5 filters.
    Mhc,
    /// The high-quality directional method.
    Directional,
}

impl Method {
    /// All methods, cheapest first.
    pub const ALL: [Method; 4] = [Self::Nearest, Self::Bilinear, Self::Mhc, Self::Directional];

    /// The methods [`row`] runs.
    pub const STREAMING: [Method; 3] = [Self::Nearest, Self::Bilinear, Self::Mhc];

    /// The method's name as the command line spells it.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Nearest => "nearest",
            Self::Bilinear => "bilinear",
            Self::Mhc => "mhc",
            Self::Directional => "directional",
        }
    }

    /// Whether [`row`] runs it (the pipeline runs every method).
    pub const fn streams(self) -> bool {
        !matches!(self, Self::Directional)
    }

    /// Rows above and below the output row the method reads.
    pub const fn radius(self) -> usize {
        match self {
            Self::Nearest | Self::Bilinear => 1,
            Self::Mhc => 2,
            Self::Directional => directional::HALO,
        }
    }

    /// The error the streaming functions give for a method they do not run.
    const fn not_streaming() -> IspError {
        IspError::InvalidParameter {
            name: "demosaic method",
            allowed:
                "nearest, bilinear or mhc from five rows (directional: directional::directional, or the pipeline)",
        }
    }
}

impl core::str::FromStr for Method {
    type Err = IspError;

    /// Parses `nearest`, `bilinear`, `mhc` or `directional` (any case).
    fn from_str(s: &str) -> Result<Self, IspError> {
        Self::ALL
            .into_iter()
            .find(|m| m.name().eq_ignore_ascii_case(s))
            .ok_or(IspError::InvalidParameter {
                name: "demosaic method",
                allowed: "one of nearest, bilinear, mhc, directional",
            })
    }
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

/// Demosaics `input` into `output` (same size) with a streaming `method` and reflect-101
/// borders.
///
/// Bilinear and MHC on frames at least 3x3 run over rows split by column parity, in strips of
/// 1024 columns held on the stack (8212 samples: 16 KiB for `u16`, 32 KiB for `f32`; with
/// 512 columns bilinear ran 12 % slower), so their loops vectorise; the output equals
/// [`row`]'s, row by row, bit for bit. On x86-64,
/// [`demosaic_avx2`] is the same code compiled for AVX2: about 880 Mpix/s for bilinear and 680
/// for MHC on one core at 16 bits, against 866 for OpenCV's bilinear `cvtColor`
/// (`scripts/bench-demosaic.sh`, 2026-11-23). Firmware runs the streaming pipeline
/// ([`crate::pipeline`]), which needs no such stack.
pub fn demosaic<T: Sample>(
    method: Method,
    input: &MosaicView<'_, T>,
    output: &mut RgbViewMut<'_, T>,
) -> Result<(), IspError> {
    demosaic_body(method, input, output)
}

/// [`demosaic`] compiled for x86-64 CPUs with AVX2: the same output (the same operations in
/// wider lanes), faster for bilinear and MHC.
///
/// # Safety
///
/// The CPU must support AVX2; check first with `is_x86_feature_detected!("avx2")`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
pub fn demosaic_avx2<T: Sample>(
    method: Method,
    input: &MosaicView<'_, T>,
    output: &mut RgbViewMut<'_, T>,
) -> Result<(), IspError> {
    demosaic_body(method, input, output)
}

/// [`demosaic`]'s body, inlined into each entry so each is compiled for its target.
#[inline(always)]
fn demosaic_body<T: Sample>(
    method: Method,
    input: &MosaicView<'_, T>,
    output: &mut RgbViewMut<'_, T>,
) -> Result<(), IspError> {
    if !method.streams() {
        return Err(Method::not_streaming());
    }
    let (w, h) = same_size(input, output)?;
    if matches!(method, Method::Bilinear | Method::Mhc) && w >= 3 && h >= 3 {
        // The parity-split kernel: the same output as the row function below, vectorised.
        planar::whole_frame(method, input, output);
        return Ok(());
    }
    for y in 0..h {
        let rows: [&[T]; 5] =
            core::array::from_fn(|i| input.row(reflect(y as isize + i as isize - 2, h)));
        row(method, rows, y, h, input.pattern(), output.row_mut(y))?;
    }
    Ok(())
}

/// Demosaics row `y` of a frame `h` rows high into `out` (`3 * width` samples, RGB).
///
/// `rows[i]` is source row `reflect(y + i - 2, h)` (all the same width, at least 1); bilinear
/// and nearest read only `rows[1..4]`. Errors if the rows differ in width, `out` is not
/// three times that width, or `method` does not stream.
pub fn row<T: Sample>(
    method: Method,
    rows: [&[T]; 5],
    y: usize,
    h: usize,
    pattern: CfaPattern,
    out: &mut [T],
) -> Result<(), IspError> {
    if !method.streams() {
        return Err(Method::not_streaming());
    }
    let w = rows[2].len();
    if w == 0 || rows.iter().any(|r| r.len() != w) || y >= h {
        return Err(IspError::InvalidParameter {
            name: "rows",
            allowed: "five rows of one width >= 1, and y < h",
        });
    }
    if out.len() != 3 * w {
        return Err(IspError::InvalidParameter {
            name: "out",
            allowed: "3 * width samples",
        });
    }
    if w == 1 || h == 1 {
        line_row(rows, y, h, pattern, out);
        return Ok(());
    }
    match method {
        Method::Nearest => nearest_row(rows, y, h, pattern, out),
        Method::Mhc if w >= 3 && h >= 3 => mhc_row(rows, y, pattern, out),
        // Directional was refused above.
        Method::Bilinear | Method::Mhc | Method::Directional => bilinear_row(
            [rows[1], rows[2], rows[3]],
            y,
            pattern,
            |x| {
                if x > 0 && x + 1 < w {
                    (x - 1, x + 1)
                } else {
                    (reflect(x as isize - 1, w), reflect(x as isize + 1, w))
                }
            },
            out,
            0..w,
        ),
    }
    Ok(())
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
    bilinear_body(input, border, output)
}

/// [`bilinear`] compiled for x86-64 CPUs with AVX2, as [`demosaic_avx2`] is [`demosaic`].
///
/// # Safety
///
/// The CPU must support AVX2; check first with `is_x86_feature_detected!("avx2")`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
pub fn bilinear_avx2<T: Sample>(
    input: &MosaicView<'_, T>,
    border: Border,
    output: &mut RgbViewMut<'_, T>,
) -> Result<(), IspError> {
    bilinear_body(input, border, output)
}

/// [`bilinear`]'s body, inlined into each entry.
#[inline(always)]
fn bilinear_body<T: Sample>(
    input: &MosaicView<'_, T>,
    border: Border,
    output: &mut RgbViewMut<'_, T>,
) -> Result<(), IspError> {
    let (w, h) = same_size(input, output)?;
    match border {
        Border::Reflect101 => demosaic_body(Method::Bilinear, input, output)?,
        Border::OpenCv => {
            if w < 3 || h < 3 {
                for y in 0..h {
                    output.row_mut(y).fill(T::default());
                }
                return Ok(());
            }
            // Inside the one-pixel border both borders give the same values (every
            // neighbour exists); OpenCV's border then copies the next column and row inward.
            demosaic_body(Method::Bilinear, input, output)?;
            for y in 1..h - 1 {
                let out = output.row_mut(y);
                out.copy_within(3..6, 0);
                out.copy_within(3 * (w - 2)..3 * (w - 1), 3 * (w - 1));
            }
            output.copy_row(1, 0);
            output.copy_row(h - 2, h - 1);
        }
    }
    Ok(())
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
    demosaic(Method::Nearest, input, output)
}

/// Malvar-He-Cutler demosaic of `input` into `output` (same size); see the module docs.
pub fn mhc<T: Sample>(
    input: &MosaicView<'_, T>,
    output: &mut RgbViewMut<'_, T>,
) -> Result<(), IspError> {
    demosaic(Method::Mhc, input, output)
}

/// Index `i` mirrored into `0..n` without repeating the edge (`-1 -> 1`, `n -> n - 2`), folded
/// as often as needed; a 1-long line maps everything to 0, and `n = 0` gives 0.
#[inline]
pub fn reflect(i: isize, n: usize) -> usize {
    if i >= 0 && (i as usize) < n {
        return i as usize;
    }
    if n <= 1 {
        return 0;
    }
    let period = 2 * (n - 1);
    let m = i.rem_euclid(period as isize) as usize;
    if m < n {
        m
    } else {
        period - m
    }
}

/// Row `y` of a frame 1 pixel wide or high: each missing colour is the rounded mean of the
/// in-frame neighbours of that colour along the line, or the pixel's own sample if there is none
/// (the 3x3 rule's reflected neighbours would fold onto the pixel itself).
fn line_row<T: Sample>(rows: [&[T]; 5], y: usize, h: usize, pattern: CfaPattern, out: &mut [T]) {
    let w = rows[2].len();
    for x in 0..w {
        let own = rows[2][x];
        let mut sum = [T::Acc::default(); 3];
        let mut count = [0u32; 3];
        let mut add = |v: T, nx: usize, ny: usize| {
            let c = pattern.colour_at(nx, ny).index();
            sum[c] = sum[c] + v.weighted(1);
            count[c] += 1;
        };
        if x > 0 {
            add(rows[2][x - 1], x - 1, y);
        }
        if x + 1 < w {
            add(rows[2][x + 1], x + 1, y);
        }
        if y > 0 {
            add(rows[1][x], x, y - 1);
        }
        if y + 1 < h {
            add(rows[3][x], x, y + 1);
        }
        let own_colour = pattern.colour_at(x, y).index();
        for c in 0..3 {
            out[3 * x + c] = if c != own_colour && count[c] > 0 {
                T::mean(sum[c], count[c])
            } else {
                own
            };
        }
    }
}

/// Nearest for one row of a frame at least 2x2; `rows` as for [`row`].
fn nearest_row<T: Sample>(rows: [&[T]; 5], y: usize, h: usize, pattern: CfaPattern, out: &mut [T]) {
    let w = rows[2].len();
    let origin = |i: usize, n: usize| (i & !1).min(n - 2);
    let by = origin(y, h);
    // The block's two rows are in frame, so no reflection: rows[1] is y - 1, rows[3] is y + 1.
    let block_rows = if by == y {
        [rows[2], rows[3]]
    } else {
        [rows[1], rows[2]]
    };
    for x in 0..w {
        let bx = origin(x, w);
        let mut sum = [T::Acc::default(); 3];
        for (dy, r) in block_rows.iter().enumerate() {
            for dx in 0..2 {
                let c = pattern.colour_at(bx + dx, by + dy).index();
                sum[c] = sum[c] + r[bx + dx].weighted(1);
            }
        }
        out[3 * x] = T::scaled_down(sum[0], 0);
        out[3 * x + 1] = T::scaled_down(sum[1], 1);
        out[3 * x + 2] = T::scaled_down(sum[2], 0);
    }
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

/// What a CFA site lacks: at a green site, the colours lying horizontally and vertically;
/// at a chroma site, the opposite chroma.
#[derive(Clone, Copy)]
enum Site {
    Green { horizontal: usize, vertical: usize },
    Chroma { opposite: usize },
}

impl Site {
    fn at(pattern: CfaPattern, x: usize, y: usize) -> Self {
        match pattern.colour_at(x, y) {
            CfaColour::Green => Self::Green {
                horizontal: pattern.colour_at(x + 1, y).index(),
                vertical: pattern.colour_at(x, y + 1).index(),
            },
            CfaColour::Red => Self::Chroma { opposite: 2 },
            CfaColour::Blue => Self::Chroma { opposite: 0 },
        }
    }
}

/// A 5x5 filter at interior column `x` (two or more from either edge), summed in the taps'
/// order (which the float path's rounding depends on).
#[inline(always)]
fn interior_filter<T: Sample>(window: &[[T; 5]; 5], taps: &[Tap]) -> T {
    let mut sum = T::Acc::default();
    for &(dx, dy, k) in taps {
        sum = sum + window[(2 + dy) as usize][(2 + dx) as usize].weighted(k);
    }
    T::scaled_down(sum, 4)
}

/// Malvar-He-Cutler at interior column `x`, a `site` pixel.
#[inline(always)]
fn mhc_interior<T: Sample>(rows: &[&[T]; 5], x: usize, site: Site, out: &mut [T]) {
    let window: [[T; 5]; 5] = core::array::from_fn(|r| {
        let row = &rows[r][x - 2..x + 3];
        [row[0], row[1], row[2], row[3], row[4]]
    });
    let rows = &window;
    let mut rgb = [rows[2][2]; 3];
    match site {
        Site::Green {
            horizontal,
            vertical,
        } => {
            rgb[horizontal] = interior_filter(rows, &MHC_CHROMA_HORIZONTAL);
            rgb[vertical] = interior_filter(rows, &MHC_CHROMA_VERTICAL);
        }
        Site::Chroma { opposite } => {
            rgb[1] = interior_filter(rows, &MHC_G_AT_CHROMA);
            rgb[opposite] = interior_filter(rows, &MHC_OPPOSITE);
        }
    }
    out[3 * x..3 * x + 3].copy_from_slice(&rgb);
}

/// Malvar-He-Cutler for one row of a frame at least 3x3; `rows` as for [`row`].
fn mhc_row<T: Sample>(rows: [&[T]; 5], y: usize, pattern: CfaPattern, out: &mut [T]) {
    let w = rows[2].len();
    if w >= 6 {
        // The interior in pairs of one site of each kind, the kinds fixed for the row, so
        // the loop body has no colour tests and no reflection; the columns near the edges
        // take the general loop below.
        let sites = [Site::at(pattern, 0, y), Site::at(pattern, 1, y)];
        let mut x = 2;
        while x + 3 < w {
            mhc_interior(&rows, x, sites[0], out);
            mhc_interior(&rows, x + 1, sites[1], out);
            x += 2;
        }
        for x in (0..2).chain(x..w) {
            mhc_general(&rows, x, y, pattern, out);
        }
        return;
    }
    for x in 0..w {
        mhc_general(&rows, x, y, pattern, out);
    }
}

/// Malvar-He-Cutler at any column `x` of row `y`, reflecting columns at the edges.
fn mhc_general<T: Sample>(
    rows: &[&[T]; 5],
    x: usize,
    y: usize,
    pattern: CfaPattern,
    out: &mut [T],
) {
    let w = rows[2].len();
    let pixel = |x: usize, cols: [usize; 5], out: &mut [T]| {
        let apply = |taps: &[Tap]| -> T {
            let mut sum = T::Acc::default();
            for &(dx, dy, k) in taps {
                sum = sum + rows[(2 + dy) as usize][cols[(2 + dx) as usize]].weighted(k);
            }
            T::scaled_down(sum, 4)
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
    };
    let cols: [usize; 5] = core::array::from_fn(|i| reflect(x as isize + i as isize - 2, w));
    pixel(x, cols, out);
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
    let v = |row: &[T], x: usize| row[x].weighted(1);
    for x in xs {
        let (l, r) = horizontal(x);
        let own = pattern.colour_at(x, y);
        let mut rgb = [mid[x]; 3];
        match own {
            CfaColour::Green => {
                // The horizontal neighbours carry one chroma, the vertical ones the other.
                let horizontal_colour = pattern.colour_at(x + 1, y);
                let vertical_colour = pattern.colour_at(x, y + 1);
                rgb[horizontal_colour.index()] = T::scaled_down(v(mid, l) + v(mid, r), 1);
                rgb[vertical_colour.index()] = T::scaled_down(v(up, x) + v(down, x), 1);
            }
            chroma => {
                let g = v(up, x) + v(down, x) + v(mid, l) + v(mid, r);
                let opposite = v(up, l) + v(up, r) + v(down, l) + v(down, r);
                rgb[1] = T::scaled_down(g, 2);
                let other = if chroma == CfaColour::Red { 2 } else { 0 };
                rgb[other] = T::scaled_down(opposite, 2);
            }
        }
        out[3 * x..3 * x + 3].copy_from_slice(&rgb);
    }
}

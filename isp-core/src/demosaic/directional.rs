//! The high-quality method: directional colour-difference demosaicing with ratio-free
//! refinement, designed for a fixed window and a band of line buffers.
//!
//! [`directional`] computes in `f32` on samples scaled to `[0, 1]` (any FPU-equipped core;
//! integer samples are converted on the way in and rounded half up on the way out);
//! [`directional_fixed`] is the same method in integer arithmetic for cores without one (`u8`
//! and `u16` samples, `i32` scratch; same CPSNR on the standard sets). Seven stages over a band of
//! rows with a 12-row halo above and below (and 12 columns left and right), reflected at the
//! frame edges like every other method (reflect-101, which keeps the CFA parity):
//!
//! 1. **Directional colour differences.** At every pixel, Hamilton-Adams estimates of the
//!    missing green (at R/B) or chroma (at G) along the row and along the column give two
//!    colour-difference planes `G - C`, horizontal and vertical.
//! 2. **Their gradients** along their own direction, summed over 3x3 windows displaced north,
//!    south, west and east of the pixel (the gradient-based threshold-free idea of
//!    Pekkucuksen and Altunbasak, ICIP 2010, with our own windows and weights).
//! 3. **Green at R/B** blends two estimates. The first adds to the pixel's own sample the four
//!    one-sided smoothed colour differences (taps 0.56, 0.35, 0.08, 0.01 from the centre out),
//!    weighted by the inverse square of each side's gradient sum. The second is a gradient-
//!    weighted mean of the green neighbours alone, steered by a horizontal/vertical classifier
//!    from the same gradient sums. The blend favours the colour-difference estimate (0.6 to
//!    0.95) where the colour differences are smoother than the raw samples, and the plain
//!    neighbours where they are not: colour differences hold for natural scenes (Kodak) but
//!    break on saturated, weakly correlated colour (McMaster).
//! 4. **Classifiers on the mosaic** (horizontal/vertical and the two diagonals): a sum of
//!    squared first and second differences along each direction, refined by the mean of the
//!    four diagonal neighbours' where those are more decided (fading from one to the other
//!    where both are about equally decided, so the method stays continuous). This statistic
//!    and steps 5-6 follow Luis Sanz Rodríguez's ratio corrected demosaicing (RCD), without its
//!    ratios and its hard switch.
//! 5. **B at R and R at B**: colour differences from the four diagonal neighbours, weighted by
//!    inverse gradients and steered by the diagonal classifier.
//! 6. **R and B at G**: the same from the four cardinal neighbours (now all known), steered by
//!    the horizontal/vertical classifier.
//!
//! Every estimate is clamped to `[0, 1]` before use, so no overshoot survives and integer
//! outputs saturate. The window reaches 11 pixels out; frames 1 pixel wide or high use
//! bilinear's line rule (see the parent module).
//!
//! **Streaming.** Each stage runs one row at a time, a fixed number of rows behind the stage it
//! reads, over ring buffers of rows: [`scratch_len`]`(width)` samples in all (83 rows of the
//! padded width), about 690 kB for a 2048-pixel-wide frame and independent of the height.
//! Rows are stored split into their even and odd columns, so the pixels of one CFA colour in a
//! row are consecutive and each stage computes only the sites that need it (green only at red
//! and blue pixels, for instance) in a straight loop over slices, which vectorises. On x86-64,
//! [`directional_avx2`] is the same code compiled for AVX2 (bit-identical output): 138-140 Mpix/s
//! single-thread at 16 bits on Kodak and McMaster on the project's Zen 3 EPYC (`camsim bench
//! demosaic`, 2026-11-24; MHC 623-668 in the same runs).
//!
//! The schedule is a `Stream`: one step reads one padded row and writes one frame row once
//! the stages have caught up. The whole-frame functions run it from the top; the pipeline
//! ([`crate::pipeline`]) feeds it its prepared rows (after defect correction, black level and
//! white balance) and starts it again wherever a band starts, 12 rows above it.

use super::{reflect, same_size, Method};
use crate::frame::{MosaicView, RgbViewMut, Sample};
use crate::{CfaColour, CfaPattern, IspError};

mod fixed;
pub use fixed::directional_fixed;
#[cfg(target_arch = "x86_64")]
pub use fixed::directional_fixed_avx2;
#[cfg(target_arch = "x86_64")]
pub use fixed::directional_fixed_avx512;
pub(crate) use fixed::Fixed;

/// Rows and columns of context outside the frame (even, so padded coordinates keep the
/// frame's CFA parity).
pub const HALO: usize = 12;
/// Floor of the one-sided gradients, in units of full scale.
const EPS: f32 = 1e-5;
/// Added to the gradient sums that weight the colour differences and classify the green
/// estimate: one 16-bit step of full scale (the integer method's 4 units), so a sum that is
/// off zero by rounding alone weighs as zero does, and the weights are continuous where a
/// side is flat (with a bare `1 / s^2` a side at exactly zero took all the weight, one at
/// 1e-9 almost none).
const SUM_FLOOR: f32 = 1.0 / 65535.0;
/// One-sided smoothing of the colour differences, centre first.
const SMOOTH: [f32; 4] = [0.56, 0.35, 0.08, 0.01];
/// [`SMOOTH`] in percent, for the integer method.
const SMOOTH_PERCENT: [i32; 4] = [56, 35, 8, 1];

/// Rows held by each ring buffer (powers of two), in the order [`Planes::split`] takes them:
/// each is at least the span from the row a stage writes to the oldest row a later stage still
/// reads (see [`directional_body`]'s schedule).
const RING_ROWS: [usize; 8] = [
    16, // mosaic: written at lag 0, read down to lag 14 (output, vertical neighbours)
    8,  // diff_h
    8,  // diff_v: lag 2, read down to lag 9 (green)
    8,  // sum3_v: lag 4, read down to lag 8 (green)
    8,  // sum3_h
    16, // class: lag 3, read down to lag 12 (output)
    8,  // green: lag 6, read down to lag 13 (output)
    8,  // opposite: lag 8, read down to lag 14 (output)
];
/// Rows of all ring buffers together, plus three rows for the output's planar colours.
const SCRATCH_ROWS: usize = {
    let mut sum = 3;
    let mut k = 0;
    while k < RING_ROWS.len() {
        sum += RING_ROWS[k];
        k += 1;
    }
    sum
};

/// Samples in one stored row for a frame `width` pixels wide: the padded row split into its
/// even and odd columns, each half `(width + 2 * HALO + 1) / 2` long.
const fn row_len(width: usize) -> Option<usize> {
    let Some(padded) = width.checked_add(2 * HALO + 1) else {
        return None;
    };
    Some(padded / 2 * 2)
}

/// Scratch samples [`directional`] needs for a frame `width` pixels wide; `None` on overflow.
///
/// ```
/// use isp_core::demosaic::directional::{scratch_len, HALO};
/// assert_eq!(scratch_len(100), Some(83 * (100 + 2 * HALO)));
/// ```
pub const fn scratch_len(width: usize) -> Option<usize> {
    let Some(row) = row_len(width) else {
        return None;
    };
    row.checked_mul(SCRATCH_ROWS)
}

/// Demosaics `input` into `output` (same size) with the directional method, using `scratch`
/// (at least [`scratch_len`]`(width)` samples).
///
/// ```
/// use isp_core::demosaic::directional::{directional, scratch_len};
/// use isp_core::frame::{MosaicView, RgbViewMut};
/// use isp_core::CfaPattern;
/// let flat = [1000u16; 64];
/// let mosaic = MosaicView::new(&flat, 8, 8, 8, CfaPattern::Grbg).unwrap();
/// let mut rgb = [0u16; 192];
/// let mut out = RgbViewMut::new(&mut rgb, 8, 8, 24).unwrap();
/// let mut scratch = vec![0f32; scratch_len(8).unwrap()];
/// directional(&mosaic, &mut out, &mut scratch).unwrap();
/// assert!(rgb.iter().all(|v| *v == 1000)); // a flat field stays flat
/// ```
pub fn directional<T: Sample>(
    input: &MosaicView<'_, T>,
    output: &mut RgbViewMut<'_, T>,
    scratch: &mut [f32],
) -> Result<(), IspError> {
    directional_body(input, output, scratch)
}

/// The method itself, inlined into each entry point so each is compiled for its own target
/// features.
#[inline(always)]
fn directional_body<T: Sample>(
    input: &MosaicView<'_, T>,
    output: &mut RgbViewMut<'_, T>,
    scratch: &mut [f32],
) -> Result<(), IspError> {
    whole_frame::<Float<T>, LANES>(input, output, scratch)
}

/// Runs a [`Stream`] over the whole frame: every padded row read once, every frame row written
/// once.
#[inline(always)]
fn whole_frame<A: Arithmetic, const L: usize>(
    input: &MosaicView<'_, A::T>,
    output: &mut RgbViewMut<'_, A::T>,
    scratch: &mut [A::E],
) -> Result<(), IspError>
where
    A::T: Sample,
{
    let Some(frame) = prepare(input, output, scratch.len())? else {
        return Ok(());
    };
    let mut p = Planes::split(scratch, frame.half * 2);
    let h = frame.h;
    for t in 0..schedule_len(h) {
        let due = Due::at(t, 0, h);
        let source = due
            .mosaic
            .map(|r| input.row(reflect(r as isize - HALO as isize, h)));
        let out = due
            .output
            .map(|r| OutputRow::Interleaved(output.row_mut(r - HALO)));
        step::<A, L>(&frame, &mut p, due, source.map(SourceRow::Interleaved), out);
    }
    Ok(())
}

/// A frame row of the mosaic as a stream reads it.
#[derive(Clone, Copy)]
pub(crate) enum SourceRow<'a, T> {
    /// The samples in column order.
    Interleaved(&'a [T]),
    /// The even columns and the odd columns (`(w + 1) / 2` and `w / 2` samples).
    Split {
        /// Columns 0, 2, 4, ...
        even: &'a [T],
        /// Columns 1, 3, 5, ...
        odd: &'a [T],
    },
}

/// Where a stream writes a frame row.
pub(crate) enum OutputRow<'a, T> {
    /// Interleaved RGB, `3 * w` samples.
    Interleaved(&'a mut [T]),
    /// Three planes, R then G then B, of `w` samples each, each its even columns then its odd
    /// ones: the layout the pipeline's planar schedule works on.
    Planes(&'a mut [T]),
}

/// Runs the stages `due` names: reads `source` (the frame row `due.mosaic` reflects) and
/// writes `out` (frame row `due.output`).
#[inline(always)]
fn step<A: Arithmetic, const L: usize>(
    frame: &Frame,
    p: &mut Planes<'_, A::E>,
    due: Due,
    source: Option<SourceRow<'_, A::T>>,
    out: Option<OutputRow<'_, A::T>>,
) {
    if let (Some(r), Some(source)) = (due.mosaic, source) {
        match source {
            SourceRow::Interleaved(row) => frame.read_row(row, r, &mut p.mosaic, A::enter),
            SourceRow::Split { even, odd } => {
                frame.read_split(even, odd, r, &mut p.mosaic, A::enter)
            }
        }
    }
    if let Some(r) = due.diff {
        A::diff(frame, r, p);
    }
    if let Some(r) = due.class {
        A::class::<L>(frame, r, p);
    }
    if let Some(r) = due.sum3 {
        frame.sum3_row(r, p);
    }
    if let Some(r) = due.green {
        A::green(frame, r, p);
    }
    if let Some(r) = due.chroma {
        A::chroma::<L>(frame, r, p);
    }
    if let (Some(r), Some(out)) = (due.output, out) {
        match out {
            OutputRow::Interleaved(out) => A::output::<L>(frame, r, p, out),
            OutputRow::Planes(out) => {
                A::estimate_output::<L>(frame, r, p);
                frame.write_planes(r, p, out, A::leave);
            }
        }
    }
}

/// One version of the method's arithmetic: the working element its ring buffers hold, how
/// samples enter and leave it, and the stages whose arithmetic differs (the gradient stages
/// are shared, generic over [`Level`]). [`Float`] is the `f32` method, `fixed::Fixed` the
/// integer one. `L` is the sites per block of the integer stages' vector loops ([`LANES`],
/// or [`LANES_AVX512`] in the AVX-512 builds); the `f32` stages loop over slices and ignore
/// it.
pub(crate) trait Arithmetic {
    /// The sample type in and out.
    type T: Copy;
    /// The working element.
    type E: Copy + Level;
    /// A sample on the working scale.
    fn enter(v: Self::T) -> Self::E;
    /// A working value back on the sample's scale (the exact inverse of `enter` on values it
    /// made).
    fn leave(v: Self::E) -> Self::T;
    /// Stage 1.
    fn diff(frame: &Frame, r: usize, p: &mut Planes<'_, Self::E>);
    /// Stage 4's classifiers.
    fn class<const L: usize>(frame: &Frame, r: usize, p: &mut Planes<'_, Self::E>);
    /// Stage 3.
    fn green(frame: &Frame, r: usize, p: &mut Planes<'_, Self::E>);
    /// Stage 5.
    fn chroma<const L: usize>(frame: &Frame, r: usize, p: &mut Planes<'_, Self::E>);
    /// Stage 6 and the interleaved output row.
    fn output<const L: usize>(
        frame: &Frame,
        r: usize,
        p: &mut Planes<'_, Self::E>,
        out: &mut [Self::T],
    );
    /// Stage 6 alone: red and blue at the green sites, into the planes' output rows.
    fn estimate_output<const L: usize>(frame: &Frame, r: usize, p: &mut Planes<'_, Self::E>);
}

/// The `f32` method on samples of type `T`.
pub(crate) struct Float<T>(core::marker::PhantomData<T>);

impl<T: Sample> Arithmetic for Float<T> {
    type T = T;
    type E = f32;
    #[inline(always)]
    fn enter(v: T) -> f32 {
        v.to_unit()
    }
    #[inline(always)]
    fn leave(v: f32) -> T {
        T::from_unit(v)
    }
    #[inline(always)]
    fn diff(frame: &Frame, r: usize, p: &mut Planes<'_, f32>) {
        frame.diff_row(r, p);
    }
    #[inline(always)]
    fn class<const L: usize>(frame: &Frame, r: usize, p: &mut Planes<'_, f32>) {
        frame.class_row(r, p);
    }
    #[inline(always)]
    fn green(frame: &Frame, r: usize, p: &mut Planes<'_, f32>) {
        frame.green_row(r, p);
    }
    #[inline(always)]
    fn chroma<const L: usize>(frame: &Frame, r: usize, p: &mut Planes<'_, f32>) {
        frame.chroma_row(r, p);
    }
    #[inline(always)]
    fn output<const L: usize>(frame: &Frame, r: usize, p: &mut Planes<'_, f32>, out: &mut [T]) {
        frame.output_row(r, p, out);
    }
    #[inline(always)]
    fn estimate_output<const L: usize>(frame: &Frame, r: usize, p: &mut Planes<'_, f32>) {
        frame.output_estimates(r, p);
    }
}

/// The method as a stream of rows: each step reads one padded mosaic row (given by the
/// caller) and, once the stages have caught up, writes one frame row. A stream started at
/// frame row `y` ([`Stream::restart`]) first reads the 12 rows above `y` (reflected at the
/// frame's top) and writes `y` first, and each row it writes equals the whole frame's: every
/// stage skips the rows within its radius of the first row read, as the whole frame skips
/// those within its radius of the padded top, so nothing is read that this run did not
/// write. That is how the pipeline runs the method on any band.
pub(crate) struct Stream<'s, A: Arithmetic> {
    frame: Frame,
    planes: Planes<'s, A::E>,
    /// The padded row this run read first.
    first: usize,
    /// The padded row the next step reads (past the padded bottom once all are read).
    next: usize,
}

impl<'s, A: Arithmetic> Stream<'s, A> {
    /// A stream for a `width` x `height` mosaic of `pattern` in `scratch` (at least
    /// [`scratch_len`]`(width)` elements); `None` when the frame is under 2 pixels wide or
    /// high, which the method does not stream (it falls back to bilinear's line rule).
    pub(crate) fn new(
        width: usize,
        height: usize,
        pattern: CfaPattern,
        scratch: &'s mut [A::E],
    ) -> Result<Option<Self>, IspError> {
        if width < 2 || height < 2 {
            return Ok(None);
        }
        let frame = geometry(width, height, pattern, scratch.len())?;
        let stride = frame.half * 2;
        Ok(Some(Stream {
            frame,
            planes: Planes::split(scratch, stride),
            first: 0,
            next: 0,
        }))
    }

    /// Starts again so that the next row written is frame row `y`.
    pub(crate) fn restart(&mut self, y: usize) {
        self.first = y;
        self.next = y;
    }

    /// The schedule of the next step.
    #[inline(always)]
    fn due(&self) -> Due {
        Due::at(self.next, self.first, self.frame.h)
    }

    /// Whether every frame row from the start has been written.
    #[inline(always)]
    pub(crate) fn finished(&self) -> bool {
        self.next >= schedule_len(self.frame.h)
    }

    /// The frame row whose samples the next step reads, if it reads one.
    #[inline(always)]
    pub(crate) fn next_read(&self) -> Option<usize> {
        let r = self.due().mosaic?;
        Some(reflect(r as isize - HALO as isize, self.frame.h))
    }

    /// The frame row the next step writes, if it writes one.
    #[inline(always)]
    pub(crate) fn next_output(&self) -> Option<usize> {
        self.due().output.map(|r| r - HALO)
    }

    /// Runs one step: reads `source` (the row [`Stream::next_read`] named) and writes `out`
    /// (the row [`Stream::next_output`] named); either is ignored when the step has no use
    /// for it.
    #[inline(always)]
    pub(crate) fn step<const L: usize>(
        &mut self,
        source: Option<SourceRow<'_, A::T>>,
        out: Option<OutputRow<'_, A::T>>,
    ) {
        let due = self.due();
        step::<A, L>(&self.frame, &mut self.planes, due, source, out);
        self.next += 1;
    }

    /// The stored mosaic rows around frame row `y` (rows `y - 1`, `y`, `y + 1`, reflected),
    /// each a padded row split by parity, and the length of each half: padded column
    /// `x + HALO` of frame column `x` is at `(x + HALO) / 2`, in the odd half for odd `x`.
    /// Held while `y` is the row written last (as for [`Stream::sample`]).
    #[inline(always)]
    pub(crate) fn mosaic_around(&self, y: usize) -> ([&[A::E]; 3], usize) {
        let r = y + HALO;
        let rows = [
            self.planes.mosaic.row(r - 1),
            self.planes.mosaic.row(r),
            self.planes.mosaic.row(r + 1),
        ];
        (rows, self.frame.half)
    }

    /// The sample the stream read at frame row `y`, column `x`, each within one of a row it
    /// wrote last (reflected at the frame's edges): the mosaic around an output pixel, for the
    /// pipeline's highlight stage.
    #[inline(always)]
    pub(crate) fn sample(&self, y: isize, x: isize) -> A::T {
        let (r, c) = ((y + HALO as isize) as usize, (x + HALO as isize) as usize);
        A::leave(self.planes.mosaic.row(r)[c / 2 + (c % 2) * self.frame.half])
    }
}

/// [`directional`] compiled for x86-64 CPUs with AVX2: eight lanes per vector instead of
/// four, the same operations in the same order, so the output is bit-identical (no FMA
/// contraction happens without fast-math).
///
/// On other targets use [`directional`].
///
/// # Safety
///
/// The CPU must support AVX2 (a function with a target feature is unsafe to call from code
/// compiled without it). Check first, as `camsim` does with
/// `is_x86_feature_detected!("avx2")`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
pub fn directional_avx2<T: Sample>(
    input: &MosaicView<'_, T>,
    output: &mut RgbViewMut<'_, T>,
    scratch: &mut [f32],
) -> Result<(), IspError> {
    directional_body(input, output, scratch)
}

/// Checks the sizes and the scratch length; the frame's geometry, or `None` when the frame is
/// too thin for the window and has been demosaiced by the fallback already.
#[inline(always)]
fn prepare<T: Sample>(
    input: &MosaicView<'_, T>,
    output: &mut RgbViewMut<'_, T>,
    scratch_len_given: usize,
) -> Result<Option<Frame>, IspError> {
    let (w, h) = same_size(input, output)?;
    if w < 2 || h < 2 {
        super::demosaic(Method::Bilinear, input, output)?;
        return Ok(None);
    }
    geometry(w, h, input.pattern(), scratch_len_given).map(Some)
}

/// The geometry of a `w` x `h` frame (both at least 2), checking the scratch length.
fn geometry(
    w: usize,
    h: usize,
    pattern: CfaPattern,
    scratch_len_given: usize,
) -> Result<Frame, IspError> {
    let too_wide = IspError::InvalidParameter {
        name: "width",
        allowed: "small enough that scratch_len(width) fits in usize",
    };
    let needed = scratch_len(w).ok_or(too_wide)?;
    let stride = row_len(w).ok_or(too_wide)?;
    if scratch_len_given < needed {
        return Err(IspError::InvalidParameter {
            name: "scratch",
            allowed: "at least scratch_len(width) samples",
        });
    }
    Ok(Frame {
        w,
        h,
        pw: w + 2 * HALO,
        half: stride / 2,
        pattern,
    })
}

/// Steps of the schedule for a frame `h` rows high: one per padded row read, plus the output
/// stage's lag.
fn schedule_len(h: usize) -> usize {
    h + 2 * HALO + 11
}

/// The padded row each stage works on at step `t` of the schedule, if any. Each stage runs a
/// fixed number of rows (its lag) behind the mosaic row read at step `t`, far enough for every
/// row it reads to be written, and skips the rows within its radius of the padded frame's top
/// and bottom (it cannot compute them and nothing reads them).
struct Due {
    mosaic: Option<usize>,
    diff: Option<usize>,
    class: Option<usize>,
    sum3: Option<usize>,
    green: Option<usize>,
    chroma: Option<usize>,
    /// Only the frame's own rows.
    output: Option<usize>,
}

impl Due {
    /// Step `t` (the padded row it reads) of a run that read padded row `first` first.
    #[inline(always)]
    fn at(t: usize, first: usize, h: usize) -> Due {
        let rows = h + 2 * HALO;
        let valid = |lag: usize, radius: usize| {
            t.checked_sub(lag)
                .filter(|r| *r >= first + radius && *r + radius < rows)
        };
        Due {
            mosaic: (t < rows).then_some(t),
            diff: valid(2, 2),
            class: valid(3, 3),
            sum3: valid(4, 4),
            green: valid(6, 6),
            chroma: valid(8, 8),
            output: t
                .checked_sub(11)
                .filter(|r| *r >= first + HALO && *r < HALO + h),
        }
    }
}

/// A ring buffer of rows, each `stride` samples: the padded row's even columns, then its odd
/// columns.
struct Ring<'a, E> {
    data: &'a mut [E],
    /// Rows held minus one (the count is a power of two).
    mask: usize,
    stride: usize,
}

impl<E> Ring<'_, E> {
    #[inline(always)]
    fn row(&self, r: usize) -> &[E] {
        let start = (r & self.mask) * self.stride;
        &self.data[start..start + self.stride]
    }

    #[inline(always)]
    fn row_mut(&mut self, r: usize) -> &mut [E] {
        let start = (r & self.mask) * self.stride;
        &mut self.data[start..start + self.stride]
    }

    /// Rows `r - N/2 ..= r + N/2`.
    #[inline(always)]
    fn rows<const N: usize>(&self, r: usize) -> [&[E]; N] {
        core::array::from_fn(|k| self.row(r + k - N / 2))
    }
}

/// The ring buffers, of `f32` in [`directional`] and of `i32` in [`directional_fixed`].
pub(crate) struct Planes<'a, E> {
    mosaic: Ring<'a, E>,
    diff_h: Ring<'a, E>,
    diff_v: Ring<'a, E>,
    /// The vertical gradients of `diff_v` summed over 3 columns.
    sum3_v: Ring<'a, E>,
    /// The horizontal gradients of `diff_h` summed over 3 rows.
    sum3_h: Ring<'a, E>,
    /// At green pixels the horizontal/vertical classifier on the mosaic (1 = use the horizontal
    /// estimate); at red and blue pixels the diagonal one (1 = use the NE-SW estimate).
    class: Ring<'a, E>,
    green: Ring<'a, E>,
    /// At red and blue pixels, the other of the two (blue at red, red at blue).
    opposite: Ring<'a, E>,
    /// The output row's red, green and blue, one split row each.
    out_rgb: [&'a mut [E]; 3],
}

impl<'a, E> Planes<'a, E> {
    fn split(scratch: &'a mut [E], stride: usize) -> Self {
        let mut rest = scratch;
        let mut take = |rows: usize| {
            let (data, tail) = core::mem::take(&mut rest).split_at_mut(rows * stride);
            rest = tail;
            Ring {
                data,
                mask: rows - 1,
                stride,
            }
        };
        let [mosaic, diff_h, diff_v, sum3_v, sum3_h, class, green, opposite] =
            RING_ROWS.map(&mut take);
        let [r, g, b] = [take(1), take(1), take(1)];
        Planes {
            mosaic,
            diff_h,
            diff_v,
            sum3_v,
            sum3_h,
            class,
            green,
            opposite,
            out_rgb: [r.data, g.data, b.data],
        }
    }
}

/// What output row `r` already knows: row `r` of the mosaic, the green estimate and the
/// opposite colour, and which of them holds each plane's value at each site. The one
/// statement of which colour comes from where, for [`Frame::fill_known`] and
/// [`Frame::write_planes`].
struct Known<'a, E> {
    rows: [&'a [E]; 3],
    green_parity: usize,
    /// The plane (0 red, 2 blue) of the row's red or blue sites' own colour.
    own: usize,
}

impl<'a, E> Known<'a, E> {
    /// The row holding plane `c`'s (0 red, 1 green, 2 blue) values at the sites of
    /// `parity`: the mosaic at a site's own colour, the green row for green at red and blue
    /// sites, the opposite row for the other colour there; `None` for red and blue at green
    /// sites, which stage 6 estimates into the output rows.
    #[inline(always)]
    fn row(&self, c: usize, parity: usize) -> Option<&'a [E]> {
        let [mosaic, green, opposite] = self.rows;
        match (parity == self.green_parity, c) {
            (true, 1) => Some(mosaic),
            (true, _) => None,
            (false, 1) => Some(green),
            (false, c) if c == self.own => Some(mosaic),
            (false, _) => Some(opposite),
        }
    }
}

/// The frame's geometry in padded coordinates (`HALO` added on every side).
#[derive(Clone, Copy)]
pub(crate) struct Frame {
    w: usize,
    h: usize,
    pw: usize,
    /// Samples in each half (even, odd columns) of a stored row.
    half: usize,
    pattern: CfaPattern,
}

/// The columns `x = 2 i + parity` of a padded row that a stage computes, as a run of `n`
/// consecutive samples in the row's `parity` half. Taps at column offsets from them are runs
/// in one half too, so every stage's inner loop is a straight, vectorisable pass over slices
/// of equal length.
#[derive(Clone, Copy)]
struct Span {
    parity: usize,
    /// First `i`.
    lo: usize,
    n: usize,
    half: usize,
}

impl Span {
    /// The columns of `parity` with `radius <= x < pw - radius`.
    fn new(frame: &Frame, parity: usize, radius: usize) -> Span {
        let lo = (radius + 1 - parity) / 2;
        let hi = (frame.pw - radius + 1 - parity) / 2;
        Span {
            parity,
            lo,
            n: hi - lo,
            half: frame.half,
        }
    }

    /// The samples `d` columns right of the span's columns in a stored row.
    #[inline(always)]
    fn tap<E>(self, row: &[E], d: isize) -> &[E] {
        let at = self.parity as isize + d;
        let start =
            (self.lo as isize + at.div_euclid(2)) as usize + at.rem_euclid(2) as usize * self.half;
        &row[start..start + self.n]
    }

    /// Taps `-(N/2) ..= N/2` of a row.
    #[inline(always)]
    fn taps<E, const N: usize>(self, row: &[E]) -> [&[E]; N] {
        core::array::from_fn(|k| self.tap(row, k as isize - (N / 2) as isize))
    }

    /// Tap 0 of each row.
    #[inline(always)]
    fn column<E, const N: usize>(self, rows: [&[E]; N]) -> [&[E]; N] {
        rows.map(|row| self.tap(row, 0))
    }

    /// Tap 0 of rows -3, -1, 1 and 3 of seven.
    #[inline(always)]
    fn odd_rows<E>(self, rows: [&[E]; 7]) -> [&[E]; 4] {
        [rows[0], rows[2], rows[4], rows[6]].map(|row| self.tap(row, 0))
    }

    /// Taps -3, -1, 1 and 3 of a row.
    #[inline(always)]
    fn odd_taps<E>(self, row: &[E]) -> [&[E]; 4] {
        [-3, -1, 1, 3].map(|d| self.tap(row, d))
    }

    /// The four diagonal neighbours (NW, NE, SW, SE) in rows -1..=1.
    #[inline(always)]
    fn diagonals<E>(self, rows: [&[E]; 3]) -> [&[E]; 4] {
        [
            self.tap(rows[0], -1),
            self.tap(rows[0], 1),
            self.tap(rows[2], -1),
            self.tap(rows[2], 1),
        ]
    }

    /// The span's own samples in a row being written.
    #[inline(always)]
    fn out<E>(self, row: &mut [E]) -> &mut [E] {
        let start = self.lo + self.parity * self.half;
        &mut row[start..start + self.n]
    }
}

/// Sites per block of [`Blocks`] in the AVX-512 build: one vector of `i32`.
#[cfg(target_arch = "x86_64")]
pub(crate) const LANES_AVX512: usize = 16;
/// Sites per block of [`Blocks`] in the other builds: one AVX2 vector of `i32`. Sixteen, two
/// AVX2 vectors per value, spilled more than it gained on AVX2's sixteen registers: the fixed
/// pipeline's directional frame took 21 ns per pixel against 17 on a Zen 3 EPYC.
#[cfg(not(target_arch = "arm"))]
pub(crate) const LANES: usize = 8;
/// Sites per block on 32-bit ARM (Cortex-M), which has no vector registers: blocks of eight
/// were arrays on the stack, gathered tap by tap with `memcpy`.
#[cfg(target_arch = "arm")]
pub(crate) const LANES: usize = 1;

/// A block of `L` sites of a span: whole block `b` (sites `b * L..`), or the last `L` sites
/// where the span is not a whole number of blocks (see [`for_each_block`]).
#[derive(Clone, Copy)]
pub(super) enum Block {
    /// Sites `b * L..(b + 1) * L`.
    Whole(usize),
    /// The span's last `L` sites.
    Last,
}

/// Calls `f` with each block of `L` sites covering a span of `n >= L` sites: every whole
/// block, then one ending at `n` that overlaps the block before and computes its shared sites
/// again, to the same values (a stage writes only its own sites and reads nothing it
/// writes). A plain loop over a span's sites ends in scalar code for up to `L` of them,
/// which cost 10-20 times a vector site: about a sixth of the fixed method's time at 16.
/// Two loops, not one over a chained iterator, so the first has a plain count (see
/// [`Blocks`] for the range checks that remain).
#[inline(always)]
pub(super) fn for_each_block<const L: usize>(n: usize, mut f: impl FnMut(Block)) {
    for b in 0..n / L {
        f(Block::Whole(b));
    }
    if !n.is_multiple_of(L) {
        f(Block::Last);
    }
}

/// `N` taps of a span of `n` sites (a stage's inputs), as blocks of `L` sites.
///
/// The whole blocks are held as the taps' chunks, each tap's the same count, so that in a
/// loop over them (see [`for_each_block`]) the taps' range checks merge into about one per
/// block: LLVM 22 keeps `b < count` inside `for b in 0..count`, but holds the one count in a
/// register. Build each stage's `Blocks` in a statement of its own: held in a tuple of
/// `Option`s they stayed on the stack, and each tap's block took a reload of its length, a
/// compare and a branch (53 per block at green sites).
pub(super) struct Blocks<'a, const N: usize, const L: usize> {
    whole: [&'a [[i32; L]]; N],
    last: [&'a [i32; L]; N],
}

impl<'a, const N: usize, const L: usize> Blocks<'a, N, L> {
    /// The blocks of `taps` over `n` sites; `None` if `n < L` or a tap is shorter than `n` (a
    /// span's taps are `n` long).
    #[inline(always)]
    pub(super) fn new(taps: &[&'a [i32]; N], n: usize) -> Option<Self> {
        let count = n / L;
        let mut whole: [&'a [[i32; L]]; N] = [&[]; N];
        let mut last: [&'a [i32; L]; N] = [&[0; L]; N];
        for k in 0..N {
            let tap = taps[k].get(..n)?;
            whole[k] = tap.as_chunks::<L>().0.get(..count)?;
            last[k] = tap.last_chunk::<L>()?;
        }
        Some(Self { whole, last })
    }

    /// Each tap's block `block`, as arrays: a stage's loop over such blocks has a known trip
    /// count and no bounds check that may exit early, so it vectorises without a scalar
    /// remainder.
    #[inline(always)]
    #[allow(clippy::needless_range_loop)]
    pub(super) fn at(&self, block: Block) -> [[i32; L]; N] {
        let mut out = [[0; L]; N];
        for k in 0..N {
            let chunk = match block {
                Block::Whole(b) => self.whole[k].get(b),
                Block::Last => Some(self.last[k]),
            };
            if let Some(chunk) = chunk {
                out[k] = *chunk;
            }
        }
        out
    }
}

/// Lane `j` of each of `N` blocks.
#[inline(always)]
#[allow(clippy::needless_range_loop)]
pub(super) fn lane<const N: usize, const L: usize>(blocks: &[[i32; L]; N], j: usize) -> [i32; N] {
    let mut v = [0; N];
    for k in 0..N {
        v[k] = blocks[k][j % L];
    }
    v
}

/// Writes a block of sites into a stage's output (the span's length).
#[inline(always)]
pub(super) fn store<const L: usize>(plane: &mut [i32], block: Block, values: &[i32; L]) {
    let chunk = match block {
        Block::Whole(b) => plane.as_chunks_mut::<L>().0.get_mut(b),
        Block::Last => plane.last_chunk_mut::<L>(),
    };
    if let Some(chunk) = chunk {
        *chunk = *values;
    }
}

/// Element `i` of each of `N` slices.
// A loop, not `array::from_fn`: inlined into the pipeline's large AVX2 entry, `from_fn` was
// left a call per pixel (the loops then ran 5x slower).
#[inline(always)]
#[allow(clippy::needless_range_loop)]
fn at<E: Copy + Default, const N: usize>(slices: &[&[E]; N], i: usize) -> [E; N] {
    let mut v = [E::default(); N];
    for k in 0..N {
        v[k] = slices[k][i];
    }
    v
}

/// `v` clamped to `[0, 1]`; NaN gives 0. Without a branch (`max` then `min`), so the scalar
/// rows do not mispredict on it.
#[inline(always)]
fn clamp01(v: f32) -> f32 {
    min(max(v, 0.0), 1.0)
}

/// The smaller of `a` and `b`, `b` if either is NaN: one `minps` on x86 (`f32::min`'s NaN
/// rule takes three instructions there). The stages take it of non-negative sums only.
#[inline(always)]
fn min(a: f32, b: f32) -> f32 {
    if a < b {
        a
    } else {
        b
    }
}

/// The larger of `a` and `b`, `b` if either is NaN (one `maxps`; see [`min`]).
#[inline(always)]
fn max(a: f32, b: f32) -> f32 {
    if a > b {
        a
    } else {
        b
    }
}

/// Half the width of the band of decidedness over which [`refined`] fades from the
/// neighbourhood's classifier to the pixel's own (1/64, exact in `f32` and Q16).
const FADE: f32 = 1.0 / 64.0;

/// A classifier refined by its neighbourhood: its own value `own` if it is more decided
/// (further from 0.5) than the mean of its four diagonal neighbours `diagonal`, else that
/// mean, with a linear fade between the two where they are within [`FADE`] of equally
/// decided. RCD switches hard; but where the two are equally decided in opposite directions a
/// hard switch turns a difference in the last bit (of the input's rounding, or between the
/// float and integer arithmetic) into the other direction's estimate, hundreds of 16-bit LSB
/// away. The fade keeps the method continuous, so the integer method tracks this one.
#[inline(always)]
fn refined(own: f32, diagonal: [f32; 4]) -> f32 {
    let around = 0.25 * (diagonal[0] + diagonal[1] + diagonal[2] + diagonal[3]);
    // How much more decided `own` is: 1 keeps it, 0 takes `around`.
    let lead = (0.5 - own).abs() - (0.5 - around).abs();
    let keep = clamp01((lead + FADE) * (0.5 / FADE));
    around + keep * (own - around)
}

/// Sum of squared first and second differences along a line of seven samples `v[0..7]`
/// centred on `v[3]`, over the three centre positions.
#[inline(always)]
fn line_stat(v: [f32; 7]) -> f32 {
    let mut s = 1e-10;
    for k in 2..5 {
        let first = v[k - 1] - v[k + 1];
        let second = 2.0 * v[k] - v[k - 2] - v[k + 2];
        s += first * first + 0.25 * second * second;
    }
    s
}

/// Inverse-gradient weighted colour difference from two opposite neighbours: `x` is the
/// chroma along the line at offsets -3, -1, +1, +3 and `g` the green at offsets `-2..=2`.
#[inline(always)]
fn pair_estimate(x: [f32; 4], g: [f32; 5]) -> f32 {
    // |a - b| and |b - a| are the same float, so the shared term is computed once.
    let across = (x[1] - x[2]).abs();
    let before = EPS + across + (x[1] - x[0]).abs() + (g[2] - g[0]).abs();
    let after = EPS + across + (x[2] - x[3]).abs() + (g[2] - g[4]).abs();
    (after * (x[1] - g[1]) + before * (x[2] - g[3])) / (before + after)
}

/// `|a0 - b0| + |a1 - b1| + |a2 - b2|` at each site of `out`: three gradients summed, in
/// that order (both methods).
#[inline(always)]
fn sum3_distances<E: Level>(a: [&[E]; 3], b: [&[E]; 3], out: &mut [E]) {
    for (i, sum) in out.iter_mut().enumerate() {
        *sum = a[0][i].distance(b[0][i]) + a[1][i].distance(b[1][i]) + a[2][i].distance(b[2][i]);
    }
}

/// A working sample of either method: what the stages both methods share need of it.
pub(crate) trait Level:
    Copy + PartialOrd + core::ops::Add<Output = Self> + core::ops::Sub<Output = Self>
{
    /// `|self - other|`.
    fn distance(self, other: Self) -> Self;
}

impl Level for f32 {
    #[inline(always)]
    fn distance(self, other: f32) -> f32 {
        (self - other).abs()
    }
}

impl Level for i32 {
    #[inline(always)]
    fn distance(self, other: i32) -> i32 {
        (self - other).abs()
    }
}

/// What the classifier stage reads: at the green pixels (`green`) the column and the row
/// through each, at the red and blue pixels (`other`) the two diagonals; seven samples each.
struct ClassTaps<'p, E> {
    green: Span,
    vertical: [&'p [E]; 7],
    horizontal: [&'p [E]; 7],
    other: Span,
    /// Rows -3..=3 at columns -3..=3 (NE-SW).
    along_p: [&'p [E]; 7],
    /// Rows -3..=3 at columns 3..=-3 (NW-SE).
    along_q: [&'p [E]; 7],
}

/// What the green stage reads at the red and blue pixels of a row (its span of them): the mosaic's column and
/// row (offsets -3..=3), the colour differences along them, and the gradient sums (-2..=2).
struct GreenTaps<'p, E> {
    span: Span,
    column: [&'p [E]; 7],
    row: [&'p [E]; 7],
    diff_v: [&'p [E]; 7],
    diff_h: [&'p [E]; 7],
    sum3_v: [&'p [E]; 5],
    sum3_h: [&'p [E]; 5],
}

/// What the chroma stage reads at the red and blue pixels of a row: along the NE-SW diagonal
/// (`_p`) and the NW-SE one (`_q`) the chroma at offsets -3, -1, 1, 3 and the green at -2..=2,
/// and the diagonal classifier with its four diagonal neighbours.
struct ChromaTaps<'p, E> {
    span: Span,
    chroma_p: [&'p [E]; 4],
    green_p: [&'p [E]; 5],
    chroma_q: [&'p [E]; 4],
    green_q: [&'p [E]; 5],
    class: &'p [E],
    class_around: [&'p [E]; 4],
}

/// What the output stage reads at the green pixels of a row: red and blue at offsets -3, -1,
/// 1, 3 along the column (`_v`) and the row (`_h`), green at -2..=2 along both, and the
/// horizontal/vertical classifier with its four diagonal neighbours.
struct GreenSiteTaps<'p, E> {
    span: Span,
    red_v: [&'p [E]; 4],
    red_h: [&'p [E]; 4],
    blue_v: [&'p [E]; 4],
    blue_h: [&'p [E]; 4],
    green_v: [&'p [E]; 5],
    green_h: [&'p [E]; 5],
    class: &'p [E],
    class_around: [&'p [E]; 4],
}

impl Frame {
    /// Parity of the green columns of padded row `r`.
    fn green_parity(&self, r: usize) -> usize {
        usize::from(self.pattern.colour_at(0, r) != CfaColour::Green)
    }

    /// Whether the red and blue pixels of padded row `r` are red.
    fn red_row(&self, r: usize) -> bool {
        self.pattern.colour_at(1 - self.green_parity(r), r) == CfaColour::Red
    }

    #[inline(always)]
    fn class_taps<'p, E>(&self, r: usize, mosaic: &'p Ring<'_, E>) -> ClassTaps<'p, E> {
        let m: [&[E]; 7] = mosaic.rows(r);
        let gp = self.green_parity(r);
        let (green, other) = (Span::new(self, gp, 3), Span::new(self, 1 - gp, 3));
        ClassTaps {
            green,
            vertical: green.column(m),
            horizontal: green.taps(m[3]),
            other,
            along_p: core::array::from_fn(|k| other.tap(m[k], k as isize - 3)),
            along_q: core::array::from_fn(|k| other.tap(m[k], 3 - k as isize)),
        }
    }

    /// Copies row `r`'s green samples into its green plane row.
    #[inline(always)]
    fn keep_green<E: Copy>(&self, r: usize, mosaic: &Ring<'_, E>, green: &mut Ring<'_, E>) {
        let copy = Span::new(self, self.green_parity(r), 6);
        copy.out(green.row_mut(r))
            .copy_from_slice(copy.tap(mosaic.row(r), 0));
    }

    /// The taps the green estimate at row `r`'s red and blue pixels reads.
    #[inline(always)]
    fn green_taps<'p, E>(
        &self,
        r: usize,
        mosaic: &'p Ring<'_, E>,
        diff: [&'p Ring<'_, E>; 2],
        sum3: [&'p Ring<'_, E>; 2],
    ) -> GreenTaps<'p, E> {
        let m: [&[E]; 7] = mosaic.rows(r);
        let span = Span::new(self, 1 - self.green_parity(r), 6);
        GreenTaps {
            span,
            column: span.column(m),
            row: span.taps(m[3]),
            diff_v: span.column(diff[0].rows(r)),
            diff_h: span.taps(diff[1].row(r)),
            sum3_v: span.column(sum3[0].rows(r)),
            sum3_h: span.taps(sum3[1].row(r)),
        }
    }

    #[inline(always)]
    fn chroma_taps<'p, E>(
        &self,
        r: usize,
        mosaic: &'p Ring<'_, E>,
        green: &'p Ring<'_, E>,
        class: &'p Ring<'_, E>,
    ) -> ChromaTaps<'p, E> {
        let span = Span::new(self, 1 - self.green_parity(r), 8);
        let m: [&[E]; 7] = mosaic.rows(r);
        let g: [&[E]; 5] = green.rows(r);
        let class: [&[E]; 3] = class.rows(r);
        ChromaTaps {
            span,
            chroma_p: core::array::from_fn(|k| span.tap(m[2 * k], 2 * k as isize - 3)),
            green_p: core::array::from_fn(|k| span.tap(g[k], k as isize - 2)),
            chroma_q: core::array::from_fn(|k| span.tap(m[2 * k], 3 - 2 * k as isize)),
            green_q: core::array::from_fn(|k| span.tap(g[k], 2 - k as isize)),
            class: span.tap(class[1], 0),
            class_around: span.diagonals(class),
        }
    }

    /// The taps for red and blue at row `r`'s green pixels.
    #[inline(always)]
    fn green_site_taps<'p, E>(
        &self,
        r: usize,
        mosaic: &'p Ring<'_, E>,
        opposite: &'p Ring<'_, E>,
        green: &'p Ring<'_, E>,
        class: &'p Ring<'_, E>,
    ) -> GreenSiteTaps<'p, E> {
        let m: [&[E]; 7] = mosaic.rows(r);
        let opposite: [&[E]; 7] = opposite.rows(r);
        let g: [&[E]; 5] = green.rows(r);
        let class: [&[E]; 3] = class.rows(r);
        // Along the row the neighbours of a green pixel are this row's red (blue) pixels, whose
        // samples are in the mosaic; along the column they are the other colour's pixels,
        // whose red (blue) is in `opposite`.
        let span = Span::new(self, self.green_parity(r), HALO);
        let (red_v, red_h, blue_v, blue_h) = if self.red_row(r) {
            (opposite, m[3], m, opposite[3])
        } else {
            (m, opposite[3], opposite, m[3])
        };
        GreenSiteTaps {
            span,
            red_v: span.odd_rows(red_v),
            red_h: span.odd_taps(red_h),
            blue_v: span.odd_rows(blue_v),
            blue_h: span.odd_taps(blue_h),
            green_v: span.column(g),
            green_h: span.taps(g[2]),
            class: span.tap(class[1], 0),
            class_around: span.diagonals(class),
        }
    }

    /// Row `r` of the mosaic, the green estimate and the opposite colour, as [`Known`].
    #[inline(always)]
    fn known<'a, E>(
        &self,
        r: usize,
        [mosaic, green, opposite]: [&'a Ring<'_, E>; 3],
    ) -> Known<'a, E> {
        Known {
            rows: [mosaic.row(r), green.row(r), opposite.row(r)],
            green_parity: self.green_parity(r),
            own: if self.red_row(r) { 0 } else { 2 },
        }
    }

    /// Fills the output rows with what row `r` already knows (see [`Known`]), for
    /// the interleaved output.
    #[inline(always)]
    fn fill_known<E: Copy>(&self, r: usize, p: &mut Planes<'_, E>) {
        let known = self.known(r, [&p.mosaic, &p.green, &p.opposite]);
        for (c, plane) in p.out_rgb.iter_mut().enumerate() {
            for parity in 0..2 {
                if let Some(known) = known.row(c, parity) {
                    let span = Span::new(self, parity, HALO);
                    span.out(plane).copy_from_slice(span.tap(known, 0));
                }
            }
        }
    }

    /// The frame column that padded column `x`, in the halo, reflects (reflect-101). Written
    /// out where the frame is wider than the halo: [`reflect`]'s general case takes a 64-bit
    /// division, 24 of them per row read.
    #[inline(always)]
    fn halo_source(&self, x: usize) -> usize {
        if self.w <= HALO {
            reflect(x as isize - HALO as isize, self.w)
        } else if x < HALO {
            HALO - x
        } else {
            2 * (self.w - 1) + HALO - x
        }
    }

    /// Stores `src`, the frame row padded row `r` reflects (the caller reads it), as padded
    /// row `r` of `ring`, reflected at the frame's left and right and converting each sample
    /// with `convert`.
    #[inline(always)]
    fn read_row<T: Copy, E: Copy, F: Fn(T) -> E>(
        &self,
        src: &[T],
        r: usize,
        ring: &mut Ring<'_, E>,
        convert: F,
    ) {
        let src = &src[..self.w];
        let dst = ring.row_mut(r);
        let (even, odd) = dst.split_at_mut(self.half);
        let pairs = src.chunks_exact(2);
        if let [last] = pairs.remainder() {
            even[HALO / 2 + self.w / 2] = convert(*last);
        }
        let halves = even[HALO / 2..].iter_mut().zip(&mut odd[HALO / 2..]);
        for ((e, o), pair) in halves.zip(pairs) {
            *e = convert(pair[0]);
            *o = convert(pair[1]);
        }
        for x in (0..HALO).chain(HALO + self.w..self.pw) {
            let v = convert(src[self.halo_source(x)]);
            let half = if x % 2 == 0 { &mut *even } else { &mut *odd };
            half[x / 2] = v;
        }
    }

    /// [`Frame::read_row`] for a row given as its even and odd columns.
    #[inline(always)]
    fn read_split<T: Copy, E: Copy, F: Fn(T) -> E>(
        &self,
        even: &[T],
        odd: &[T],
        r: usize,
        ring: &mut Ring<'_, E>,
        convert: F,
    ) {
        let (even, odd) = (&even[..self.w.div_ceil(2)], &odd[..self.w / 2]);
        let dst = ring.row_mut(r);
        let (dst_even, dst_odd) = dst.split_at_mut(self.half);
        for (d, s) in dst_even[HALO / 2..].iter_mut().zip(even) {
            *d = convert(*s);
        }
        for (d, s) in dst_odd[HALO / 2..].iter_mut().zip(odd) {
            *d = convert(*s);
        }
        for x in (0..HALO).chain(HALO + self.w..self.pw) {
            // HALO is even, so padded column x has the parity of frame column c.
            let c = self.halo_source(x);
            let v = convert(if c.is_multiple_of(2) {
                even[c / 2]
            } else {
                odd[c / 2]
            });
            let half = if x % 2 == 0 {
                &mut *dst_even
            } else {
                &mut *dst_odd
            };
            half[x / 2] = v;
        }
    }

    /// Writes output row `r` into `out` as three planes (see [`OutputRow::Planes`]),
    /// converting each value with `convert`: the known values from their rows (see
    /// [`Known`]), red and blue at the green sites from stage 6's output rows.
    /// Read where they are, not first copied into the output rows as [`Frame::fill_known`]
    /// does for the interleaved output: those copies took 1.4 % of the fixed pipeline's time.
    #[inline(always)]
    fn write_planes<T: Copy, E: Copy, F: Fn(E) -> T>(
        &self,
        r: usize,
        p: &Planes<'_, E>,
        out: &mut [T],
        convert: F,
    ) {
        let known = self.known(r, [&p.mosaic, &p.green, &p.opposite]);
        let even = self.w.div_ceil(2);
        for (c, plane) in out.chunks_exact_mut(self.w).take(3).enumerate() {
            let (to_even, to_odd) = plane.split_at_mut(even);
            for (parity, to) in [(0, to_even), (1, to_odd)] {
                let from = match known.row(c, parity) {
                    Some(row) => row,
                    None => p.out_rgb[c],
                };
                let start = parity * self.half + HALO / 2;
                if let Some(from) = from.get(start..start + to.len()) {
                    for (d, s) in to.iter_mut().zip(from) {
                        *d = convert(*s);
                    }
                }
            }
        }
    }

    /// Writes the frame's part of the split rows `rgb` into `out`, interleaved, two pixels
    /// (an even and an odd column) at a time, converting each value with `convert`.
    #[inline(always)]
    fn write_row<T: Sample, E: Copy, F: Fn(E) -> T>(
        &self,
        rgb: [&[E]; 3],
        out: &mut [T],
        convert: F,
    ) {
        let start = HALO / 2;
        let at =
            |plane: &[E], parity: usize, k: usize| convert(plane[parity * self.half + start + k]);
        let mut pairs = out.chunks_exact_mut(6);
        for (k, o) in (&mut pairs).enumerate() {
            for c in 0..3 {
                o[c] = at(rgb[c], 0, k);
                o[3 + c] = at(rgb[c], 1, k);
            }
        }
        if let [r_last, g_last, b_last] = pairs.into_remainder() {
            let k = self.w / 2;
            *r_last = at(rgb[0], 0, k);
            *g_last = at(rgb[1], 0, k);
            *b_last = at(rgb[2], 0, k);
        }
    }

    #[inline(always)]
    fn diff_row(&self, r: usize, p: &mut Planes<'_, f32>) {
        let m: [&[f32]; 5] = p.mosaic.rows(r);
        let gp = self.green_parity(r);
        for parity in 0..2 {
            let span = Span::new(self, parity, 2);
            // G - C: the sample minus the estimate at green, the estimate minus it elsewhere.
            let sign = if parity == gp { 1.0 } else { -1.0 };
            let c: [&[f32]; 5] = span.taps(m[2]);
            let dh = span.out(p.diff_h.row_mut(r));
            for i in 0..dh.len() {
                let along = 0.5 * (c[1][i] + c[3][i]) + 0.25 * (2.0 * c[2][i] - c[0][i] - c[4][i]);
                dh[i] = sign * (c[2][i] - along);
            }
            let v = span.column(m);
            let dv = span.out(p.diff_v.row_mut(r));
            for i in 0..dv.len() {
                let along = 0.5 * (v[1][i] + v[3][i]) + 0.25 * (2.0 * v[2][i] - v[0][i] - v[4][i]);
                dv[i] = sign * (v[2][i] - along);
            }
        }
    }

    /// The gradients of the colour differences along their own direction (`|d(-1) - d(+1)|`),
    /// summed over three samples across it (both methods). Each gradient is formed where it
    /// is summed, three times over, rather than stored in planes of its own and read back:
    /// the same values in the same order, with two ring buffers and a pass fewer.
    #[inline(always)]
    fn sum3_row<E: Level>(&self, r: usize, p: &mut Planes<'_, E>) {
        let [up, _, down]: [&[E]; 3] = p.diff_v.rows(r);
        let dh: [&[E]; 3] = p.diff_h.rows(r);
        for parity in 0..2 {
            let span = Span::new(self, parity, 4);
            let [up, down]: [[&[E]; 3]; 2] = [span.taps(up), span.taps(down)];
            sum3_distances(up, down, span.out(p.sum3_v.row_mut(r)));
            let [left, right]: [[&[E]; 3]; 2] = [
                dh.map(|row| span.tap(row, -1)),
                dh.map(|row| span.tap(row, 1)),
            ];
            sum3_distances(left, right, span.out(p.sum3_h.row_mut(r)));
        }
    }

    #[inline(always)]
    // Indexed, not `iter_mut().enumerate()`: measured 3 % faster overall (143 against 138
    // Mpix/s).
    #[allow(clippy::needless_range_loop)]
    fn class_row(&self, r: usize, p: &mut Planes<'_, f32>) {
        let t = self.class_taps(r, &p.mosaic);
        let hv = t.green.out(p.class.row_mut(r));
        for i in 0..hv.len() {
            let vertical = line_stat(at(&t.vertical, i));
            let horizontal = line_stat(at(&t.horizontal, i));
            hv[i] = vertical / (vertical + horizontal);
        }
        let pq = t.other.out(p.class.row_mut(r));
        for i in 0..pq.len() {
            let along_p = line_stat(at(&t.along_p, i));
            let along_q = line_stat(at(&t.along_q, i));
            pq[i] = along_p / (along_p + along_q);
        }
    }

    #[inline(always)]
    fn green_row(&self, r: usize, p: &mut Planes<'_, f32>) {
        self.keep_green(r, &p.mosaic, &mut p.green);
        let t = self.green_taps(r, &p.mosaic, [&p.diff_v, &p.diff_h], [&p.sum3_v, &p.sum3_h]);
        let out = t.span.out(p.green.row_mut(r));
        let (col, c, dv, dh, s3v, s3h) = (t.column, t.row, t.diff_v, t.diff_h, t.sum3_v, t.sum3_h);
        for i in 0..out.len() {
            let sn = s3v[2][i] + s3v[1][i] + s3v[0][i];
            let ss = s3v[2][i] + s3v[3][i] + s3v[4][i];
            let sw = s3h[2][i] + s3h[1][i] + s3h[0][i];
            let se = s3h[2][i] + s3h[3][i] + s3h[4][i];
            let box_v = sn + ss - s3v[2][i];
            let box_h = sw + se - s3h[2][i];
            let inverse_square = |s: f32| {
                let s = s + SUM_FLOOR;
                1.0 / (s * s)
            };
            let (sv, sh) = (box_v + SUM_FLOOR, box_h + SUM_FLOOR);
            let class = sv * sv / (sv * sv + sh * sh);
            let (wn, ws, ww, we) = (
                inverse_square(sn),
                inverse_square(ss),
                inverse_square(sw),
                inverse_square(se),
            );
            let mut dn = 0.0;
            let mut ds = 0.0;
            let mut dw = 0.0;
            let mut de = 0.0;
            for (k, f) in SMOOTH.iter().enumerate() {
                dn += f * dv[3 - k][i];
                ds += f * dv[3 + k][i];
                dw += f * dh[3 - k][i];
                de += f * dh[3 + k][i];
            }
            let g_diff = c[3][i] + (wn * dn + ws * ds + ww * dw + we * de) / (wn + ws + ww + we);
            // |a - b| = |b - a| exactly: the across terms are shared by both sides.
            let (across_v, across_h) = ((col[4][i] - col[2][i]).abs(), (c[4][i] - c[2][i]).abs());
            let gn = EPS + across_v + (col[3][i] - col[1][i]).abs() + (col[2][i] - col[0][i]).abs();
            let gs = EPS + across_v + (col[3][i] - col[5][i]).abs() + (col[4][i] - col[6][i]).abs();
            let gw = EPS + across_h + (c[3][i] - c[1][i]).abs() + (c[2][i] - c[0][i]).abs();
            let ge = EPS + across_h + (c[3][i] - c[5][i]).abs() + (c[4][i] - c[6][i]).abs();
            let vertical = (gs * col[2][i] + gn * col[4][i]) / (gn + gs);
            let horizontal = (ge * c[2][i] + gw * c[4][i]) / (gw + ge);
            let g_plain = class * horizontal + (1.0 - class) * vertical;
            let diff_mean = min(min(sn, ss), min(sw, se)) * (1.0 / 9.0);
            let raw_mean = min(min(gn, gs), min(gw, ge)) * (1.0 / 3.0);
            let a = 0.6 + 0.35 * raw_mean / (raw_mean + 2.0 * diff_mean + 1e-9);
            out[i] = clamp01(a * g_diff + (1.0 - a) * g_plain);
        }
    }

    #[inline(always)]
    // Indexed, not `iter_mut().enumerate()`: measured 3 % faster overall (143 against 138
    // Mpix/s).
    #[allow(clippy::needless_range_loop)]
    fn chroma_row(&self, r: usize, p: &mut Planes<'_, f32>) {
        let t = self.chroma_taps(r, &p.mosaic, &p.green, &p.class);
        let out = t.span.out(p.opposite.row_mut(r));
        for i in 0..out.len() {
            let est_p = pair_estimate(at(&t.chroma_p, i), at(&t.green_p, i));
            let est_q = pair_estimate(at(&t.chroma_q, i), at(&t.green_q, i));
            let c = refined(t.class[i], at(&t.class_around, i));
            out[i] = clamp01(t.green_p[2][i] + (1.0 - c) * est_p + c * est_q);
        }
    }

    #[inline(always)]
    fn output_row<T: Sample>(&self, r: usize, p: &mut Planes<'_, f32>, out: &mut [T]) {
        self.fill_known(r, p);
        self.output_estimates(r, p);
        let [red, green, blue] = &p.out_rgb;
        // The same loop as `write_row`, written out: called through `write_row` this loop
        // measured 10 % slower overall (140 -> 130 Mpix/s), for no reason visible in the source.
        let start = HALO / 2;
        let at = |plane: &[f32], parity: usize, k: usize| {
            T::from_unit(plane[parity * self.half + start + k])
        };
        let planes = [&**red, &**green, &**blue];
        let mut pairs = out.chunks_exact_mut(6);
        for (k, o) in (&mut pairs).enumerate() {
            for c in 0..3 {
                o[c] = at(planes[c], 0, k);
                o[3 + c] = at(planes[c], 1, k);
            }
        }
        if let [r_last, g_last, b_last] = pairs.into_remainder() {
            let k = self.w / 2;
            *r_last = at(planes[0], 0, k);
            *g_last = at(planes[1], 0, k);
            *b_last = at(planes[2], 0, k);
        }
    }

    /// Stage 6: red and blue at row `r`'s green pixels, into the output rows (their
    /// green-site halves; [`Frame::fill_known`] or [`Frame::write_planes`] adds the rest).
    #[inline(always)]
    fn output_estimates(&self, r: usize, p: &mut Planes<'_, f32>) {
        let t = self.green_site_taps(r, &p.mosaic, &p.opposite, &p.green, &p.class);
        let [red, _, blue] = &mut p.out_rgb;
        let (red_g, blue_g) = (t.span.out(red), t.span.out(blue));
        for i in 0..red_g.len() {
            let c = refined(t.class[i], at(&t.class_around, i));
            let (gv, gh) = (at(&t.green_v, i), at(&t.green_h, i));
            let vertical = pair_estimate(at(&t.red_v, i), gv);
            let horizontal = pair_estimate(at(&t.red_h, i), gh);
            red_g[i] = clamp01(gv[2] + (1.0 - c) * vertical + c * horizontal);
            let vertical = pair_estimate(at(&t.blue_v, i), gv);
            let horizontal = pair_estimate(at(&t.blue_h, i), gh);
            blue_g[i] = clamp01(gv[2] + (1.0 - c) * vertical + c * horizontal);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{geometry, reflect, HALO};
    use crate::CfaPattern;

    /// The halo's columns written out are `reflect`'s, at every halo column of every width
    /// from the narrowest the method streams to well past the halo.
    #[test]
    fn halo_source_is_reflect_101() {
        for w in 2..64 {
            let frame = geometry(w, 2, CfaPattern::Rggb, usize::MAX).unwrap();
            for x in (0..HALO).chain(HALO + w..frame.pw) {
                let expected = reflect(x as isize - HALO as isize, w);
                assert_eq!(frame.halo_source(x), expected, "width {w}, column {x}");
            }
        }
    }
}

//! Checked views over caller memory: Bayer mosaics, raw frames with their levels, and RGB
//! outputs. Constructors reject every inconsistent size or value; after that, processing
//! cannot index out of bounds.

use crate::{CfaPattern, IspError};

/// A pixel sample type the demosaicing kernels and views work on: `u8`, `u16` or `f32`.
///
/// Integer samples use their whole range; `f32` samples are linear values in `[0, 1]`. Kernels
/// accumulate weighted sums in [`Sample::Acc`] and finish with [`Sample::scaled_down`], so one
/// kernel gives the integer path (rounded half up, saturating) and the float path (exact,
/// clamped to `[0, 1]`, NaN to 0).
pub trait Sample: Copy + Default + PartialEq + core::fmt::Debug + 'static {
    /// Accumulator of weighted sums: `i32` for integers, `f32` for `f32`.
    type Acc: Copy + Default + core::ops::Add<Output = Self::Acc>;
    /// `k * self` in the accumulator.
    fn weighted(self, k: i32) -> Self::Acc;
    /// `acc / 2^shift`: for integers rounded half up; clamped to the sample's range.
    fn scaled_down(acc: Self::Acc, shift: u32) -> Self;
    /// The mean of `n >= 1` samples whose sum is `acc`, rounded half up for integers.
    fn mean(acc: Self::Acc, n: u32) -> Self;
    /// The sample as a fraction of full scale, in `[0, 1]` (for float kernels on any sample).
    fn to_unit(self) -> f32;
    /// From a fraction of full scale: for integers rounded half up; clamped to the sample's
    /// range, NaN to 0.
    fn from_unit(v: f32) -> Self;
}

/// An integer sample: `u8` or `u16`.
pub trait IntSample: Sample {
    /// Largest value.
    const MAX: u32;
    /// Widened to `u32`.
    fn to_u32(self) -> u32;
    /// From a `u32`, saturating at [`IntSample::MAX`].
    fn from_u32(x: u32) -> Self;
}

/// `y` rounded down and clamped to `[0, max]` (`max` an integer below 2^22), NaN to 0: what
/// `y as u16` gives for `max = 65535` (`as u8` for 255), in operations that vectorise.
/// Rust's saturating `as` from `f32` does not: in the float directional method's output loop
/// LLVM left it as a scalar conversion, two clamps and an insert per sample, and the AVX2
/// build ran at 108-109 Mpix/s on Kodak and McMaster at 16 bits against 138-140 with this.
#[inline(always)]
fn floor_saturated(y: f32, max: f32) -> u32 {
    let y = if y > 0.0 { y } else { 0.0 };
    let y = if y < max { y } else { max };
    // The nearest integer, one less where that rounded up (both exact in `f32` here).
    let nearest = crate::math::nearest(y);
    (nearest - i32::from(nearest as f32 > y)) as u32
}

macro_rules! int_sample {
    ($t:ty) => {
        impl Sample for $t {
            type Acc = i32;
            #[inline]
            fn weighted(self, k: i32) -> i32 {
                k * self as i32
            }
            #[inline]
            fn scaled_down(acc: i32, shift: u32) -> Self {
                let half = (1i32 << shift) >> 1;
                ((acc + half) >> shift).clamp(0, <$t>::MAX as i32) as $t
            }
            #[inline]
            fn mean(acc: i32, n: u32) -> Self {
                let n = n.max(1) as i32;
                ((acc.max(0) + n / 2) / n).min(<$t>::MAX as i32) as $t
            }
            #[inline]
            fn to_unit(self) -> f32 {
                self as f32 * (1.0 / <$t>::MAX as f32)
            }
            #[inline]
            fn from_unit(v: f32) -> Self {
                floor_saturated(v * <$t>::MAX as f32 + 0.5, <$t>::MAX as f32) as $t
            }
        }

        impl IntSample for $t {
            const MAX: u32 = <$t>::MAX as u32;
            #[inline]
            fn to_u32(self) -> u32 {
                self as u32
            }
            #[inline]
            fn from_u32(x: u32) -> Self {
                x.min(<Self as IntSample>::MAX) as $t
            }
        }
    };
}

int_sample!(u8);
int_sample!(u16);

impl Sample for f32 {
    type Acc = f32;
    #[inline]
    fn weighted(self, k: i32) -> f32 {
        k as f32 * self
    }
    #[inline]
    fn scaled_down(acc: f32, shift: u32) -> f32 {
        // 2^-shift is exact.
        clamp01(acc * (1.0 / (1u32 << shift.min(31)) as f32))
    }
    #[inline]
    fn mean(acc: f32, n: u32) -> f32 {
        clamp01(acc / n.max(1) as f32)
    }
    #[inline]
    fn to_unit(self) -> f32 {
        clamp01(self)
    }
    #[inline]
    fn from_unit(v: f32) -> f32 {
        clamp01(v)
    }
}

/// `x` clamped to `[0, 1]`, NaN to 0.
#[inline]
fn clamp01(x: f32) -> f32 {
    if x > 0.0 {
        x.min(1.0)
    } else {
        0.0
    }
}

/// Checks that `len` elements hold `rows` rows of `row_len` elements, `stride` apart.
fn check_plane(
    len: usize,
    row_len: usize,
    rows: usize,
    stride: usize,
    name: &'static str,
) -> Result<(), IspError> {
    let needed = required_len(row_len, rows, stride, name)?;
    if len < needed {
        return Err(IspError::BufferTooSmall {
            needed,
            provided: len,
        });
    }
    Ok(())
}

/// Checks a frame's levels: bit depth 8..=16, each white level within it, and each black level
/// below the white level beside it.
fn check_levels(bit_depth: u8, black: &[u16], white: &[u16]) -> Result<(), IspError> {
    if !(8..=16).contains(&bit_depth) {
        return Err(IspError::InvalidParameter {
            name: "bit_depth",
            allowed: "8..=16",
        });
    }
    let max = ((1u32 << bit_depth) - 1) as u16;
    if white.iter().any(|w| *w == 0 || *w > max) {
        return Err(IspError::InvalidParameter {
            name: "white_level",
            allowed: "1..=2^bit_depth - 1",
        });
    }
    if black.iter().zip(white).any(|(b, w)| b >= w) {
        return Err(IspError::InvalidParameter {
            name: "black_level",
            allowed: "< white_level",
        });
    }
    Ok(())
}

/// Checks that `len` samples hold an interleaved RGB image of `width` x `height` at `stride`.
fn check_rgb_plane(len: usize, width: usize, height: usize, stride: usize) -> Result<(), IspError> {
    let row_len = width.checked_mul(3).ok_or(IspError::InvalidParameter {
        name: "rgb",
        allowed: "a size that fits in memory",
    })?;
    check_plane(len, row_len, height, stride, "rgb")
}

/// Elements a plane of `rows` rows of `row_len` elements at `stride` needs, or an error.
fn required_len(
    row_len: usize,
    rows: usize,
    stride: usize,
    name: &'static str,
) -> Result<usize, IspError> {
    if row_len == 0 || rows == 0 {
        return Err(IspError::InvalidParameter {
            name,
            allowed: "width and height >= 1",
        });
    }
    if stride < row_len {
        return Err(IspError::InvalidParameter {
            name,
            allowed: "stride >= the row length",
        });
    }
    (rows - 1)
        .checked_mul(stride)
        .and_then(|n| n.checked_add(row_len))
        .ok_or(IspError::InvalidParameter {
            name,
            allowed: "a size that fits in memory",
        })
}

/// A Bayer mosaic: one sample per pixel, `stride` samples from one row to the next.
#[derive(Debug, Clone, Copy)]
pub struct MosaicView<'a, T> {
    data: &'a [T],
    width: usize,
    height: usize,
    stride: usize,
    pattern: CfaPattern,
}

impl<'a, T: Sample> MosaicView<'a, T> {
    /// A checked view; `data` must hold `(height - 1) * stride + width` samples.
    pub fn new(
        data: &'a [T],
        width: usize,
        height: usize,
        stride: usize,
        pattern: CfaPattern,
    ) -> Result<Self, IspError> {
        check_plane(data.len(), width, height, stride, "mosaic")?;
        Ok(Self {
            data,
            width,
            height,
            stride,
            pattern,
        })
    }

    /// Width in pixels.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> usize {
        self.height
    }

    /// Samples from one row to the next.
    pub fn stride(&self) -> usize {
        self.stride
    }

    /// The CFA pattern.
    pub fn pattern(&self) -> CfaPattern {
        self.pattern
    }

    /// Row `y` (exactly `width` samples); `y` must be < height.
    #[inline]
    pub(crate) fn row(&self, y: usize) -> &'a [T] {
        &self.data[y * self.stride..y * self.stride + self.width]
    }

    /// The sample at `(x, y)`, or `None` outside the frame.
    pub fn get(&self, x: usize, y: usize) -> Option<T> {
        (x < self.width && y < self.height).then(|| self.data[y * self.stride + x])
    }
}

/// A raw sensor frame: a `u16` mosaic holding `bit_depth`-bit samples, with the black level of
/// each position of the 2x2 CFA block (row by row) and the white level.
#[derive(Debug, Clone, Copy)]
pub struct RawFrame<'a> {
    mosaic: MosaicView<'a, u16>,
    bit_depth: u8,
    black_level: [u16; 4],
    white_level: u16,
}

impl<'a> RawFrame<'a> {
    /// A checked raw frame: bit depth 8..=16, white level within the bit depth, and every black
    /// level below the white level.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        data: &'a [u16],
        width: usize,
        height: usize,
        stride: usize,
        bit_depth: u8,
        pattern: CfaPattern,
        black_level: [u16; 4],
        white_level: u16,
    ) -> Result<Self, IspError> {
        check_levels(bit_depth, &black_level, &[white_level; 4])?;
        let mosaic = MosaicView::new(data, width, height, stride, pattern)?;
        Ok(Self {
            mosaic,
            bit_depth,
            black_level,
            white_level,
        })
    }

    /// The mosaic.
    pub fn mosaic(&self) -> &MosaicView<'a, u16> {
        &self.mosaic
    }

    /// Bits per sample.
    pub fn bit_depth(&self) -> u8 {
        self.bit_depth
    }

    /// Black level of each 2x2 block position, row by row.
    pub fn black_level(&self) -> [u16; 4] {
        self.black_level
    }

    /// Black level at pixel `(x, y)`.
    pub fn black_at(&self, x: usize, y: usize) -> u16 {
        self.black_level[(y & 1) * 2 + (x & 1)]
    }

    /// White level.
    pub fn white_level(&self) -> u16 {
        self.white_level
    }
}

/// A linear raw frame that is already demosaiced (a DNG's LinearRaw): three `u16` samples per
/// pixel, R, G, B, holding `bit_depth`-bit data, with each channel's black and white level.
/// The pipeline runs it as it runs a [`RawFrame`], without defect correction and demosaicing.
///
/// ```
/// use isp_core::frame::LinearFrame;
/// let data = [100u16, 200, 300, 4000, 4000, 4000];
/// let frame = LinearFrame::new(&data, 2, 1, 6, 12, [64; 3], [4095; 3]).unwrap();
/// assert_eq!(frame.pixel(1, 0), Some([4000; 3]));
/// assert!(LinearFrame::new(&data, 2, 1, 6, 12, [64; 3], [5000; 3]).is_err());
/// ```
#[derive(Debug, Clone, Copy)]
pub struct LinearFrame<'a> {
    data: &'a [u16],
    width: usize,
    height: usize,
    stride: usize,
    bit_depth: u8,
    black_level: [u16; 3],
    white_level: [u16; 3],
}

impl<'a> LinearFrame<'a> {
    /// A checked frame: `data` holds `(height - 1) * stride + 3 * width` samples, bit depth
    /// 8..=16, each white level within the bit depth and above its channel's black level.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        data: &'a [u16],
        width: usize,
        height: usize,
        stride: usize,
        bit_depth: u8,
        black_level: [u16; 3],
        white_level: [u16; 3],
    ) -> Result<Self, IspError> {
        check_levels(bit_depth, &black_level, &white_level)?;
        check_rgb_plane(data.len(), width, height, stride)?;
        Ok(Self {
            data,
            width,
            height,
            stride,
            bit_depth,
            black_level,
            white_level,
        })
    }

    /// Width in pixels.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> usize {
        self.height
    }

    /// Bits per sample.
    pub fn bit_depth(&self) -> u8 {
        self.bit_depth
    }

    /// Black level of R, G and B.
    pub fn black_level(&self) -> [u16; 3] {
        self.black_level
    }

    /// White level of R, G and B.
    pub fn white_level(&self) -> [u16; 3] {
        self.white_level
    }

    /// Row `y` (exactly `3 * width` samples); `y` must be < height.
    #[inline]
    pub(crate) fn row(&self, y: usize) -> &'a [u16] {
        &self.data[y * self.stride..y * self.stride + 3 * self.width]
    }

    /// The pixel at `(x, y)`, or `None` outside the frame.
    pub fn pixel(&self, x: usize, y: usize) -> Option<[u16; 3]> {
        (x < self.width && y < self.height).then(|| {
            let i = y * self.stride + 3 * x;
            [self.data[i], self.data[i + 1], self.data[i + 2]]
        })
    }
}

/// An interleaved RGB output: three samples per pixel, `stride` samples from one row to the
/// next (at least `3 * width`).
#[derive(Debug)]
pub struct RgbViewMut<'a, T> {
    data: &'a mut [T],
    width: usize,
    height: usize,
    stride: usize,
}

impl<'a, T: Copy> RgbViewMut<'a, T> {
    /// A checked view; `data` must hold `(height - 1) * stride + 3 * width` samples.
    pub fn new(
        data: &'a mut [T],
        width: usize,
        height: usize,
        stride: usize,
    ) -> Result<Self, IspError> {
        check_rgb_plane(data.len(), width, height, stride)?;
        Ok(Self {
            data,
            width,
            height,
            stride,
        })
    }

    /// Width in pixels.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> usize {
        self.height
    }

    /// Row `y` (exactly `3 * width` samples).
    #[inline]
    pub(crate) fn row_mut(&mut self, y: usize) -> &mut [T] {
        &mut self.data[y * self.stride..y * self.stride + 3 * self.width]
    }

    /// Copies row `from` over row `to`.
    pub(crate) fn copy_row(&mut self, from: usize, to: usize) {
        let n = 3 * self.width;
        self.data
            .copy_within(from * self.stride..from * self.stride + n, to * self.stride);
    }

    /// Pixel `(x, y)` as `[r, g, b]`, or `None` outside.
    pub fn get(&self, x: usize, y: usize) -> Option<[T; 3]> {
        (x < self.width && y < self.height).then(|| {
            let i = y * self.stride + 3 * x;
            [self.data[i], self.data[i + 1], self.data[i + 2]]
        })
    }
}

/// A read-only interleaved RGB image: three samples per pixel, `stride` samples from one row
/// to the next (at least `3 * width`).
#[derive(Debug, Clone, Copy)]
pub struct RgbView<'a, T> {
    data: &'a [T],
    width: usize,
    height: usize,
    stride: usize,
}

impl<'a, T: Copy> RgbView<'a, T> {
    /// A checked view; `data` must hold `(height - 1) * stride + 3 * width` samples.
    pub fn new(
        data: &'a [T],
        width: usize,
        height: usize,
        stride: usize,
    ) -> Result<Self, IspError> {
        check_rgb_plane(data.len(), width, height, stride)?;
        Ok(Self {
            data,
            width,
            height,
            stride,
        })
    }

    /// Width in pixels.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> usize {
        self.height
    }

    /// Row `y` (exactly `3 * width` samples), or `None` below the image.
    #[inline]
    pub fn row(&self, y: usize) -> Option<&'a [T]> {
        if y >= self.height {
            return None;
        }
        let start = y * self.stride;
        self.data.get(start..start + 3 * self.width)
    }

    /// Pixel `(x, y)` as `[r, g, b]`, or `None` outside.
    pub fn get(&self, x: usize, y: usize) -> Option<[T; 3]> {
        (x < self.width && y < self.height).then(|| {
            let i = y * self.stride + 3 * x;
            [self.data[i], self.data[i + 1], self.data[i + 2]]
        })
    }
}

#[cfg(test)]
mod tests {
    use super::Sample;

    /// `from_unit` is Rust's saturating `(v * MAX + 0.5) as T`: next to every code's
    /// boundary (a few `f32` steps either side), on a stride through every `f32` in
    /// `[-1, 2]`, and at the special values.
    #[test]
    fn from_unit_is_the_saturating_cast() {
        fn check(v: f32) {
            assert_eq!(u8::from_unit(v), (v * 255.0 + 0.5) as u8, "{v:e}");
            assert_eq!(u16::from_unit(v), (v * 65535.0 + 0.5) as u16, "{v:e}");
        }
        let specials = [
            f32::NAN,
            -f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::MAX,
            f32::MIN,
            f32::MIN_POSITIVE,
            0.0,
            -0.0,
            1.0,
        ];
        specials.into_iter().for_each(check);
        for max in [255.0f32, 65535.0] {
            for k in 0..=max as u32 + 1 {
                let boundary = (k as f32 - 0.5) / max;
                let mut v = boundary;
                for _ in 0..4 {
                    v = v.next_down();
                }
                for _ in 0..9 {
                    check(v);
                    v = v.next_up();
                }
            }
        }
        let (low, high) = ((-1.0f32).to_bits(), 2.0f32.to_bits());
        // Negative values' bits run from -0 up to -1, positive ones from 0 up to 2.
        for bits in (0x8000_0000..=low)
            .step_by(101)
            .chain((0..=high).step_by(97))
        {
            check(f32::from_bits(bits));
        }
    }
}

//! Lateral chromatic aberration correction: the red and blue planes rescaled radially about
//! the optical centre, so each lands where the green plane's image of the same point is, as
//! camera ISPs do it (a lens images red and blue at slightly different magnifications).
//!
//! # Semantics
//!
//! For output pixel `(u, v)` and colour `c` in {red, blue}, in integers (so the float and the
//! fixed path read from the same positions, bit for bit):
//!
//! ```text
//! d     = 32 (u, v) - q0                  offset from the centre q0 = rint(32 centre), 1/32 px
//! t     = |d|^2 (NODES - 1) / (32 r_max)^2   the node coordinate (nodes uniform in r^2), Q12
//! s_c   = scale_c[k] + (scale_c[k+1] - scale_c[k]) frac(t)   Q20, k = floor(t); the last
//!                                         node's scale from r_max on
//! q     = q0 + round(d s_c / 2^20)        the source position in 1/32 pixel
//! ```
//!
//! and the output is the bilinear blend of the four pixels around `q` with integer weights
//! over 1024, as [`crate::distortion`] resamples (rounded half up for `u8` and `u16`, exact
//! for `f32`), except that a tap beyond the frame reads the nearest edge pixel (the corners'
//! red and blue come from just outside the image when their scale is above 1). Green is
//! copied. A scale of 1 at every node leaves a plane exactly as it was.
//!
//! `scale_c(r)` is the factor by which colour `c`'s image is larger than green's at image
//! radius `r`: optics-core derives it from a prescription
//! (`Prescription::lateral_colour_scale`), sampled at [`LateralColour::node_radius`].
//!
//! ```
//! use isp_core::lateral_colour::{LateralColour, NODES};
//! use isp_core::frame::{RgbView, RgbViewMut};
//! // Red 0.2 % larger than green everywhere, blue as green.
//! let lca = LateralColour::new(64, 48, [31.5, 23.5], None, &[1.002; NODES], &[1.0; NODES]).unwrap();
//! let src = vec![100u16; 64 * 48 * 3];
//! let mut dst = vec![0u16; 64 * 48 * 3];
//! lca.correct(&RgbView::new(&src, 64, 48, 192).unwrap(), &mut RgbViewMut::new(&mut dst, 64, 48, 192).unwrap()).unwrap();
//! // A flat field stays flat.
//! assert!(dst.iter().all(|&v| v == 100));
//! ```

use crate::frame::{RgbView, RgbViewMut, Sample};
use crate::IspError;

/// Nodes of each colour's scale curve, uniform in `r^2` from the centre to `r_max`.
pub const NODES: usize = 17;
/// Fractional bits of a scale: Q20.
pub const SCALE_BITS: u32 = 20;
const SUBPIXEL_BITS: u32 = 5;
const SUBPIXELS: i64 = 1 << SUBPIXEL_BITS;
const WEIGHT_BITS: u32 = 2 * SUBPIXEL_BITS;
/// Largest frame side: positions in 1/32 pixel and their squares stay within `i64`.
pub const MAX_SIDE: usize = 1 << 16;
/// The scales accepted: a lens's colours differ in size by far less.
pub const SCALE_RANGE: [f64; 2] = [0.9, 1.1];

/// A lateral-colour correction for one frame size.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LateralColour {
    width: usize,
    height: usize,
    /// The centre, 1/32 pixel.
    centre: [i64; 2],
    /// `(32 r_max)^2`.
    r2_max: i64,
    /// Red's and blue's scales, Q20.
    scales: [[i64; NODES]; 2],
    identity: bool,
}

impl LateralColour {
    /// A correction for `width x height` frames about `centre` (pixels, `(0, 0)` the top-left
    /// pixel's centre), nodes out to `r_max` pixels (`None`: the furthest corner, at least 1
    /// pixel away), with red's
    /// and blue's scale at each node. Errors for an empty or too large frame, a centre or
    /// radius that is not finite, or scales outside [`SCALE_RANGE`].
    pub fn new(
        width: usize,
        height: usize,
        centre: [f64; 2],
        r_max: Option<f64>,
        red: &[f64; NODES],
        blue: &[f64; NODES],
    ) -> Result<Self, IspError> {
        if !(1..=MAX_SIDE).contains(&width) || !(1..=MAX_SIDE).contains(&height) {
            return Err(IspError::InvalidParameter {
                name: "lateral colour frame size",
                allowed: "1..=65536 each way",
            });
        }
        let side = MAX_SIDE as f64;
        if !centre.iter().all(|c| c.is_finite() && c.abs() <= side) {
            return Err(IspError::InvalidParameter {
                name: "lateral colour centre",
                allowed: "finite, within 65536 pixels",
            });
        }
        let corner = {
            let dx = centre[0].abs().max((width as f64 - 1.0 - centre[0]).abs());
            let dy = centre[1].abs().max((height as f64 - 1.0 - centre[1]).abs());
            libm::hypot(dx, dy)
        };
        // A frame of one or two pixels has its corner within a pixel of the centre.
        let r_max = r_max.unwrap_or(corner.max(1.0));
        if !(1.0..=2.0 * side).contains(&r_max) {
            return Err(IspError::InvalidParameter {
                name: "lateral colour r_max",
                allowed: "1 to 131072 pixels",
            });
        }
        let mut scales = [[0i64; NODES]; 2];
        for (out, given) in scales.iter_mut().zip([red, blue]) {
            for (o, &s) in out.iter_mut().zip(given) {
                if !(SCALE_RANGE[0]..=SCALE_RANGE[1]).contains(&s) {
                    return Err(IspError::InvalidParameter {
                        name: "lateral colour scale",
                        allowed: "0.9 to 1.1",
                    });
                }
                *o = libm::round(s * f64::from(1u32 << SCALE_BITS)) as i64;
            }
        }
        let q = |v: f64| libm::rint(v * SUBPIXELS as f64) as i64;
        let r32 = r_max * SUBPIXELS as f64;
        Ok(Self {
            width,
            height,
            centre: [q(centre[0]), q(centre[1])],
            r2_max: (r32 * r32) as i64,
            identity: scales.iter().flatten().all(|&s| s == 1 << SCALE_BITS),
            scales,
        })
    }

    /// [`LateralColour::new`] with the scales read off a curve: `curve(radius)` gives red's and
    /// blue's scale at an image radius in pixels (each node's, [`LateralColour::node_radius`]),
    /// or `None` beyond the field the lens passes, where the last scale found holds (1 before
    /// the first). How a prescription's `lateral_colour_scale` becomes the stage.
    pub fn from_curve(
        width: usize,
        height: usize,
        centre: [f64; 2],
        r_max: Option<f64>,
        mut curve: impl FnMut(f64) -> Option<[f64; 2]>,
    ) -> Result<Self, IspError> {
        let probe = Self::new(width, height, centre, r_max, &[1.0; NODES], &[1.0; NODES])?;
        let (mut red, mut blue) = ([1.0; NODES], [1.0; NODES]);
        let mut last = [1.0, 1.0];
        for k in 0..NODES {
            if let Some(scales) = probe.node_radius(k).and_then(&mut curve) {
                last = scales;
            }
            [red[k], blue[k]] = last;
        }
        Self::new(width, height, centre, r_max, &red, &blue)
    }

    /// The radius of node `k`, pixels: `r_max sqrt(k / (NODES - 1))` (`None` beyond the last).
    pub fn node_radius(&self, k: usize) -> Option<f64> {
        (k < NODES).then(|| {
            libm::sqrt(self.r2_max as f64 * k as f64 / (NODES - 1) as f64) / SUBPIXELS as f64
        })
    }

    /// Colour `c`'s (0 red, 1 blue) scale at node `k`, as stored (Q20); `None` for a colour
    /// or node beyond the last.
    pub fn node_scale(&self, c: usize, k: usize) -> Option<f64> {
        let q = *self.scales.get(c)?.get(k)?;
        Some(q as f64 / f64::from(1u32 << SCALE_BITS))
    }

    /// The centre, pixels (as given, rounded to 1/32 pixel).
    pub fn centre(&self) -> [f64; 2] {
        self.centre.map(|c| c as f64 / SUBPIXELS as f64)
    }

    /// Whether every scale is 1 (the stage changes nothing and a pipeline skips it).
    pub fn is_identity(&self) -> bool {
        self.identity
    }

    /// The source position of colour `c` (0 red, 1 blue) for output pixel `(u, v)`, 1/32
    /// pixel.
    pub fn source_position(&self, c: usize, u: usize, v: usize) -> [i64; 2] {
        self.map_position(c, [(u as i64) * SUBPIXELS, (v as i64) * SUBPIXELS])
    }

    /// Where colour `c` (0 red, 1 blue) is read for a pixel whose green is read at `q` (1/32
    /// pixel): `q` rescaled about the centre by the colour's scale at its radius. `q` within
    /// 2^21 pixels of the centre (a frame's positions and a lens mesh's usable ones are).
    #[inline]
    pub fn map_position(&self, c: usize, q: [i64; 2]) -> [i64; 2] {
        let d = [q[0] - self.centre[0], q[1] - self.centre[1]];
        let r2 = d[0] * d[0] + d[1] * d[1];
        let scales = &self.scales[c.min(1)];
        let s = if r2 >= self.r2_max {
            scales[NODES - 1]
        } else {
            // r2 < r2_max <= 2^44 here, so (NODES - 1) r2 2^12 stays below 2^60.
            let t = ((r2 * (NODES as i64 - 1)) << 12) / self.r2_max.max(1);
            let (k, f) = (((t >> 12) as usize).min(NODES - 2), t & 0xfff);
            scales[k] + (((scales[k + 1] - scales[k]) * f + (1 << 11)) >> 12)
        };
        let half = 1i64 << (SCALE_BITS - 1);
        [
            self.centre[0] + ((d[0] * s + half) >> SCALE_BITS),
            self.centre[1] + ((d[1] * s + half) >> SCALE_BITS),
        ]
    }

    /// The rows of input an output row needs: the tallest reach of a red or blue source
    /// position above or below its row, in whole rows, plus one for the bilinear tap.
    pub fn reach_rows(&self) -> usize {
        self.reach_rows_in(self.width, self.height)
    }

    /// [`LateralColour::reach_rows`] over a `width` x `height` frame (the correction's centre,
    /// radius and scales applied to another frame's positions, as the pipeline does when a
    /// lens's mesh moves green's position off its pixel).
    pub fn reach_rows_in(&self, width: usize, height: usize) -> usize {
        let (w, h) = (width.clamp(1, MAX_SIDE), height.clamp(1, MAX_SIDE));
        let corners = [(0, 0), (w - 1, 0), (0, h - 1), (w - 1, h - 1)];
        let mut reach = 0i64;
        for c in 0..2 {
            for &(u, v) in &corners {
                let q = self.source_position(c, u, v);
                reach = reach.max((q[1] - v as i64 * SUBPIXELS).abs());
            }
        }
        // Row reach grows with the radius, so the corners bound it; round up and add the tap.
        (reach.div_euclid(SUBPIXELS) + 2) as usize
    }

    /// Corrects a whole image: `dst` must have `src`'s size, which must be the size the
    /// correction was made for.
    pub fn correct<T: Sample>(
        &self,
        src: &RgbView<'_, T>,
        dst: &mut RgbViewMut<'_, T>,
    ) -> Result<(), IspError> {
        let (w, h) = (src.width(), src.height());
        if (w, h) != (self.width, self.height) || (dst.width(), dst.height()) != (w, h) {
            return Err(IspError::InvalidParameter {
                name: "lateral colour frame",
                allowed: "input and output of the size the correction was made for",
            });
        }
        for v in 0..h {
            let src_row = src.row(v).unwrap_or(&[]);
            let out = dst.row_mut(v);
            if self.identity {
                // Scales of 1 read every colour where it is: the row as it is.
                let n = out.len().min(src_row.len()).min(3 * w);
                out[..n].copy_from_slice(&src_row[..n]);
                continue;
            }
            for (u, px) in out.chunks_exact_mut(3).take(w).enumerate() {
                px[0] = self.sample(src, self.source_position(0, u, v), 0);
                px[1] = src_row.get(3 * u + 1).copied().unwrap_or_default();
                px[2] = self.sample(src, self.source_position(1, u, v), 2);
            }
        }
        Ok(())
    }

    /// The bilinear blend of `channel` at `q` (1/32 pixel), taps clamped to the frame.
    fn sample<T: Sample>(&self, src: &RgbView<'_, T>, q: [i64; 2], channel: usize) -> T {
        let mut acc = T::Acc::default();
        for (x, y, weight) in clamped_taps(q, self.width, self.height) {
            let sample = src
                .row(y)
                .and_then(|r| r.get(3 * x + channel))
                .copied()
                .unwrap_or_default();
            acc = acc + sample.weighted(weight);
        }
        T::scaled_down(acc, WEIGHT_BITS)
    }
}

/// The four bilinear taps of `q` (1/32 pixel) in a `width` x `height` frame (both at least
/// 1): column, row and integer weight (the four sum to 1024), a tap beyond the frame moved to
/// the nearest edge pixel.
#[inline(always)]
pub(crate) fn clamped_taps(q: [i64; 2], width: usize, height: usize) -> [(usize, usize, i32); 4] {
    let (x0, y0) = (q[0] >> SUBPIXEL_BITS, q[1] >> SUBPIXEL_BITS);
    let (ax, ay) = (q[0] & (SUBPIXELS - 1), q[1] & (SUBPIXELS - 1));
    let clamp_x = |x: i64| x.clamp(0, width as i64 - 1) as usize;
    let clamp_y = |y: i64| y.clamp(0, height as i64 - 1) as usize;
    [
        (
            clamp_x(x0),
            clamp_y(y0),
            ((SUBPIXELS - ax) * (SUBPIXELS - ay)) as i32,
        ),
        (clamp_x(x0 + 1), clamp_y(y0), (ax * (SUBPIXELS - ay)) as i32),
        (clamp_x(x0), clamp_y(y0 + 1), ((SUBPIXELS - ax) * ay) as i32),
        (clamp_x(x0 + 1), clamp_y(y0 + 1), (ax * ay) as i32),
    ]
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::vec;
    use std::vec::Vec;

    /// A smooth pattern: what the lens imaged in green.
    fn pattern(x: f64, y: f64) -> f64 {
        0.5 + 0.3 * libm::sin(x * 0.21) * libm::cos(y * 0.17)
    }

    #[test]
    fn a_red_plane_imaged_larger_is_put_back_on_green() {
        let (w, h) = (96usize, 64usize);
        let centre = [47.5, 31.5];
        let s = 1.01;
        // Red imaged 1 % larger, blue 0.5 % smaller, green as the pattern.
        let mut src = vec![0.0f32; w * h * 3];
        for v in 0..h {
            for u in 0..w {
                let at = |k: f64| {
                    let x = centre[0] + (u as f64 - centre[0]) / k;
                    let y = centre[1] + (v as f64 - centre[1]) / k;
                    pattern(x, y) as f32
                };
                let i = 3 * (v * w + u);
                src[i] = at(s);
                src[i + 1] = at(1.0);
                src[i + 2] = at(0.995);
            }
        }
        let lca = LateralColour::new(w, h, centre, None, &[s; NODES], &[0.995; NODES]).unwrap();
        assert!(!lca.is_identity());
        let mut dst = vec![0.0f32; w * h * 3];
        let view = RgbView::new(&src, w, h, 3 * w).unwrap();
        lca.correct(&view, &mut RgbViewMut::new(&mut dst, w, h, 3 * w).unwrap())
            .unwrap();
        let (mut before, mut after) = (0.0f64, 0.0f64);
        for v in 2..h - 2 {
            for u in 2..w - 2 {
                let i = 3 * (v * w + u);
                for c in [0, 2] {
                    before = before.max(f64::from((src[i + c] - src[i + 1]).abs()));
                    after = after.max(f64::from((dst[i + c] - dst[i + 1]).abs()));
                }
                assert_eq!(dst[i + 1], src[i + 1]);
            }
        }
        // The fringe was 0.027 at most; bilinear interpolation of the pattern leaves 0.003.
        assert!(before > 0.02, "{before}");
        assert!(after < 0.004, "{after}");
    }

    #[test]
    fn float_and_fixed_read_the_same_positions() {
        let (w, h) = (40usize, 30usize);
        let red: [f64; NODES] = core::array::from_fn(|k| 1.0 + 0.0004 * k as f64);
        let blue: [f64; NODES] = core::array::from_fn(|k| 1.0 - 0.0003 * k as f64);
        let lca = LateralColour::new(w, h, [19.5, 14.5], None, &red, &blue).unwrap();
        let data16: Vec<u16> = (0..w * h * 3)
            .map(|i| ((i * 7919) % 65536) as u16)
            .collect();
        let dataf: Vec<f32> = data16.iter().map(|&v| f32::from(v) / 65535.0).collect();
        let mut out16 = vec![0u16; w * h * 3];
        let mut outf = vec![0.0f32; w * h * 3];
        lca.correct(
            &RgbView::new(&data16, w, h, 3 * w).unwrap(),
            &mut RgbViewMut::new(&mut out16, w, h, 3 * w).unwrap(),
        )
        .unwrap();
        lca.correct(
            &RgbView::new(&dataf, w, h, 3 * w).unwrap(),
            &mut RgbViewMut::new(&mut outf, w, h, 3 * w).unwrap(),
        )
        .unwrap();
        // The integer path rounds the same weighted sum the float path keeps exact.
        for (a, b) in out16.iter().zip(&outf) {
            assert!((f32::from(*a) - b * 65535.0).abs() <= 0.51, "{a} {b}");
        }
        assert!(lca.reach_rows() >= 2 && lca.reach_rows() < 4);
        assert!((lca.node_radius(NODES - 1).unwrap() - 19.5f64.hypot(14.5)).abs() < 1e-9);
        assert_eq!(lca.node_radius(NODES), None);
    }

    #[test]
    fn scale_one_copies_and_bad_parameters_are_refused() {
        let ones = [1.0; NODES];
        let lca = LateralColour::new(8, 6, [3.5, 2.5], None, &ones, &ones).unwrap();
        assert!(lca.is_identity());
        let data: Vec<u8> = (0..8 * 6 * 3).map(|i| i as u8).collect();
        let mut out = vec![0u8; 8 * 6 * 3];
        lca.correct(
            &RgbView::new(&data, 8, 6, 24).unwrap(),
            &mut RgbViewMut::new(&mut out, 8, 6, 24).unwrap(),
        )
        .unwrap();
        assert_eq!(out, data);
        assert!(LateralColour::new(0, 6, [3.5, 2.5], None, &ones, &ones).is_err());
        assert!(LateralColour::new(8, 6, [f64::NAN, 2.5], None, &ones, &ones).is_err());
        assert!(LateralColour::new(8, 6, [3.5, 2.5], Some(0.0), &ones, &ones).is_err());
        let mut bad = ones;
        bad[3] = 1.5;
        assert!(LateralColour::new(8, 6, [3.5, 2.5], None, &bad, &ones).is_err());
        bad[3] = f64::NAN;
        assert!(LateralColour::new(8, 6, [3.5, 2.5], None, &ones, &bad).is_err());
        let mut small = vec![0u8; 4 * 6 * 3];
        assert!(lca
            .correct(
                &RgbView::new(&data, 8, 6, 24).unwrap(),
                &mut RgbViewMut::new(&mut small, 4, 6, 12).unwrap(),
            )
            .is_err());
    }
}

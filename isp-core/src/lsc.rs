//! Lens shading correction: a caller-provided grid of gains per CFA position, interpolated
//! bilinearly to every pixel. Corrects vignetting (all four positions) and colour shading
//! (positions differ).
//!
//! The grid has `grid_w x grid_h` nodes (each at least 2, at most [`MAX_GRID_SIDE`]) spread
//! evenly over the frame: node `i` sits on pixel column `i * (width - 1) / (grid_w - 1)`, so
//! the corner nodes sit on the corner pixels. Each node holds four gains, one per position of
//! the 2x2 CFA block read row by row (so Gr and Gb may differ), in unsigned Q4.12 (`4096` is
//! 1.0; range `[0, 16)`), the format a real ISP's shading table uses. Storage is row-major:
//! `gains[((gy * grid_w) + gx) * 4 + position]`.
//!
//! A pixel's fractional grid coordinate `t = x * (grid_w - 1) / (width - 1)` is split into a
//! node index and a remainder by exact integer division, the same in both paths; the float path
//! then interpolates exactly, the fixed path with Q16 weights.
//!
//! ```
//! use isp_core::lsc::LensShading;
//! // 2x2 grid: gain 1.0 at the top, 2.0 at the bottom.
//! let mut gains = [4096u16; 16];
//! gains[8..].fill(8192);
//! let lsc = LensShading::new(2, 2, &gains).unwrap();
//! assert_eq!(lsc.gain_f32(0, 0, 5, 5), 1.0);
//! assert_eq!(lsc.gain_f32(3, 2, 5, 5), 1.5);
//! assert_eq!(lsc.gain_f32(4, 4, 5, 5), 2.0);
//! ```

use crate::IspError;

/// Largest grid side (nodes), so a row of interpolated node gains fits a fixed stack array.
pub const MAX_GRID_SIDE: usize = 64;
/// 1.0 in the grid's Q4.12 format.
pub const ONE_Q12: u16 = 4096;

/// A gain grid; see the module docs.
#[derive(Debug, Clone, Copy)]
pub struct LensShading<'a> {
    grid_w: usize,
    grid_h: usize,
    gains: &'a [u16],
}

/// Integer split of `i * (nodes - 1) / (n - 1)`: node index (at most `nodes - 2`) and
/// remainder over `n - 1`, and the divisor.
#[inline]
pub(crate) fn split(i: usize, n: usize, nodes: usize) -> (usize, u32, u32) {
    if n <= 1 {
        return (0, 0, 1);
    }
    let den = (n - 1) as u64;
    let num = i as u64 * (nodes - 1) as u64;
    // In 32 bits whenever it fits (every frame up to 2^26 pixels wide): a 64-bit division is
    // a software routine on 32-bit cores (47 instructions per pixel on the Cortex-M4).
    let (quotient, remainder) = match (u32::try_from(num), u32::try_from(den)) {
        (Ok(n32), Ok(d32)) => (u64::from(n32 / d32), u64::from(n32 % d32)),
        _ => (num / den, num % den),
    };
    let mut idx = quotient as usize;
    let mut rem = remainder as u32;
    if idx >= nodes - 1 {
        // The last pixel sits exactly on the last node: interpolate with weight 1 on it.
        idx = nodes - 2;
        rem = den as u32;
    }
    (idx, rem, den as u32)
}

/// Fills `gains` (a `grid_w x grid_h` grid's, four CFA positions a node, as
/// [`LensShading::new`] reads them) with the gains that undo a radial fall-off over a
/// `width x height` frame: `fall_off(position, r)` is the light at `r` pixels from `centre`
/// against the centre's, for the colour at that position of the 2x2 block (so a caller maps
/// positions to colours with its CFA pattern), or `None` (or 0) where the lens sends no
/// light. Each node's gain is `1 / fall_off` at the node's pixel, in Q4.12, at most the
/// format's largest (just under 16). A node beyond the image circle takes the gain of the
/// furthest radius inside it on its way to the centre (searched in 64 steps; 1 if none), so
/// the pixels between it and the last lit node, which do get light, are interpolated
/// between like gains, not pulled down towards 1. How a prescription's relative illumination
/// (optics-core's `Prescription::illumination_at_height`) becomes a shading grid.
///
/// ```
/// use isp_core::lsc::{radial_gains, LensShading};
/// // cos^4 fall-off of a lens whose corner is 30 degrees off axis on a 64 x 48 frame.
/// let mut gains = [0u16; 9 * 7 * 4];
/// let corner = (31.5f64).hypot(23.5);
/// radial_gains(&mut gains, 9, 7, 64, 48, [31.5, 23.5], |_, r| {
///     Some((r / corner * 30f64.to_radians().tan()).atan().cos().powi(4))
/// })
/// .unwrap();
/// let lsc = LensShading::new(9, 7, &gains).unwrap();
/// // The corner is lifted by 1 / cos^4(30 degrees) = 16 / 9.
/// assert!((lsc.gain_f32(0, 0, 64, 48) - 16.0 / 9.0).abs() < 1e-3);
/// ```
pub fn radial_gains(
    gains: &mut [u16],
    grid_w: usize,
    grid_h: usize,
    width: usize,
    height: usize,
    centre: [f64; 2],
    mut fall_off: impl FnMut(usize, f64) -> Option<f64>,
) -> Result<(), IspError> {
    // The grid's own checks.
    LensShading::new(grid_w, grid_h, gains)?;
    if width == 0 || height == 0 || !centre.iter().all(|c| c.is_finite()) {
        return Err(IspError::InvalidParameter {
            name: "radial shading frame",
            allowed: "a non-empty frame and a finite centre",
        });
    }
    let largest = f64::from(u16::MAX) / f64::from(ONE_Q12);
    for gy in 0..grid_h {
        for gx in 0..grid_w {
            // The node's pixel, as the grid places it (the corner nodes on the corner pixels).
            let x = (gx * (width - 1)) as f64 / (grid_w - 1) as f64;
            let y = (gy * (height - 1)) as f64 / (grid_h - 1) as f64;
            let r = libm::hypot(x - centre[0], y - centre[1]);
            for position in 0..4 {
                let mut gain = 1.0;
                for step in 0..64 {
                    match fall_off(position, r * f64::from(64 - step) / 64.0) {
                        Some(f) if f > 0.0 && f.is_finite() => {
                            gain = (1.0 / f).min(largest);
                            break;
                        }
                        _ => continue,
                    }
                }
                gains[(gy * grid_w + gx) * 4 + position] =
                    libm::round(gain * f64::from(ONE_Q12)) as u16;
            }
        }
    }
    Ok(())
}

impl<'a> LensShading<'a> {
    /// A checked grid: sides in `2..=MAX_GRID_SIDE` and exactly `grid_w * grid_h * 4` gains.
    pub fn new(grid_w: usize, grid_h: usize, gains: &'a [u16]) -> Result<Self, IspError> {
        if !(2..=MAX_GRID_SIDE).contains(&grid_w) || !(2..=MAX_GRID_SIDE).contains(&grid_h) {
            return Err(IspError::InvalidParameter {
                name: "lens shading grid",
                allowed: "2..=64 nodes each way",
            });
        }
        if gains.len() != grid_w * grid_h * 4 {
            return Err(IspError::InvalidParameter {
                name: "lens shading gains",
                allowed: "grid_w * grid_h * 4 values",
            });
        }
        Ok(Self {
            grid_w,
            grid_h,
            gains,
        })
    }

    /// Grid width in nodes.
    pub fn grid_w(&self) -> usize {
        self.grid_w
    }

    /// Grid height in nodes.
    pub fn grid_h(&self) -> usize {
        self.grid_h
    }

    /// The Q4.12 gains.
    pub fn gains(&self) -> &'a [u16] {
        self.gains
    }

    #[inline]
    pub(crate) fn node(&self, gx: usize, gy: usize, position: usize) -> u16 {
        self.gains[(gy * self.grid_w + gx) * 4 + position]
    }

    /// The gain at pixel `(x, y)` of a `width x height` frame, in float (the reference).
    pub fn gain_f32(&self, x: usize, y: usize, width: usize, height: usize) -> f32 {
        let position = (y & 1) * 2 + (x & 1);
        let (gx, rx, dx) = split(x, width, self.grid_w);
        let (gy, ry, dy) = split(y, height, self.grid_h);
        let (fx, fy) = (rx as f32 / dx as f32, ry as f32 / dy as f32);
        let g = |i, j| self.node(i, j, position) as f32 * (1.0 / ONE_Q12 as f32);
        let top = g(gx, gy) * (1.0 - fx) + g(gx + 1, gy) * fx;
        let bottom = g(gx, gy + 1) * (1.0 - fx) + g(gx + 1, gy + 1) * fx;
        top * (1.0 - fy) + bottom * fy
    }

    /// The grid interpolated down to row `y` for each node column and CFA position of that
    /// row's parity, in Q4.16: `out[gx * 2 + (x & 1)]`.
    pub(crate) fn row_nodes_q16(
        &self,
        y: usize,
        height: usize,
        out: &mut [u32; 2 * MAX_GRID_SIDE],
    ) {
        let (gy, ry, dy) = split(y, height, self.grid_h);
        let fy = ((ry as u64) << 16) / dy as u64;
        for gx in 0..self.grid_w {
            for px in 0..2 {
                let position = (y & 1) * 2 + px;
                let a = self.node(gx, gy, position) as u64;
                let b = self.node(gx, gy + 1, position) as u64;
                // Q12 * Q16 = Q28; keep Q16.
                out[gx * 2 + px] = ((a * ((1 << 16) - fy) + b * fy + (1 << 11)) >> 12) as u32;
            }
        }
    }

    /// The gain at column `x` of a `width`-wide row from [`Self::row_nodes_q16`], in Q4.16.
    #[inline]
    pub(crate) fn gain_q16(&self, nodes: &[u32; 2 * MAX_GRID_SIDE], x: usize, width: usize) -> u64 {
        let (gx, rx, dx) = split(x, width, self.grid_w);
        let fx = ((rx as u64) << 16) / dx as u64;
        let px = x & 1;
        let a = nodes[gx * 2 + px] as u64;
        let b = nodes[(gx + 1) * 2 + px] as u64;
        (a * ((1 << 16) - fx) + b * fx + (1 << 15)) >> 16
    }
}

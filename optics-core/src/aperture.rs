//! Aperture shapes for bokeh. Each shape lives in the aperture plane in units of the aperture
//! radius (inside the unit disk) and offers uniform sampling by area from a point of the unit
//! square, a membership test and its density.
//!
//! ```
//! use optics_core::aperture::{ApertureShape, RegularPolygon};
//! use glam::Vec2;
//! let hexagon = RegularPolygon::new(6, 0.0).unwrap();
//! let p = hexagon.sample(Vec2::new(0.3, 0.7));
//! assert!(hexagon.contains(p));
//! assert!((hexagon.pdf(p) - 1.0 / hexagon.area()).abs() < 1e-6);
//! ```

use core::f32::consts::{FRAC_PI_4, PI, TAU};

use glam::Vec2;

use crate::{math, OpticsError, Result};

/// A shape an aperture can take. Points are in units of the aperture radius.
pub trait ApertureShape {
    /// Maps `u` in `[0, 1)^2` to a point distributed with density [`ApertureShape::pdf`]:
    /// uniform over the open area (a soft mask weights by transmission).
    fn sample(&self, u: Vec2) -> Vec2;
    /// Whether `p` is inside the open part of the aperture.
    fn contains(&self, p: Vec2) -> bool;
    /// Density of [`ApertureShape::sample`] at `p`, with respect to area (0 outside). The
    /// default is the uniform density `1 / area` of the analytic shapes.
    fn pdf(&self, p: Vec2) -> f32 {
        if self.contains(p) {
            1.0 / self.area()
        } else {
            0.0
        }
    }

    /// Open area, in units of radius squared.
    fn area(&self) -> f32;
}

/// Relative slack on the boundary of the analytic shapes, so a sample that rounding put a few
/// ulps outside its edge still counts as inside (the boundary has zero area).
const EDGE_TOLERANCE: f32 = 1e-5;

/// Folds `u` into `[0, 1)`; NaN becomes 0 so a bad sample never escapes the shape.
#[inline]
fn unit(u: f32) -> f32 {
    if (0.0..1.0).contains(&u) {
        u
    } else if u >= 1.0 {
        1.0 - f32::EPSILON / 2.0
    } else {
        0.0
    }
}

/// Splits `u` in `[0, 1)` into one of `n` equal bins and the position within it, in `[0, 1)`.
#[inline]
pub(crate) fn split(u: f32, n: u32) -> (u32, f32) {
    let scaled = unit(u) * n as f32;
    let k = (scaled as u32).min(n - 1);
    (k, unit(scaled - k as f32))
}

/// The unit disk, sampled with Shirley and Chiu's concentric mapping (low distortion, so
/// stratified samples stay stratified).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Disk;

impl ApertureShape for Disk {
    fn sample(&self, u: Vec2) -> Vec2 {
        let a = 2.0 * unit(u.x) - 1.0;
        let b = 2.0 * unit(u.y) - 1.0;
        if a == 0.0 && b == 0.0 {
            return Vec2::ZERO;
        }
        // Shirley-Chiu: the angle is pi/4 (b / a) in the sectors around +-x, and
        // pi/2 - pi/4 (a / b) around +-y, where cosine and sine trade places.
        if a.abs() > b.abs() {
            let (s, c) = math::sin_cos_small(FRAC_PI_4 * (b / a));
            Vec2::new(a * c, a * s)
        } else {
            let (s, c) = math::sin_cos_small(FRAC_PI_4 * (a / b));
            Vec2::new(b * s, b * c)
        }
    }
    fn contains(&self, p: Vec2) -> bool {
        p.length_squared() <= 1.0 + EDGE_TOLERANCE
    }
    fn area(&self) -> f32 {
        PI
    }
}

/// A regular polygon of `blades` sides inscribed in the unit circle (an iris of straight blades),
/// rotated by `rotation` radians (0 puts a vertex on +x).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RegularPolygon {
    blades: u32,
    rotation: f32,
    sector: f32,
}

impl RegularPolygon {
    /// Most blades accepted; beyond this a [`Disk`] is the better model.
    pub const MAX_BLADES: u32 = 64;

    /// A polygon of 3..=64 blades; any finite rotation.
    pub fn new(blades: u32, rotation: f32) -> Result<Self> {
        if !(3..=Self::MAX_BLADES).contains(&blades) {
            return Err(OpticsError::InvalidParameter {
                name: "blades",
                allowed: "3..=64",
            });
        }
        if !rotation.is_finite() {
            return Err(OpticsError::InvalidParameter {
                name: "rotation",
                allowed: "finite",
            });
        }
        Ok(Self {
            blades,
            rotation,
            sector: TAU / blades as f32,
        })
    }

    /// Number of blades (sides).
    pub fn blades(&self) -> u32 {
        self.blades
    }

    /// Vertex `k` (mod the number of blades).
    pub fn vertex(&self, k: u32) -> Vec2 {
        let a = self.rotation + (k % self.blades) as f32 * self.sector;
        Vec2::new(math::cos(a), math::sin(a))
    }
}

impl ApertureShape for RegularPolygon {
    fn sample(&self, u: Vec2) -> Vec2 {
        // All n triangles (centre, v_k, v_k+1) have equal area: pick one, then sample it
        // uniformly with the square-root warp.
        let (k, ux) = split(u.x, self.blades);
        let (a, b) = (self.vertex(k), self.vertex(k + 1));
        let s = math::sqrt(ux);
        let t = unit(u.y);
        a * (s * (1.0 - t)) + b * (s * t)
    }
    fn contains(&self, p: Vec2) -> bool {
        // Distance to the nearest edge along its normal: inside when within the apothem.
        let angle = math::atan2(p.y, p.x) - self.rotation;
        let mut folded = angle % self.sector;
        if folded < 0.0 {
            folded += self.sector;
        }
        let local = folded - self.sector / 2.0;
        let apothem = math::cos(self.sector / 2.0);
        p.length() * math::cos(local) <= apothem + EDGE_TOLERANCE
    }
    fn area(&self) -> f32 {
        0.5 * self.blades as f32 * math::sin(self.sector)
    }
}

/// A heart: a square standing on a corner with a half-disk on each of its two upper edges,
/// centred and scaled to fit the unit disk.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Heart {
    /// Half-diagonal of the square.
    d: f32,
    /// Vertical shift that centres the bounding box.
    shift: f32,
}

impl Default for Heart {
    fn default() -> Self {
        Self::new()
    }
}

impl Heart {
    /// The heart scaled to touch the unit circle.
    pub fn new() -> Self {
        // With half-diagonal d: lobes centred at (±d/2, d/2) with radius d/√2; the shape spans
        // y in [-d, d(1/2 + 1/√2)], so shifting by -d(1/√2 - 1/2)/2 centres it. The farthest
        // points are on the lobes: |centre| + radius must be 1.
        let k = core::f32::consts::FRAC_1_SQRT_2;
        let shift_per_d = -(0.5 + k - 1.0) / 2.0;
        let centre = Vec2::new(0.5, 0.5 + shift_per_d).length();
        let d = 1.0 / (centre + k);
        Self {
            d,
            shift: shift_per_d * d,
        }
    }

    fn lobe_radius(&self) -> f32 {
        self.d * core::f32::consts::FRAC_1_SQRT_2
    }

    fn lobe_centre(&self, side: f32) -> Vec2 {
        Vec2::new(side * self.d / 2.0, self.d / 2.0 + self.shift)
    }

    fn square_area(&self) -> f32 {
        2.0 * self.d * self.d
    }

    fn half_disk_area(&self) -> f32 {
        let r = self.lobe_radius();
        PI * r * r / 2.0
    }
}

impl ApertureShape for Heart {
    fn sample(&self, u: Vec2) -> Vec2 {
        // Disjoint pieces: the square and the two outer half-disks, chosen by area.
        let total = self.area();
        let square = self.square_area() / total;
        let ux = unit(u.x);
        let uy = unit(u.y);
        if ux < square {
            let a = unit(ux / square);
            // Square corners: bottom (0,-d), right (d,0), left (-d,0); edges along (1,1), (-1,1).
            let p = Vec2::new(0.0, -self.d)
                + Vec2::new(self.d, self.d) * a
                + Vec2::new(-self.d, self.d) * uy;
            return p + Vec2::new(0.0, self.shift);
        }
        let rest = unit((ux - square) / (1.0 - square));
        let (side_index, v) = split(rest, 2);
        let side = if side_index == 0 { -1.0 } else { 1.0 };
        // Outward normal of the upper-left edge is (-1,1)/√2, of the upper-right (1,1)/√2.
        let normal = Vec2::new(side, 1.0) * core::f32::consts::FRAC_1_SQRT_2;
        let theta = (v - 0.5) * PI;
        let r = self.lobe_radius() * math::sqrt(uy);
        let dir = Vec2::new(
            normal.x * math::cos(theta) - normal.y * math::sin(theta),
            normal.x * math::sin(theta) + normal.y * math::cos(theta),
        );
        self.lobe_centre(side) + dir * r
    }
    fn contains(&self, p: Vec2) -> bool {
        let q = p - Vec2::new(0.0, self.shift);
        let r2 = self.lobe_radius() * self.lobe_radius();
        let r2 = r2 * (1.0 + EDGE_TOLERANCE);
        q.x.abs() + q.y.abs() <= self.d * (1.0 + EDGE_TOLERANCE)
            || (p - self.lobe_centre(-1.0)).length_squared() <= r2
            || (p - self.lobe_centre(1.0)).length_squared() <= r2
    }
    fn area(&self) -> f32 {
        self.square_area() + 2.0 * self.half_disk_area()
    }
}

/// A caller-supplied mask over the square `[-1, 1]^2` (row 0 at the top, `y = +1`): each byte is
/// the transmission of one cell, 0 closed to 255 open. Sampling is by importance through a
/// cumulative table kept in a caller-provided buffer, so no heap is needed.
#[derive(Debug, Clone, Copy)]
pub struct BitmapMask<'a> {
    mask: &'a [u8],
    cdf: &'a [u32],
    width: usize,
    height: usize,
}

impl<'a> BitmapMask<'a> {
    /// Largest number of cells: keeps the cumulative sum within `u32`.
    pub const MAX_CELLS: usize = (u32::MAX / 255) as usize;
    /// Largest width or height: a cell stays thousands of `f32` steps wide, so a point placed
    /// in a cell is found in it again.
    pub const MAX_SIDE: usize = 8192;

    /// Builds the sampling table for `mask` (`width * height` bytes, row-major) in `cdf_buffer`,
    /// which needs `width * height` elements ([`BitmapMask::cdf_len`]).
    pub fn new(
        mask: &'a [u8],
        width: usize,
        height: usize,
        cdf_buffer: &'a mut [u32],
    ) -> Result<Self> {
        if width == 0 || height == 0 || width > Self::MAX_SIDE || height > Self::MAX_SIDE {
            return Err(OpticsError::InvalidParameter {
                name: "width/height",
                allowed: "1..=8192",
            });
        }
        let cells = Self::cdf_len(width, height)?;
        if mask.len() < cells {
            return Err(OpticsError::BufferTooSmall {
                needed: cells,
                provided: mask.len(),
            });
        }
        if cdf_buffer.len() < cells {
            return Err(OpticsError::BufferTooSmall {
                needed: cells,
                provided: cdf_buffer.len(),
            });
        }
        let mut sum: u32 = 0;
        for (c, &m) in cdf_buffer.iter_mut().zip(mask.iter()).take(cells) {
            sum += m as u32; // cannot overflow: cells <= MAX_CELLS.
            *c = sum;
        }
        if sum == 0 {
            return Err(OpticsError::EmptyMask);
        }
        Ok(Self {
            mask: &mask[..cells],
            cdf: &cdf_buffer[..cells],
            width,
            height,
        })
    }

    /// Elements the cumulative table needs, or an error past [`BitmapMask::MAX_CELLS`].
    pub fn cdf_len(width: usize, height: usize) -> Result<usize> {
        match width.checked_mul(height) {
            Some(n) if n <= Self::MAX_CELLS => Ok(n),
            _ => Err(OpticsError::InvalidParameter {
                name: "width*height",
                allowed: "<= 16843009 cells",
            }),
        }
    }

    fn total(&self) -> u32 {
        self.cdf.last().copied().unwrap_or(0)
    }

    fn cell_at(&self, p: Vec2) -> Option<usize> {
        if !(p.x >= -1.0 && p.x < 1.0 && p.y > -1.0 && p.y <= 1.0) {
            return None;
        }
        let col = (((p.x + 1.0) / 2.0 * self.width as f32) as usize).min(self.width - 1);
        let row = (((1.0 - p.y) / 2.0 * self.height as f32) as usize).min(self.height - 1);
        Some(row * self.width + col)
    }
}

impl ApertureShape for BitmapMask<'_> {
    fn sample(&self, u: Vec2) -> Vec2 {
        // Pick a cell by its share of the total transmission; the fraction of u.x within that
        // cell's interval places the point across the cell, u.y down it.
        let total = self.total() as f64;
        let target = unit(u.x) as f64 * total;
        let cell = self
            .cdf
            .partition_point(|&c| (c as f64) <= target)
            .min(self.cdf.len() - 1);
        let start = if cell == 0 { 0 } else { self.cdf[cell - 1] } as f64;
        let weight = (self.cdf[cell] as f64 - start).max(1.0);
        let fx = unit(((target - start) / weight) as f32);
        let fy = unit(u.y);
        let col = (cell % self.width) as f32;
        let row = (cell / self.width) as f32;
        let x = -1.0 + 2.0 * (col + fx) / self.width as f32;
        let y = 1.0 - 2.0 * (row + fy) / self.height as f32;
        let p = Vec2::new(x, y);
        // On a cell's edge, rounding can put the point in the neighbour (which may be closed):
        // sampling and lookup must agree, so such a point moves to its cell's centre. This
        // touches a set of measure zero and cannot bias the distribution.
        if self.cell_at(p) == Some(cell) {
            p
        } else {
            Vec2::new(
                -1.0 + 2.0 * (col + 0.5) / self.width as f32,
                1.0 - 2.0 * (row + 0.5) / self.height as f32,
            )
        }
    }
    fn contains(&self, p: Vec2) -> bool {
        self.cell_at(p).is_some_and(|i| self.mask[i] > 0)
    }
    fn pdf(&self, p: Vec2) -> f32 {
        let Some(i) = self.cell_at(p) else { return 0.0 };
        let cell_area = 4.0 / (self.width * self.height) as f32;
        self.mask[i] as f32 / self.total() as f32 / cell_area
    }
    fn area(&self) -> f32 {
        // Area weighted by transmission: a half-open cell counts half.
        4.0 * self.total() as f32 / 255.0 / (self.width * self.height) as f32
    }
}

/// Any of the built-in shapes, so a camera can hold one without generics or `dyn`.
#[derive(Debug, Clone, Copy)]
pub enum Aperture<'a> {
    /// Circular.
    Disk(Disk),
    /// n-blade iris.
    Polygon(RegularPolygon),
    /// Heart.
    Heart(Heart),
    /// Caller-supplied mask.
    Bitmap(BitmapMask<'a>),
}

impl ApertureShape for Aperture<'_> {
    fn sample(&self, u: Vec2) -> Vec2 {
        match self {
            Self::Disk(s) => s.sample(u),
            Self::Polygon(s) => s.sample(u),
            Self::Heart(s) => s.sample(u),
            Self::Bitmap(s) => s.sample(u),
        }
    }
    fn contains(&self, p: Vec2) -> bool {
        match self {
            Self::Disk(s) => s.contains(p),
            Self::Polygon(s) => s.contains(p),
            Self::Heart(s) => s.contains(p),
            Self::Bitmap(s) => s.contains(p),
        }
    }
    fn pdf(&self, p: Vec2) -> f32 {
        match self {
            Self::Disk(s) => s.pdf(p),
            Self::Polygon(s) => s.pdf(p),
            Self::Heart(s) => s.pdf(p),
            Self::Bitmap(s) => s.pdf(p),
        }
    }
    fn area(&self) -> f32 {
        match self {
            Self::Disk(s) => s.area(),
            Self::Polygon(s) => s.area(),
            Self::Heart(s) => s.area(),
            Self::Bitmap(s) => s.area(),
        }
    }
}

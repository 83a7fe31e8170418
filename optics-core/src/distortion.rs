//! Brown-Conrady lens distortion in normalised image coordinates, as OpenCV defines it
//! (`cv::projectPoints` with the 5-coefficient vector `(k1, k2, p1, p2, k3)`):
//!
//! ```text
//! r^2 = x^2 + y^2,  R = 1 + k1 r^2 + k2 r^4 + k3 r^6
//! x_d = x R + 2 p1 x y + p2 (r^2 + 2 x^2)
//! y_d = y R + p1 (r^2 + 2 y^2) + 2 p2 x y
//! ```
//!
//! The inverse runs Newton's method on the 2x2 system from `(x_d, y_d)`, with step halving
//! when a step does not reduce the residual. **Convergence bound**: [`BrownConrady::undistort`]
//! returns a point `u` with `max(|distort(u) - p|) <= 16 eps max(1, |p|)` (`eps` the type's
//! machine epsilon: about 3.6e-15 for `f64`, 1.9e-6 for `f32`), a positive Jacobian
//! determinant, and the radial map `r R(r)` increasing from the centre out to the solution
//! (checked at 32 radii), reached within 50 iterations; otherwise [`OpticsError::DidNotConverge`].
//! So the answer is always on the branch connected to the image centre: far outside the region
//! the coefficients were fitted on, the model folds over and a root found there is refused.

use crate::real::{checked, finite};
use crate::{OpticsError, Real, Result};

/// Radial (`k1`, `k2`, `k3`) and tangential (`p1`, `p2`) distortion coefficients.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BrownConrady<T> {
    k1: T,
    k2: T,
    k3: T,
    p1: T,
    p2: T,
}

impl<T: Real> Default for BrownConrady<T> {
    fn default() -> Self {
        Self {
            k1: T::zero(),
            k2: T::zero(),
            k3: T::zero(),
            p1: T::zero(),
            p2: T::zero(),
        }
    }
}

/// Iteration limit of [`BrownConrady::undistort`].
pub const MAX_ITERATIONS: u32 = 50;

impl<T: Real> BrownConrady<T> {
    /// Coefficients in OpenCV's order of meaning; each must be finite.
    pub fn new(k1: T, k2: T, k3: T, p1: T, p2: T) -> Result<Self> {
        Ok(Self {
            k1: finite(k1, "k1")?,
            k2: finite(k2, "k2")?,
            k3: finite(k3, "k3")?,
            p1: finite(p1, "p1")?,
            p2: finite(p2, "p2")?,
        })
    }

    /// From OpenCV's distortion vector `[k1, k2, p1, p2, k3]`.
    pub fn from_opencv(d: [T; 5]) -> Result<Self> {
        Self::new(d[0], d[1], d[4], d[2], d[3])
    }

    /// OpenCV's distortion vector `[k1, k2, p1, p2, k3]`.
    pub fn to_opencv(&self) -> [T; 5] {
        [self.k1, self.k2, self.p1, self.p2, self.k3]
    }

    /// Whether every coefficient is zero (distortion off).
    pub fn is_identity(&self) -> bool {
        self.to_opencv().iter().all(|c| *c == T::zero())
    }

    #[inline]
    fn eval(&self, x: T, y: T) -> [T; 2] {
        let two = T::lit(2.0);
        let r2 = x * x + y * y;
        let radial = T::one() + r2 * (self.k1 + r2 * (self.k2 + r2 * self.k3));
        [
            x * radial + two * self.p1 * x * y + self.p2 * (r2 + two * x * x),
            y * radial + self.p1 * (r2 + two * y * y) + two * self.p2 * x * y,
        ]
    }

    /// Jacobian `[[dxd/dx, dxd/dy], [dyd/dx, dyd/dy]]` at `(x, y)`.
    fn jacobian(&self, x: T, y: T) -> [[T; 2]; 2] {
        let (two, three, six) = (T::lit(2.0), T::lit(3.0), T::lit(6.0));
        let r2 = x * x + y * y;
        let radial = T::one() + r2 * (self.k1 + r2 * (self.k2 + r2 * self.k3));
        let d_radial = self.k1 + r2 * (two * self.k2 + three * self.k3 * r2);
        let cross = two * x * y * d_radial + two * self.p1 * x + two * self.p2 * y;
        [
            [
                radial + two * x * x * d_radial + two * self.p1 * y + six * self.p2 * x,
                cross,
            ],
            [
                cross,
                radial + two * y * y * d_radial + six * self.p1 * y + two * self.p2 * x,
            ],
        ]
    }

    /// Whether `d(r R)/dr = 1 + 3 k1 r^2 + 5 k2 r^4 + 7 k3 r^6` stays positive from the centre
    /// out to `u`'s radius: `u` is then on the branch that contains the image centre.
    fn radially_monotonic(&self, u: [T; 2]) -> bool {
        let r2 = u[0] * u[0] + u[1] * u[1];
        let (three, five, seven) = (T::lit(3.0), T::lit(5.0), T::lit(7.0));
        (1..=32).all(|i| {
            let s = r2 * T::lit(i as f64 / 32.0);
            T::one() + s * (three * self.k1 + s * (five * self.k2 + s * seven * self.k3))
                > T::zero()
        })
    }

    /// Distorts an ideal (undistorted) normalised point.
    pub fn distort(&self, p: [T; 2]) -> Result<[T; 2]> {
        let (x, y) = (finite(p[0], "x")?, finite(p[1], "y")?);
        if self.is_identity() {
            // Exact, and consistent with `undistort`, even where r^2 would overflow.
            return Ok(p);
        }
        let d = self.eval(x, y);
        Ok([checked(d[0])?, checked(d[1])?])
    }

    /// The ideal point that distorts to `p` (see the module docs for the convergence bound).
    pub fn undistort(&self, p: [T; 2]) -> Result<[T; 2]> {
        let (xd, yd) = (finite(p[0], "x")?, finite(p[1], "y")?);
        if self.is_identity() {
            return Ok(p);
        }
        let scale = T::one().max(xd.abs()).max(yd.abs());
        let tolerance = T::lit(16.0) * T::epsilon() * scale;
        let residual = |u: [T; 2]| {
            let d = self.eval(u[0], u[1]);
            [d[0] - xd, d[1] - yd]
        };
        // max() ignores NaN: a residual that overflowed must count as infinitely far.
        let norm = |r: [T; 2]| {
            if r[0].is_finite() && r[1].is_finite() {
                r[0].abs().max(r[1].abs())
            } else {
                T::infinity()
            }
        };
        // A root is accepted only on the branch that contains the image centre.
        let accept = |u: [T; 2]| {
            let j = self.jacobian(u[0], u[1]);
            let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
            if det > T::zero() && self.radially_monotonic(u) {
                Ok(u)
            } else {
                Err(OpticsError::DidNotConverge)
            }
        };
        let mut u = [xd, yd];
        let mut r = residual(u);
        for _ in 0..MAX_ITERATIONS {
            if norm(r) <= tolerance {
                return accept(u);
            }
            let j = self.jacobian(u[0], u[1]);
            let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
            if !(det.is_finite() && det != T::zero()) {
                return Err(OpticsError::DidNotConverge);
            }
            let step = [
                (j[1][1] * r[0] - j[0][1] * r[1]) / det,
                (j[0][0] * r[1] - j[1][0] * r[0]) / det,
            ];
            // Halve the step until the residual shrinks (at most 30 times).
            let mut improved = None;
            let mut lambda = T::one();
            for _ in 0..30 {
                let candidate = [u[0] - lambda * step[0], u[1] - lambda * step[1]];
                let rc = residual(candidate);
                if norm(rc) < norm(r) || norm(rc) <= tolerance {
                    improved = Some((candidate, rc));
                    break;
                }
                lambda = lambda / T::lit(2.0);
            }
            match improved {
                Some((candidate, rc)) if candidate[0].is_finite() && candidate[1].is_finite() => {
                    u = candidate;
                    r = rc;
                }
                // No step improves the residual: stuck at a fold or at the precision floor.
                _ => {
                    return if norm(r) <= tolerance {
                        accept(u)
                    } else {
                        Err(OpticsError::DidNotConverge)
                    };
                }
            }
        }
        Err(OpticsError::DidNotConverge)
    }
}

//! Shapes the tracer intersects: triangles (quads, boxes and meshes are made of them) and
//! spheres, each with an optional linear motion over the shutter interval.

use glam::{Vec2, Vec3};

/// A triangle with precomputed edges (Möller-Trumbore intersection).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Triangle {
    /// First vertex.
    pub p0: Vec3,
    /// `p1 - p0`.
    pub e1: Vec3,
    /// `p2 - p0`.
    pub e2: Vec3,
    /// Unit geometric normal `e1 x e2`: the side an area light emits from.
    pub normal: Vec3,
    /// Area.
    pub area: f32,
    /// Where the ray meets the plane, as barycentrics.
    pub(crate) plane: PlaneCoordinates,
}

/// A plane test first, then barycentrics from the dual basis of the edges: a ray is dropped
/// after one division when the plane lies behind it or beyond the nearest hit so far, which
/// is most of the candidates a BVH leaf offers.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct PlaneCoordinates {
    /// `normal . p0`.
    offset: f32,
    /// `(e2 x n) / |n|^2`: `(p - p0) . dual1` is the coordinate along `e1`.
    dual1: Vec3,
    /// `(n x e1) / |n|^2`: `(p - p0) . dual2` is the coordinate along `e2`.
    dual2: Vec3,
}

impl PlaneCoordinates {
    fn new(p0: Vec3, e1: Vec3, e2: Vec3, normal: Vec3) -> Self {
        let n = e1.cross(e2);
        let n2 = n.length_squared();
        Self {
            offset: normal.dot(p0),
            dual1: e2.cross(n) / n2,
            dual2: n.cross(e1) / n2,
        }
    }

    /// Distance to the plane of `normal` along the unit ray and the plane coordinates `(u, v)`
    /// there; `None` when the plane is parallel, behind, or not nearer than `t_max`.
    #[inline(always)]
    fn hit(
        &self,
        normal: Vec3,
        p0: Vec3,
        origin: Vec3,
        direction: Vec3,
        t_max: f32,
    ) -> Option<(f32, f32, f32)> {
        let denom = normal.dot(direction);
        let t = (self.offset - normal.dot(origin)) / denom;
        // Also false for NaN (a ray in the plane).
        if !(t > 0.0 && t < t_max) {
            return None;
        }
        let r = origin + direction * t - p0;
        Some((t, r.dot(self.dual1), r.dot(self.dual2)))
    }
}

impl Triangle {
    /// The triangle `a, b, c` (counter-clockwise seen from its front), or `None` when it is
    /// degenerate (zero area or not finite).
    pub fn new(a: Vec3, b: Vec3, c: Vec3) -> Option<Self> {
        let (e1, e2) = (b - a, c - a);
        let cross = e1.cross(e2);
        let len = cross.length();
        (len > 0.0 && len.is_finite() && a.is_finite() && (cross / len).is_finite()).then(|| {
            let normal = cross / len;
            Self {
                p0: a,
                e1,
                e2,
                normal,
                area: 0.5 * len,
                plane: PlaneCoordinates::new(a, e1, e2, normal),
            }
        })
    }

    /// Distance along the unit ray to a hit nearer than `t_max`, or infinity.
    #[inline(always)]
    pub fn intersect(&self, origin: Vec3, direction: Vec3, t_max: f32) -> f32 {
        match self
            .plane
            .hit(self.normal, self.p0, origin, direction, t_max)
        {
            Some((t, u, v)) if u >= 0.0 && v >= 0.0 && u + v <= 1.0 => t,
            _ => f32::INFINITY,
        }
    }

    /// A point uniformly distributed over the triangle, from `u` in `[0, 1)^2`.
    #[inline]
    pub fn sample(&self, u: Vec2) -> Vec3 {
        // Barycentrics (1 - sqrt(u), v sqrt(u)) are uniform over the triangle.
        let su = u.x.sqrt();
        let (b0, b1) = (1.0 - su, u.y * su);
        self.p0 + self.e1 * b1 + self.e2 * (1.0 - b0 - b1)
    }

    /// Bounds.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        let (a, b, c) = (self.p0, self.p0 + self.e1, self.p0 + self.e2);
        (a.min(b).min(c), a.max(b).max(c))
    }
}

/// A parallelogram `p0 + u e1 + v e2`, `u, v` in `[0, 1]`: one primitive where two triangles
/// would do, so walls and box faces cost one intersection test, not two.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Parallelogram {
    /// First corner.
    pub p0: Vec3,
    /// Edge to the second corner.
    pub e1: Vec3,
    /// Edge to the fourth corner.
    pub e2: Vec3,
    /// Unit normal `e1 x e2`: the side an area light emits from.
    pub normal: Vec3,
    /// Area.
    pub area: f32,
    plane: PlaneCoordinates,
}

impl Parallelogram {
    /// The parallelogram with corners `a, b, a + (b - a) + (d - a), d`, or `None` when degenerate.
    pub fn new(a: Vec3, b: Vec3, d: Vec3) -> Option<Self> {
        let t = Triangle::new(a, b, d)?;
        Some(Self {
            p0: t.p0,
            e1: t.e1,
            e2: t.e2,
            normal: t.normal,
            area: 2.0 * t.area,
            plane: t.plane,
        })
    }

    /// Distance along the unit ray to a hit nearer than `t_max`, or infinity.
    #[inline(always)]
    pub fn intersect(&self, origin: Vec3, direction: Vec3, t_max: f32) -> f32 {
        match self
            .plane
            .hit(self.normal, self.p0, origin, direction, t_max)
        {
            Some((t, u, v)) if (0.0..=1.0).contains(&u) && (0.0..=1.0).contains(&v) => t,
            _ => f32::INFINITY,
        }
    }

    /// A uniformly distributed point.
    #[inline]
    pub fn sample(&self, u: Vec2) -> Vec3 {
        self.p0 + self.e1 * u.x + self.e2 * u.y
    }

    /// Bounds.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        let (a, b, c, d) = (
            self.p0,
            self.p0 + self.e1,
            self.p0 + self.e1 + self.e2,
            self.p0 + self.e2,
        );
        (a.min(b).min(c).min(d), a.max(b).max(c).max(d))
    }
}

/// A sphere.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sphere {
    /// Centre.
    pub centre: Vec3,
    /// Radius (> 0).
    pub radius: f32,
}

impl Sphere {
    /// Distance along the unit ray to the nearest hit in front of the origin, or infinity
    /// (the caller compares with its nearest hit).
    #[inline(always)]
    pub fn intersect(&self, origin: Vec3, direction: Vec3) -> f32 {
        let oc = origin - self.centre;
        let b = oc.dot(direction);
        // The discriminant from the closest approach, not b^2 - c, so far spheres stay exact.
        let closest = oc - direction * b;
        let disc = self.radius * self.radius - closest.length_squared();
        if disc < 0.0 {
            return f32::INFINITY;
        }
        let s = disc.sqrt();
        let (t0, t1) = (-b - s, -b + s);
        if t0 > 0.0 {
            t0
        } else if t1 > 0.0 {
            t1
        } else {
            f32::INFINITY
        }
    }

    /// Area.
    pub fn area(&self) -> f32 {
        4.0 * std::f32::consts::PI * self.radius * self.radius
    }

    /// A point uniformly distributed over the surface, with its outward normal.
    #[inline]
    pub fn sample(&self, u: Vec2) -> (Vec3, Vec3) {
        let z = 1.0 - 2.0 * u.x;
        let r = (1.0 - z * z).max(0.0).sqrt();
        let (sin, cos) = optics_core::math::sin_cos_turns(u.y);
        let n = Vec3::new(r * cos, r * sin, z);
        (self.centre + n * self.radius, n)
    }
}

/// A triangle or a sphere.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shape {
    /// Triangle.
    Triangle(Triangle),
    /// Parallelogram.
    Parallelogram(Parallelogram),
    /// Sphere.
    Sphere(Sphere),
}

impl Shape {
    /// Distance to a hit along a unit ray nearer than `t_max`, or infinity.
    #[inline(always)]
    pub fn intersect(&self, origin: Vec3, direction: Vec3, t_max: f32) -> f32 {
        match self {
            Shape::Triangle(t) => t.intersect(origin, direction, t_max),
            Shape::Parallelogram(q) => q.intersect(origin, direction, t_max),
            Shape::Sphere(s) => s.intersect(origin, direction),
        }
    }

    /// Outward (front) normal at a surface point `p`.
    #[inline]
    pub fn normal_at(&self, p: Vec3) -> Vec3 {
        match self {
            Shape::Triangle(t) => t.normal,
            Shape::Parallelogram(q) => q.normal,
            Shape::Sphere(s) => (p - s.centre).normalize_or(Vec3::Z),
        }
    }

    /// Surface area.
    pub fn area(&self) -> f32 {
        match self {
            Shape::Triangle(t) => t.area,
            Shape::Parallelogram(q) => q.area,
            Shape::Sphere(s) => s.area(),
        }
    }

    /// A uniformly distributed point on the surface and its outward normal.
    // Inline: returned through memory, the pair stalled the load that followed the call
    // (store forwarding) for a tenth of the render time.
    #[inline]
    pub fn sample(&self, u: Vec2) -> (Vec3, Vec3) {
        match self {
            Shape::Triangle(t) => (t.sample(u), t.normal),
            Shape::Parallelogram(q) => (q.sample(u), q.normal),
            Shape::Sphere(s) => s.sample(u),
        }
    }

    /// Bounds.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        match self {
            Shape::Triangle(t) => t.bounds(),
            Shape::Parallelogram(q) => q.bounds(),
            Shape::Sphere(s) => (s.centre - s.radius, s.centre + s.radius),
        }
    }
}

/// The quad `a, b, c, d` (in order around it): one parallelogram when it is one (to a
/// millionth of its size), else two triangles; empty when degenerate.
pub fn quad(corners: [Vec3; 4]) -> Vec<Shape> {
    let [a, b, c, d] = corners;
    let scale = (b - a).length().max((d - a).length());
    if (b + d - a - c).length() <= 1e-6 * scale {
        if let Some(q) = Parallelogram::new(a, b, d) {
            return vec![Shape::Parallelogram(q)];
        }
    }
    [Triangle::new(a, b, c), Triangle::new(a, c, d)]
        .into_iter()
        .flatten()
        .map(Shape::Triangle)
        .collect()
}

/// The six outward-facing faces of the cube `[-1, 1]^3` mapped by `to_world` (affine, with a
/// positive determinant, so each face stays a parallelogram).
pub fn cube(to_world: &glam::Mat4) -> Vec<Shape> {
    // Each face: its outward axis and two in-face axes ordered so u x v points outward.
    let faces = [
        (Vec3::X, Vec3::Y, Vec3::Z),
        (-Vec3::X, Vec3::Z, Vec3::Y),
        (Vec3::Y, Vec3::Z, Vec3::X),
        (-Vec3::Y, Vec3::X, Vec3::Z),
        (Vec3::Z, Vec3::X, Vec3::Y),
        (-Vec3::Z, Vec3::Y, Vec3::X),
    ];
    faces
        .iter()
        .flat_map(|&(n, u, v)| {
            let corners =
                [n - u - v, n + u - v, n + u + v, n - u + v].map(|p| to_world.transform_point3(p));
            quad(corners)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn triangle_hits_inside_and_misses_outside() {
        let t = Triangle::new(Vec3::ZERO, Vec3::X, Vec3::Y).unwrap();
        assert_eq!(t.normal, Vec3::Z);
        let hit = t.intersect(Vec3::new(0.25, 0.25, 2.0), -Vec3::Z, f32::INFINITY);
        assert!((hit - 2.0).abs() < 1e-6);
        assert!(t
            .intersect(Vec3::new(0.75, 0.75, 2.0), -Vec3::Z, f32::INFINITY)
            .is_infinite());
        assert!(t
            .intersect(Vec3::new(0.25, 0.25, 2.0), Vec3::Z, f32::INFINITY)
            .is_infinite());
        assert!(t
            .intersect(Vec3::new(0.25, 0.25, 2.0), -Vec3::Z, 1.5)
            .is_infinite());
    }

    #[test]
    fn triangle_samples_stay_inside() {
        let t = Triangle::new(Vec3::ZERO, Vec3::X * 2.0, Vec3::Y).unwrap();
        let mut mean = Vec3::ZERO;
        let n = 64;
        for i in 0..n {
            for j in 0..n {
                let p = t.sample(Vec2::new(
                    (i as f32 + 0.5) / n as f32,
                    (j as f32 + 0.5) / n as f32,
                ));
                assert!(
                    p.x >= -1e-6 && p.y >= -1e-6 && p.x / 2.0 + p.y <= 1.0 + 1e-5,
                    "{p}"
                );
                mean += p;
            }
        }
        // Uniform: the mean is the centroid.
        let mean = mean / (n * n) as f32;
        assert!(
            (mean - Vec3::new(2.0 / 3.0, 1.0 / 3.0, 0.0)).length() < 1e-2,
            "{mean}"
        );
    }

    #[test]
    fn parallelogram_covers_its_fourth_corner_and_quad_splits_otherwise() {
        let corners = [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y];
        let shapes = quad(corners);
        assert_eq!(shapes.len(), 1);
        assert!((shapes[0].intersect(Vec3::new(0.9, 0.9, 1.0), -Vec3::Z, 2.0) - 1.0).abs() < 1e-6);
        assert!(shapes[0]
            .intersect(Vec3::new(1.1, 0.5, 1.0), -Vec3::Z, 2.0)
            .is_infinite());
        assert_eq!(shapes[0].area(), 1.0);
        let kite = quad([Vec3::ZERO, Vec3::X, Vec3::new(2.0, 2.0, 0.0), Vec3::Y]);
        assert_eq!(kite.len(), 2);
        assert!((kite.iter().map(Shape::area).sum::<f32>() - 2.0).abs() < 1e-6);
    }

    #[test]
    fn sphere_hits_near_side_then_far_side_from_inside() {
        let s = Sphere {
            centre: Vec3::ZERO,
            radius: 1.0,
        };
        assert!((s.intersect(Vec3::new(0.0, 0.0, 5.0), -Vec3::Z) - 4.0).abs() < 1e-6);
        assert!((s.intersect(Vec3::ZERO, Vec3::X) - 1.0).abs() < 1e-6);
        assert!(s
            .intersect(Vec3::new(0.0, 2.0, 5.0), -Vec3::Z)
            .is_infinite());
    }

    #[test]
    fn cube_faces_point_outward() {
        let faces = cube(&glam::Mat4::IDENTITY);
        assert_eq!(faces.len(), 6);
        for f in &faces {
            let Shape::Parallelogram(q) = f else {
                panic!("a cube face is a parallelogram: {f:?}")
            };
            let centre = q.p0 + (q.e1 + q.e2) / 2.0;
            assert!(q.normal.dot(centre) > 0.0, "{q:?}");
        }
        let area: f32 = faces.iter().map(|f| f.area()).sum();
        assert!((area - 24.0).abs() < 1e-4);
    }
}

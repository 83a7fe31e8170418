//! The bounding volume hierarchy: obvhs's compressed wide BVH (CWBVH, eight children per node)
//! over every primitive's bounds. Triangles and spheres are intersected in the traversal
//! closure; a moving primitive is bounded over its whole path and intersected at the ray's time.

use std::time::Duration;

use glam::{Vec3, Vec3A};
use obvhs::aabb::Aabb;
use obvhs::cwbvh::builder::build_cwbvh;
use obvhs::cwbvh::CwBvh;
use obvhs::ray::{Ray, RayHit};
use obvhs::{Boundable, BvhBuildParams};

use super::geometry::Shape;

/// One primitive of a scene.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Primitive {
    /// Its geometry at shutter open.
    pub shape: Shape,
    /// Translation at shutter close (zero: static). Positions move linearly in between.
    pub motion: Vec3,
    /// Index of its material.
    pub material: u32,
    /// Index of its emission, or [`Primitive::NO_EMISSION`].
    pub emission: u32,
}

impl Primitive {
    /// `emission` of a primitive that does not emit.
    pub const NO_EMISSION: u32 = u32::MAX;
}

impl Boundable for Primitive {
    fn aabb(&self) -> Aabb {
        let (lo, hi) = self.shape.bounds();
        let (lo, hi) = (lo.min(lo + self.motion), hi.max(hi + self.motion));
        Aabb::new(lo.into(), hi.into())
    }
}

/// A hit: distance along the ray and the primitive.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Distance along the unit ray.
    pub t: f32,
    /// Index into the scene's primitives.
    pub primitive: u32,
}

/// Primitives in BVH order with their hierarchy.
pub struct Accel {
    /// Primitives, reordered to the BVH's leaf order so a leaf reads them in sequence.
    pub primitives: Vec<Primitive>,
    bvh: Option<CwBvh>,
}

impl Accel {
    /// Builds the hierarchy (an empty scene has none and every ray misses).
    pub fn new(primitives: Vec<Primitive>) -> Self {
        if primitives.is_empty() {
            return Self {
                primitives,
                bvh: None,
            };
        }
        let mut bvh = build_cwbvh(
            &primitives,
            if primitives.len() < 100_000 {
                // Small scenes: the best tree is worth its build time (well under a second).
                BvhBuildParams::very_slow_build()
            } else {
                BvhBuildParams::medium_build()
            },
            &mut Duration::default(),
        );
        let ordered: Vec<Primitive> = bvh
            .primitive_indices
            .iter()
            .map(|&i| primitives[i as usize])
            .collect();
        // The leaves now index the reordered list directly.
        for (k, index) in bvh.primitive_indices.iter_mut().enumerate() {
            *index = k as u32;
        }
        Self {
            primitives: ordered,
            bvh: Some(bvh),
        }
    }

    #[inline(always)]
    fn shape_distance(p: &Primitive, origin: Vec3, direction: Vec3, s: f32, t_max: f32) -> f32 {
        if p.motion == Vec3::ZERO {
            p.shape.intersect(origin, direction, t_max)
        } else {
            // Move the ray instead of the shape.
            p.shape.intersect(origin - p.motion * s, direction, t_max)
        }
    }

    /// obvhs's ray for traversal. Its CWBVH traversal misses everything along a direction with
    /// a component exactly zero (seen with obvhs 0.4.0: a ray straight down -z through a sphere
    /// at the origin finds nothing), so such components become a tiny value of the same sign;
    /// the primitives are still intersected with the exact direction.
    #[inline(always)]
    fn bvh_ray(origin: Vec3, direction: Vec3, t_max: f32) -> Ray {
        let nudge = |v: f32| if v == 0.0 { 1e-20f32.copysign(v) } else { v };
        let d = Vec3A::new(nudge(direction.x), nudge(direction.y), nudge(direction.z));
        Ray::new(Vec3A::from(origin), d, 0.0, t_max)
    }

    /// The nearest hit along the unit ray closer than `t_max`, at shutter fraction `s`.
    #[inline]
    pub fn intersect(&self, origin: Vec3, direction: Vec3, s: f32, t_max: f32) -> Option<Hit> {
        let bvh = self.bvh.as_ref()?;
        let ray = Self::bvh_ray(origin, direction, t_max);
        let mut hit = RayHit::none();
        let found = bvh.ray_traverse(ray, &mut hit, |ray, id| {
            Self::shape_distance(&self.primitives[id], origin, direction, s, ray.tmax)
        });
        found.then_some(Hit {
            t: hit.t,
            primitive: hit.primitive_id,
        })
    }

    /// Whether anything lies along the unit ray before `t_max` (shadow rays).
    #[inline]
    pub fn occluded(&self, origin: Vec3, direction: Vec3, s: f32, t_max: f32) -> bool {
        let Some(bvh) = self.bvh.as_ref() else {
            return false;
        };
        let ray = Self::bvh_ray(origin, direction, t_max);
        !bvh.ray_traverse_miss(ray, |_, id| {
            Self::shape_distance(&self.primitives[id], origin, direction, s, t_max)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tracer::geometry::{cube, Sphere};

    fn prim(shape: Shape) -> Primitive {
        Primitive {
            shape,
            motion: Vec3::ZERO,
            material: 0,
            emission: Primitive::NO_EMISSION,
        }
    }

    #[test]
    fn finds_the_nearest_of_spheres_and_triangles() {
        let mut prims: Vec<Primitive> = cube(&glam::Mat4::IDENTITY).into_iter().map(prim).collect();
        prims.push(prim(Shape::Sphere(Sphere {
            centre: Vec3::new(0.0, 0.0, 3.0),
            radius: 0.5,
        })));
        let accel = Accel::new(prims);
        let hit = accel
            .intersect(Vec3::new(0.0, 0.0, 10.0), -Vec3::Z, 0.0, f32::INFINITY)
            .unwrap();
        assert!((hit.t - 6.5).abs() < 1e-5);
        assert!(matches!(
            accel.primitives[hit.primitive as usize].shape,
            Shape::Sphere(_)
        ));
        let hit = accel
            .intersect(Vec3::new(0.9, 0.0, 10.0), -Vec3::Z, 0.0, f32::INFINITY)
            .unwrap();
        assert!((hit.t - 9.0).abs() < 1e-5);
        assert!(accel.occluded(Vec3::new(0.9, 0.0, 10.0), -Vec3::Z, 0.0, 9.5));
        assert!(!accel.occluded(Vec3::new(0.9, 0.0, 10.0), -Vec3::Z, 0.0, 8.5));
        assert!(accel
            .intersect(Vec3::new(3.0, 0.0, 10.0), -Vec3::Z, 0.0, f32::INFINITY)
            .is_none());
    }

    #[test]
    fn a_moving_sphere_is_hit_where_it_is_at_the_ray_time() {
        let mut p = prim(Shape::Sphere(Sphere {
            centre: Vec3::ZERO,
            radius: 0.5,
        }));
        p.motion = Vec3::new(4.0, 0.0, 0.0);
        let accel = Accel::new(vec![p]);
        let at =
            |x: f32, s: f32| accel.intersect(Vec3::new(x, 0.0, 5.0), -Vec3::Z, s, f32::INFINITY);
        assert!(at(0.0, 0.0).is_some() && at(0.0, 1.0).is_none());
        assert!(at(4.0, 1.0).is_some() && at(2.0, 0.5).is_some() && at(4.0, 0.0).is_none());
    }

    #[test]
    fn axis_aligned_rays_hit() {
        let accel = Accel::new(vec![prim(Shape::Sphere(Sphere {
            centre: Vec3::ZERO,
            radius: 0.5,
        }))]);
        for d in [Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z] {
            let hit = accel.intersect(-d * 5.0, d, 0.0, f32::INFINITY);
            assert!(
                hit.is_some_and(|h| (h.t - 4.5).abs() < 1e-5),
                "{d}: {hit:?}"
            );
            assert!(accel.occluded(-d * 5.0, d, 0.0, 5.0), "{d}");
        }
    }

    #[test]
    fn an_empty_scene_misses() {
        let accel = Accel::new(Vec::new());
        assert!(accel.intersect(Vec3::ZERO, Vec3::X, 0.0, 1.0).is_none());
        assert!(!accel.occluded(Vec3::ZERO, Vec3::X, 0.0, 1.0));
    }
}

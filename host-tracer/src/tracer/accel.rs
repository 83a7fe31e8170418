//! The bounding volume hierarchy. obvhs builds it (PLOC with reinsertion, collapsed to eight
//! children per node, the CWBVH layout); the tracer walks its own copy of that tree with each
//! child's exact bounds as `f32` planes, eight children tested at once, nearest first. The
//! copy exists for speed: on the Cornell box, decoding CWBVH's 8-bit quantised child boxes was
//! the largest single cost in a profile, and its traversal cannot skip a child once a nearer
//! hit is found. Triangles, parallelograms and spheres are intersected inline; a moving
//! primitive is bounded over its whole path and intersected at the ray's time.

use std::time::Duration;

use glam::{Vec3, Vec3A, Vec4};
use obvhs::aabb::Aabb;
use obvhs::cwbvh::builder::build_cwbvh;
use obvhs::cwbvh::CwBvh;
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

    /// Bounds over the whole shutter interval.
    fn bounds(&self) -> (Vec3, Vec3) {
        let (lo, hi) = self.shape.bounds();
        (lo.min(lo + self.motion), hi.max(hi + self.motion))
    }
}

impl Boundable for Primitive {
    fn aabb(&self) -> Aabb {
        let (lo, hi) = self.bounds();
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

/// A child reference: an inner node's index, or a leaf's first primitive with its count
/// (1..=3 in CWBVH) in the top two bits.
type Child = u32;
const COUNT_SHIFT: u32 = 30;
const FIRST_MASK: u32 = (1 << COUNT_SHIFT) - 1;

/// Eight children's bounds as planes, so one ray is tested against four children per vector
/// operation. An empty slot has the empty box (min +inf, max -inf), which no ray enters.
#[derive(Debug, Clone, Copy)]
#[repr(C, align(64))]
struct WideNode {
    /// `[min x, min y, min z, max x, max y, max z]`, each for children 0..4 and 4..8.
    planes: [[Vec4; 2]; 6],
    children: [Child; 8],
}

/// Slab tests compare a far distance scaled up by this much (twice the relative error of the
/// three roundings in a distance, as in pbrt's robust ray-box test), so rounding never drops
/// a box the ray grazes.
const ROBUST: f32 = 1.0 + 4.0 * f32::EPSILON;

/// Pending subtrees of one traversal: at most seven siblings per level wait while the nearest
/// is descended, so a tree of depth `d` needs `7 d + 1` entries.
const fn stack_len(depth: usize) -> usize {
    7 * depth + 1
}
/// Deepest tree walked (obvhs's CWBVH itself refuses trees of depth 32 or more).
const MAX_DEPTH: usize = 48;

/// What a ray needs for the slab tests, computed once per ray.
struct RaySlabs {
    /// `1 / direction` per axis, each in all four lanes.
    inv: [Vec4; 3],
    /// `origin / direction` per axis, each in all four lanes.
    origin_inv: [Vec4; 3],
    /// Per axis, the plane row met first (min when the direction is positive) and last.
    near: [usize; 3],
    far: [usize; 3],
}

impl RaySlabs {
    #[inline(always)]
    fn new(origin: Vec3A, direction: Vec3A) -> Self {
        // A zero component becomes a tiny one of the same sign: its slabs are then crossed at
        // distances of +-1e20 scale (never NaN), which the tests order correctly.
        let zero = direction.cmpeq(Vec3A::ZERO);
        let d = Vec3A::select(zero, Vec3A::splat(1e-20).copysign(direction), direction);
        let inv = Vec3A::ONE / d;
        let origin_inv = origin * inv;
        let negative = inv.cmplt(Vec3A::ZERO).bitmask();
        let near = [0, 1, 2].map(|a| if negative & (1 << a) == 0 { a } else { a + 3 });
        Self {
            inv: [inv.x, inv.y, inv.z].map(Vec4::splat),
            origin_inv: [origin_inv.x, origin_inv.y, origin_inv.z].map(Vec4::splat),
            near,
            far: near.map(|row| (row + 3) % 6),
        }
    }

    /// Entry distances of the eight children (clamped at 0) and the mask of children the ray
    /// enters before `t_max`.
    #[inline(always)]
    fn enter(&self, node: &WideNode, t_max: f32) -> ([Vec4; 2], u32) {
        let t_max = Vec4::splat(t_max);
        let mut mask = 0;
        let mut entry = [Vec4::ZERO; 2];
        for (half, entry) in entry.iter_mut().enumerate() {
            let slab = |row: usize, axis: usize| {
                node.planes[row][half] * self.inv[axis] - self.origin_inv[axis]
            };
            let t_in = slab(self.near[0], 0)
                .max(slab(self.near[1], 1))
                .max(slab(self.near[2], 2).max(Vec4::ZERO));
            let t_out = slab(self.far[0], 0)
                .min(slab(self.far[1], 1))
                .min(slab(self.far[2], 2).min(t_max))
                * ROBUST;
            mask |= t_in.cmple(t_out).bitmask() << (4 * half);
            *entry = t_in;
        }
        (entry, mask)
    }
}

/// Primitives in BVH order with their hierarchy.
pub struct Accel {
    /// Primitives, reordered to the BVH's leaf order so a leaf reads them in sequence.
    pub primitives: Vec<Primitive>,
    /// The tree; node 0 is the root. Empty for an empty scene.
    nodes: Vec<WideNode>,
    /// Levels in the tree (0: empty).
    depth: usize,
}

impl Accel {
    /// Builds the hierarchy (an empty scene has none and every ray misses).
    ///
    /// # Panics
    /// When obvhs builds a tree deeper than 48 levels (it never has; its own traversal stops
    /// at 32).
    pub fn new(primitives: Vec<Primitive>) -> Self {
        if primitives.is_empty() {
            return Self {
                primitives,
                nodes: Vec::new(),
                depth: 0,
            };
        }
        let cw = build_cwbvh(
            &primitives,
            if primitives.len() < 100_000 {
                // Small scenes: the best tree is worth its build time (well under a second).
                BvhBuildParams::very_slow_build()
            } else {
                BvhBuildParams::medium_build()
            },
            &mut Duration::default(),
        );
        // Leaves index `primitive_indices`; storing the primitives in that order lets a leaf
        // read its primitives directly.
        let ordered: Vec<Primitive> = cw
            .primitive_indices
            .iter()
            .map(|&i| primitives[i as usize])
            .collect();
        let mut nodes = vec![
            WideNode {
                planes: [[Vec4::ZERO; 2]; 6],
                children: [0; 8],
            };
            cw.nodes.len()
        ];
        let (_, depth) = Self::copy_node(&cw, &ordered, &mut nodes, 0);
        assert!(
            depth <= MAX_DEPTH,
            "BVH depth {depth} exceeds the traversal's {MAX_DEPTH}"
        );
        Self {
            primitives: ordered,
            nodes,
            depth,
        }
    }

    /// Fills `nodes[index]` from CWBVH node `index` with exact child bounds; returns the
    /// node's bounds and the depth of its subtree.
    fn copy_node(
        cw: &CwBvh,
        primitives: &[Primitive],
        nodes: &mut [WideNode],
        index: usize,
    ) -> ((Vec3, Vec3), usize) {
        let source = cw.nodes[index];
        let empty = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        let mut node_bounds = empty;
        let mut depth = 1;
        // Empty slots keep the empty box (min +inf, max -inf).
        let mut rows = [[f32::INFINITY; 8]; 6];
        rows[3..].fill([f32::NEG_INFINITY; 8]);
        let mut children = [0; 8];
        for slot in 0..8 {
            if source.is_child_empty(slot) {
                continue;
            }
            let (bounds, child) = if source.is_leaf(slot) {
                let (first, count) = source.child_primitives(slot);
                let bounds = primitives[first as usize..(first + count) as usize]
                    .iter()
                    .fold(empty, |(lo, hi), p| {
                        let (a, b) = p.bounds();
                        (lo.min(a), hi.max(b))
                    });
                (bounds, first | (count << COUNT_SHIFT))
            } else {
                let child = source.child_node_index(slot);
                let (bounds, below) = Self::copy_node(cw, primitives, nodes, child as usize);
                depth = depth.max(below + 1);
                (bounds, child)
            };
            let (lo, hi) = bounds;
            for axis in 0..3 {
                rows[axis][slot] = lo[axis];
                rows[axis + 3][slot] = hi[axis];
            }
            children[slot] = child;
            node_bounds = (node_bounds.0.min(lo), node_bounds.1.max(hi));
        }
        let planes = std::array::from_fn(|row| {
            [
                Vec4::from_slice(&rows[row][..4]),
                Vec4::from_slice(&rows[row][4..]),
            ]
        });
        nodes[index] = WideNode { planes, children };
        (node_bounds, depth)
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

    /// The nearest hit along the unit ray closer than `t_max`, at shutter fraction `s`.
    #[inline(always)]
    pub fn intersect(&self, origin: Vec3, direction: Vec3, s: f32, t_max: f32) -> Option<Hit> {
        // 16-byte vectors across the call: `Vec3`s go through memory as 8 + 4 byte stores,
        // which the callee's loads straddled, stalling store forwarding on every ray.
        self.intersect_wide(origin.into(), direction.into(), s, t_max)
    }

    #[inline(never)]
    fn intersect_wide(&self, origin: Vec3A, direction: Vec3A, s: f32, t_max: f32) -> Option<Hit> {
        // The stack is sized for the tree (zeroing a deep tree's stack for a shallow one cost
        // an eighth of the render time).
        match self.depth {
            0 => None,
            1..=4 => self.nearest::<{ stack_len(4) }>(origin, direction, s, t_max),
            5..=12 => self.nearest::<{ stack_len(12) }>(origin, direction, s, t_max),
            _ => self.nearest::<{ stack_len(MAX_DEPTH) }>(origin, direction, s, t_max),
        }
    }

    #[inline(always)]
    fn nearest<const STACK: usize>(
        &self,
        origin: Vec3A,
        direction: Vec3A,
        s: f32,
        t_max: f32,
    ) -> Option<Hit> {
        let slabs = RaySlabs::new(origin, direction);
        let (origin, direction) = (Vec3::from(origin), Vec3::from(direction));
        let mut best = Hit {
            t: t_max,
            primitive: u32::MAX,
        };
        let mut stack = [(0 as Child, 0.0f32); STACK];
        let mut pending = 0;
        let mut current: Child = 0;
        loop {
            if current >> COUNT_SHIFT != 0 {
                let first = current & FIRST_MASK;
                for id in first..first + (current >> COUNT_SHIFT) {
                    let t = Self::shape_distance(
                        &self.primitives[id as usize],
                        origin,
                        direction,
                        s,
                        best.t,
                    );
                    if t < best.t {
                        best = Hit { t, primitive: id };
                    }
                }
            } else {
                let node = &self.nodes[current as usize];
                let (entry, mut mask) = slabs.enter(node, best.t);
                if mask != 0 {
                    // Children entered go on the stack sorted nearest last; the nearest is
                    // descended now, the rest wait.
                    let entry: [f32; 8] = std::array::from_fn(|k| entry[k / 4][k % 4]);
                    let base = pending;
                    while mask != 0 {
                        let slot = mask.trailing_zeros() as usize;
                        mask &= mask - 1;
                        let item = (node.children[slot], entry[slot]);
                        let mut k = pending;
                        while k > base && stack[k - 1].1 < item.1 {
                            stack[k] = stack[k - 1];
                            k -= 1;
                        }
                        stack[k] = item;
                        pending += 1;
                    }
                    pending -= 1;
                    current = stack[pending].0;
                    continue;
                }
            }
            // Next waiting subtree that could still hold a nearer hit.
            loop {
                if pending == 0 {
                    return (best.primitive != u32::MAX).then_some(best);
                }
                pending -= 1;
                let (child, t_in) = stack[pending];
                if t_in <= best.t * ROBUST {
                    current = child;
                    break;
                }
            }
        }
    }

    /// Whether anything lies along the unit ray before `t_max` (shadow rays).
    #[inline(always)]
    pub fn occluded(&self, origin: Vec3, direction: Vec3, s: f32, t_max: f32) -> bool {
        self.occluded_wide(origin.into(), direction.into(), s, t_max)
    }

    #[inline(never)]
    fn occluded_wide(&self, origin: Vec3A, direction: Vec3A, s: f32, t_max: f32) -> bool {
        match self.depth {
            0 => false,
            1..=4 => self.any::<{ stack_len(4) }>(origin, direction, s, t_max),
            5..=12 => self.any::<{ stack_len(12) }>(origin, direction, s, t_max),
            _ => self.any::<{ stack_len(MAX_DEPTH) }>(origin, direction, s, t_max),
        }
    }

    #[inline(always)]
    fn any<const STACK: usize>(&self, origin: Vec3A, direction: Vec3A, s: f32, t_max: f32) -> bool {
        let slabs = RaySlabs::new(origin, direction);
        let (origin, direction) = (Vec3::from(origin), Vec3::from(direction));
        let mut stack = [0 as Child; STACK];
        let mut pending = 1;
        while pending > 0 {
            pending -= 1;
            let node = &self.nodes[stack[pending] as usize];
            let (_, mut mask) = slabs.enter(node, t_max);
            while mask != 0 {
                let slot = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                let child = node.children[slot];
                if child >> COUNT_SHIFT == 0 {
                    stack[pending] = child;
                    pending += 1;
                    continue;
                }
                let first = child & FIRST_MASK;
                for id in first..first + (child >> COUNT_SHIFT) {
                    let p = &self.primitives[id as usize];
                    if Self::shape_distance(p, origin, direction, s, t_max) < t_max {
                        return true;
                    }
                }
            }
        }
        false
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

    /// Random triangles, parallelograms and spheres, some moving, in a 10-unit cube.
    fn random_scene(count: usize, rng: &mut crate::tracer::sampling::Rng) -> Vec<Primitive> {
        use crate::tracer::geometry::{Parallelogram, Triangle};
        let mut point = |scale: f32| {
            Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * scale - scale / 2.0
        };
        (0..count)
            .filter_map(|k| {
                let centre = point(10.0);
                let shape = match k % 3 {
                    0 => Shape::Triangle(Triangle::new(
                        centre,
                        centre + point(1.0),
                        centre + point(1.0),
                    )?),
                    1 => Shape::Parallelogram(Parallelogram::new(
                        centre,
                        centre + point(1.0),
                        centre + point(1.0),
                    )?),
                    _ => Shape::Sphere(Sphere {
                        centre,
                        radius: 0.05 + point(0.4).x.abs(),
                    }),
                };
                let mut p = prim(shape);
                if k % 5 == 0 {
                    p.motion = point(2.0);
                }
                Some(p)
            })
            .collect()
    }

    #[test]
    fn traversal_agrees_with_testing_every_primitive() {
        let mut rng = crate::tracer::sampling::Rng::new(11, 0);
        // Sizes from one leaf to a tree deep enough for the largest stack class.
        for count in [1, 2, 7, 40, 500, 20_000] {
            let prims = random_scene(count, &mut rng);
            let accel = Accel::new(prims);
            assert!(
                count < 20_000 || accel.depth > 4,
                "depth {} does not reach the deeper stack",
                accel.depth
            );
            for _ in 0..2000 {
                let origin = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 14.0 - 7.0;
                let mut direction = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5;
                // Some rays along an axis or in a coordinate plane.
                match rng.next_u32() % 8 {
                    0 => direction.x = 0.0,
                    1 => direction = Vec3::new(0.0, 0.0, direction.z),
                    _ => {}
                }
                let direction = direction.normalize_or(Vec3::Z);
                let s = rng.next_f32();
                let t_max = if rng.next_u32().is_multiple_of(2) {
                    f32::INFINITY
                } else {
                    rng.next_f32() * 12.0
                };
                let brute = accel
                    .primitives
                    .iter()
                    .enumerate()
                    .map(|(i, p)| (Accel::shape_distance(p, origin, direction, s, t_max), i))
                    .filter(|&(t, _)| t < t_max)
                    .min_by(|a, b| a.0.total_cmp(&b.0));
                let hit = accel.intersect(origin, direction, s, t_max);
                match (hit, brute) {
                    (None, None) => {}
                    (Some(h), Some((t, _))) => {
                        // Ties (shared edges) may pick either primitive; the distance agrees.
                        assert!((h.t - t).abs() <= 1e-5 * t.max(1.0), "{h:?} vs {t}");
                    }
                    other => panic!("{count} primitives, {origin} {direction}: {other:?}"),
                }
                assert_eq!(
                    accel.occluded(origin, direction, s, t_max),
                    brute.is_some(),
                    "{count} primitives, {origin} {direction} before {t_max}"
                );
            }
        }
    }

    #[test]
    fn an_empty_scene_misses() {
        let accel = Accel::new(Vec::new());
        assert!(accel.intersect(Vec3::ZERO, Vec3::X, 0.0, 1.0).is_none());
        assert!(!accel.occluded(Vec3::ZERO, Vec3::X, 0.0, 1.0));
    }
}

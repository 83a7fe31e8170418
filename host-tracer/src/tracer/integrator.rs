//! A path tracer for diffuse (Lambertian) surfaces: next-event estimation on area lights
//! combined with BSDF sampling by multiple importance sampling (power heuristic), Russian
//! roulette after a few bounces, and a maximum path length.

use glam::Vec3;

use super::color::Channels;
use super::sampling::{cosine_hemisphere, Rng};
use super::scene::Scene;

/// Path-length limits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathSettings {
    /// Longest path in segments, as Mitsuba's `max_depth`: 1 shows emitters only, 2 adds
    /// direct light, and so on.
    pub max_depth: u32,
    /// Segments before Russian roulette may end a path (Mitsuba's `rr_depth`, default 5).
    pub rr_depth: u32,
}

impl Default for PathSettings {
    fn default() -> Self {
        Self {
            max_depth: 8,
            rr_depth: 5,
        }
    }
}

#[inline]
fn power_heuristic(a: f32, b: f32) -> f32 {
    let (a2, b2) = (a * a, b * b);
    if a2 + b2 > 0.0 {
        a2 / (a2 + b2)
    } else {
        0.0
    }
}

/// Radiance along the unit ray `origin + t direction` at shutter fraction `s`, weighted by
/// `weight` (the camera's per-channel throughput).
pub fn radiance<const N: usize>(
    scene: &Scene<N>,
    settings: &PathSettings,
    mut origin: Vec3,
    mut direction: Vec3,
    s: f32,
    weight: Channels<N>,
    rng: &mut Rng,
) -> Channels<N> {
    let mut sum = Channels::<N>::ZERO;
    let mut beta = weight;
    // Density (solid angle) of the BSDF sample that made the current segment; 0 for the camera
    // ray, whose emitter hits take no MIS weight.
    let mut bsdf_pdf = 0.0f32;
    let nee = scene.has_lights();
    let mut segments = 1u32;
    loop {
        let Some(hit) = scene.accel.intersect(origin, direction, s, f32::INFINITY) else {
            sum += beta * scene.environment;
            break;
        };
        let prim = &scene.accel.primitives[hit.primitive as usize];
        let p = origin + direction * hit.t;
        let normal = prim.shape.normal_at(p - prim.motion * s);
        let cos_out = -normal.dot(direction);
        if prim.emission != super::accel::Primitive::NO_EMISSION && cos_out > 0.0 {
            let le = scene.emission[prim.emission as usize];
            let w = if bsdf_pdf == 0.0 {
                1.0
            } else {
                let light_pdf = scene.light_area_pdf(hit.primitive) * hit.t * hit.t / cos_out;
                power_heuristic(bsdf_pdf, light_pdf)
            };
            sum += beta * le * w;
        }
        if segments >= settings.max_depth {
            break;
        }
        // Diffuse surfaces reflect on both sides.
        let n = if cos_out >= 0.0 { normal } else { -normal };
        let albedo = scene.albedo[prim.material as usize];
        if albedo.is_black() {
            break;
        }
        let f = albedo * std::f32::consts::FRAC_1_PI;
        let offset = p + n * scene.epsilon;
        if nee {
            if let Some(light) = scene.sample_light(offset, s, rng) {
                let cos_in = n.dot(light.direction);
                if cos_in > 0.0
                    && !scene.accel.occluded(
                        offset,
                        light.direction,
                        s,
                        light.distance * (1.0 - 1e-4) - scene.epsilon,
                    )
                {
                    let bsdf = cos_in * std::f32::consts::FRAC_1_PI;
                    // The power heuristic's weight over the light's density, in one division:
                    // w / p_light = p_light / (p_light^2 + p_bsdf^2).
                    let w_over_pdf = light.pdf / (light.pdf * light.pdf + bsdf * bsdf);
                    sum += beta * f * light.radiance * (cos_in * w_over_pdf);
                }
            }
        }
        let (next, cos_in) = cosine_hemisphere(n, rng.next_2d());
        if cos_in <= 0.0 {
            break;
        }
        // f cos / pdf = albedo for a cosine-sampled Lambertian surface.
        beta = beta * albedo;
        bsdf_pdf = cos_in * std::f32::consts::FRAC_1_PI;
        segments += 1;
        if segments > settings.rr_depth {
            let q = beta.max_channel().min(0.95);
            if q <= 0.0 || rng.next_f32() >= q {
                break;
            }
            beta = beta / q;
        }
        origin = offset;
        direction = next;
    }
    sum
}

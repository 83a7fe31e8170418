//! Fuzz target bodies: each takes arbitrary bytes, drives a public entry point that accepts
//! untrusted sizes or values, and panics only if that entry point broke its contract.

use optics_core::aperture::{ApertureShape, BitmapMask};
use optics_core::distortion::BrownConrady;
use optics_core::dof::{circle_of_confusion, depth_of_field};
use optics_core::fixed_point::{self, Dioptres, FNumber, Mm};
use optics_core::glam::Vec2;
use optics_core::lens::{image_distance, sensor_distance_for_focus};

fn f64s<const N: usize>(data: &[u8]) -> [f64; N] {
    let mut out = [0.0; N];
    for (i, chunk) in data.chunks(8).take(N).enumerate() {
        let mut b = [0u8; 8];
        b[..chunk.len()].copy_from_slice(chunk);
        out[i] = f64::from_le_bytes(b);
    }
    out
}

/// Float lens and depth-of-field equations: every answer is an error or finite.
pub fn optics_scalar(data: &[u8]) {
    let [f, n, c, s, d] = f64s::<5>(data);
    if let Ok(dof) = depth_of_field(f, n, c, s) {
        assert!(dof.near.is_finite());
        assert!(dof.far.finite().is_none_or(f64::is_finite));
    }
    if let Ok(x) = circle_of_confusion(f, n, s, d) {
        assert!(x.is_finite() && x >= 0.0);
    }
    if let Ok(i) = image_distance(f, s) {
        assert!(i.signed().is_none_or(f64::is_finite));
    }
    if let Ok(x) = sensor_distance_for_focus(f, s) {
        assert!(x.is_finite() && x > 0.0);
    }
}

/// Fixed-point focusing from raw bit patterns: errors, never a panic or a wrap (checked by
/// comparing with f64 where an answer is given).
pub fn optics_fixed(data: &[u8]) {
    let mut w = [0u64; 4];
    for (i, chunk) in data.chunks(8).take(4).enumerate() {
        let mut b = [0u8; 8];
        b[..chunk.len()].copy_from_slice(chunk);
        w[i] = u64::from_le_bytes(b);
    }
    let (f, n, c, v) = (
        Mm::from_bits(w[0]),
        FNumber::from_bits(w[1]),
        Mm::from_bits(w[2]),
        Dioptres::from_bits(w[3]),
    );
    if let Ok(s_i) = fixed_point::sensor_distance(f, v) {
        assert!(s_i >= f, "the sensor is never closer than f");
    }
    if let Ok(dof) = fixed_point::depth_of_field(f, n, c, v) {
        assert!(
            dof.far <= v && v <= dof.near,
            "far <= focus <= near in vergence"
        );
    }
    let _ = fixed_point::circle_of_confusion(f, n, v, Dioptres::from_bits(w[0]));
    let _ = fixed_point::distance(v);
}

/// Bitmap apertures of any size and content: built or refused, and every sample inside.
pub fn bitmap_aperture(data: &[u8]) {
    if data.len() < 6 {
        return;
    }
    let width = data[0] as usize % 40;
    let height = data[1] as usize % 40;
    let u = Vec2::new(data[2] as f32 / 255.0, data[3] as f32 / 256.0);
    let mask = &data[4..];
    let mut cdf = vec![0u32; (data[4] as usize * 7) % 1700];
    if let Ok(shape) = BitmapMask::new(mask, width, height, &mut cdf) {
        let p = shape.sample(u);
        assert!(shape.contains(p), "sample {p:?} outside the mask");
        assert!(shape.pdf(p) > 0.0);
    }
}

/// Distortion inverse: where it answers, the answer meets the documented bound.
pub fn distortion_inverse(data: &[u8]) {
    let [k1, k2, k3, p1, p2, x, y] = f64s::<7>(data);
    let Ok(model) = BrownConrady::new(k1, k2, k3, p1, p2) else {
        return;
    };
    if let Ok(u) = model.undistort([x, y]) {
        let d = model.distort(u).expect("an accepted inverse distorts back");
        let bound = 16.0 * f64::EPSILON * 1f64.max(x.abs()).max(y.abs());
        assert!((d[0] - x).abs() <= bound && (d[1] - y).abs() <= bound);
    }
}

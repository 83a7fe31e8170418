//! Proptest strategies more than one test file draws from.

use isp_core::distortion::{BrownConrady, LensDistortion};
use proptest::prelude::*;

/// Realistic Brown-Conrady coefficients in OpenCV's order `[k1, k2, p1, p2, k3]`: barrel and
/// pincushion, with tangential terms; within these the model is monotonic out to r = 0.6.
pub fn distortion_coefficients() -> impl Strategy<Value = [f64; 5]> {
    (
        -0.5f64..0.5,
        -0.2f64..0.2,
        -0.01f64..0.01,
        -0.01f64..0.01,
        -0.1f64..0.1,
    )
        .prop_map(|(k1, k2, p1, p2, k3)| [k1, k2, p1, p2, k3])
}

/// A lens for a `w` x `h` frame: focal length about the frame's size, principal point near
/// the centre, [`distortion_coefficients`].
pub fn lens(w: usize, h: usize) -> impl Strategy<Value = LensDistortion> {
    let size = w.max(h) as f64;
    (
        (0.5f64..2.0, 0.9f64..1.1, 0.3f64..0.7, 0.3f64..0.7),
        distortion_coefficients(),
    )
        .prop_map(move |((f, aspect, cx, cy), d)| {
            let model = BrownConrady::from_opencv(d).unwrap();
            LensDistortion::new(
                f * size,
                f * size * aspect,
                cx * (w - 1) as f64,
                cy * (h - 1) as f64,
                model,
            )
            .unwrap()
            .fitted(w, h)
        })
}

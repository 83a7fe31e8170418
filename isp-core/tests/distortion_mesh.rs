//! The distortion mesh against the exact model: with its cell fitted to the frame
//! ([`LensDistortion::fitted`]), every pixel's mesh position (before its rounding to 1/32
//! pixel) is within 1/32 pixel of where the Brown-Conrady model puts it, on each axis, for the
//! distortions the bench, the firmware cases and the OpenCV parity test use.

use isp_core::distortion::{BrownConrady, LensDistortion};

/// `(name, OpenCV coefficients, focal length over the larger side, principal point's offset
/// from the centre, width, height)`.
type Lens = (&'static str, [f64; 5], f64, (f64, f64), usize, usize);

const LENSES: [Lens; 7] = [
    (
        "firmware 64x48",
        [-0.15, 0.0, 0.0, 0.0, 0.0],
        1.0,
        (0.0, 0.0),
        64,
        48,
    ),
    (
        "firmware 128x96",
        [-0.15, 0.0, 0.0, 0.0, 0.0],
        1.0,
        (0.0, 0.0),
        128,
        96,
    ),
    (
        "bench 2592x1968",
        [-0.15, 0.0, 0.0, 0.0, 0.0],
        1.0,
        (0.0, 0.0),
        2592,
        1968,
    ),
    (
        "strong 96x64",
        [-0.3, 0.08, 0.002, -0.001, 0.0],
        0.85,
        (0.0, 0.0),
        96,
        64,
    ),
    (
        "strong 2592x1968",
        [-0.3, 0.08, 0.002, -0.001, 0.0],
        0.85,
        (0.0, 0.0),
        2592,
        1968,
    ),
    (
        "kodak 768x512",
        [-0.28, 0.09, 0.002, -0.001, -0.01],
        0.9,
        (3.3, -2.1),
        768,
        512,
    ),
    (
        "pincushion 48x40",
        [0.5, -0.2, 0.01, -0.01, 0.1],
        0.5,
        (0.0, 0.0),
        48,
        40,
    ),
];

#[test]
fn fitted_mesh_is_within_a_32nd_of_a_pixel_of_the_model() {
    for (name, coefficients, focal, (ox, oy), w, h) in LENSES {
        let model = BrownConrady::from_opencv(coefficients).unwrap();
        let f = focal * w.max(h) as f64;
        let (cx, cy) = ((w as f64 - 1.0) / 2.0 + ox, (h as f64 - 1.0) / 2.0 + oy);
        let lens = LensDistortion::new(f, f, cx, cy, model)
            .unwrap()
            .fitted(w, h);
        let mut worst = 0.0f64;
        let mut covered = 0usize;
        for v in 0..h {
            for u in 0..w {
                let [xd, yd] = model
                    .distort([(u as f64 - cx) / f, (v as f64 - cy) / f])
                    .unwrap();
                let exact = [f * xd + cx, f * yd + cy];
                if let Some(m) = lens.mesh_position_unrounded(u, v) {
                    covered += 1;
                    worst = worst
                        .max((m[0] - exact[0]).abs())
                        .max((m[1] - exact[1]).abs());
                }
            }
        }
        println!("{name}: cell {} px, worst {worst:.4} px", lens.mesh_cell());
        assert_eq!(covered, w * h, "{name}: every pixel has a mesh position");
        assert!(
            worst <= 1.0 / 32.0,
            "{name}: {worst} px with cell {}",
            lens.mesh_cell()
        );
    }
}

/// Without fitting, the 16-pixel mesh is what the fitting improves on: on a small frame's
/// strong lens it is off by more than the tolerance, so the test above tests something.
#[test]
fn an_unfitted_coarse_mesh_misses_on_a_small_frame() {
    let model = BrownConrady::from_opencv([-0.3, 0.08, 0.002, -0.001, 0.0]).unwrap();
    let (w, h) = (96usize, 64usize);
    let f = 0.85 * 96.0;
    let (cx, cy) = ((w as f64 - 1.0) / 2.0, (h as f64 - 1.0) / 2.0);
    let lens = LensDistortion::new(f, f, cx, cy, model).unwrap();
    assert_eq!(lens.mesh_cell(), 16);
    let mut worst = 0.0f64;
    for v in 0..h {
        for u in 0..w {
            let [xd, yd] = model
                .distort([(u as f64 - cx) / f, (v as f64 - cy) / f])
                .unwrap();
            if let Some(m) = lens.mesh_position_unrounded(u, v) {
                worst = worst
                    .max((m[0] - (f * xd + cx)).abs())
                    .max((m[1] - (f * yd + cy)).abs());
            }
        }
    }
    assert!(worst > 1.0 / 32.0, "{worst}");
    assert!(lens.fitted(w, h).mesh_cell() < 16);
}

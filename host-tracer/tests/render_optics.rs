//! The optics in the picture: what the renderer draws through optics-core's cameras, measured
//! on the film and compared with the lens formulas.

use std::path::Path;

use host_tracer::tracer::render::{render, RenderSettings, Rendered};
use host_tracer::tracer::scene::SceneDesc;
use host_tracer::tracer::scene_file::parse;

fn scene(text: &str) -> SceneDesc {
    parse(text, "test.toml", Path::new(".")).unwrap()
}

fn shoot(desc: &SceneDesc, seed: u64, threads: usize) -> Rendered {
    let mut s = RenderSettings::for_scene(desc);
    s.seed = seed;
    s.threads = threads;
    render(desc, &s).unwrap()
}

/// Luminance-like weight per pixel (the sum of R, G, B).
fn weights(image: &Rendered) -> Vec<f64> {
    image
        .rgb
        .chunks_exact(3)
        .map(|p| (p[0] + p[1] + p[2]) as f64)
        .collect()
}

/// Centroid and mean squared distance from it, in pixels (pixel centres at +0.5).
fn moments(image: &Rendered) -> ((f64, f64), f64, f64) {
    let w = weights(image);
    let width = image.width as usize;
    let total: f64 = w.iter().sum();
    assert!(total > 0.0, "the image is black");
    let (mut cx, mut cy) = (0.0, 0.0);
    for (i, v) in w.iter().enumerate() {
        cx += v * ((i % width) as f64 + 0.5);
        cy += v * ((i / width) as f64 + 0.5);
    }
    let (cx, cy) = (cx / total, cy / total);
    let (mut vx, mut vy) = (0.0, 0.0);
    for (i, v) in w.iter().enumerate() {
        vx += v * ((i % width) as f64 + 0.5 - cx).powi(2);
        vy += v * ((i / width) as f64 + 0.5 - cy).powi(2);
    }
    ((cx, cy), vx / total, vy / total)
}

/// A small emitting sphere on the axis at `distance` m, radius `radius` m, seen through a
/// 50 mm lens focused at `focus` m; the film is 64 px across 9 mm (0.140625 mm pixels).
fn bokeh_scene(
    f_number: f32,
    focus: f32,
    distance: f32,
    radius: f32,
    aperture: &str,
    size: u32,
) -> String {
    format!(
        r#"
[film]
width = {size}
height = {size}
spp = 256
max_depth = 1

[camera]
position = [0.0, 0.0, 0.0]
target = [0.0, 0.0, -1.0]
focal_length_mm = 50.0
sensor_width_mm = {sensor}
f_number = {f_number}
focus_distance = {focus}
{aperture}

[[shape]]
type = "sphere"
center = [0.0, 0.0, -{distance}]
radius = {radius}
emission = {{ rgb = [1.0, 1.0, 1.0] }}
"#,
        sensor = 0.140625 * size as f32
    )
}

#[test]
fn out_of_focus_sphere_blurs_to_the_circle_of_confusion() {
    let (f, n, focus, distance, radius) = (50.0f32, 1.4f32, 0.5f32, 2.0f32, 0.02f32);
    let desc = scene(&bokeh_scene(n, focus, distance, radius, "", 64));
    let image = shoot(&desc, 1, 0);
    let (_, vx, vy) = moments(&image);
    let pitch = 0.140625f64;
    // A uniform disk of radius R has E[r^2] = R^2 / 2. The blur is the circle of confusion
    // convolved with the sphere's own image (radius s_i tan(asin(r/d)) on the film) and the
    // pixel (variance 1/12 per axis): second moments add.
    let image_distance = 1.0 / (1.0 / f as f64 - 1.0 / (focus as f64 * 1000.0));
    let sphere_px = image_distance * (radius as f64 / distance as f64).asin().tan() / pitch;
    let coc_r2 = vx + vy - sphere_px * sphere_px / 2.0 - 2.0 / 12.0;
    let measured_mm = 2.0 * (2.0 * coc_r2).sqrt() * pitch;
    let expected_mm = optics_core::dof::circle_of_confusion(
        f as f64,
        n as f64,
        focus as f64 * 1000.0,
        distance as f64 * 1000.0,
    )
    .unwrap();
    let error = measured_mm / expected_mm - 1.0;
    eprintln!(
        "blur disk {measured_mm:.4} mm, circle of confusion {expected_mm:.4} mm ({:+.2} %)",
        100.0 * error
    );
    assert!(
        error.abs() < 0.03,
        "blur {measured_mm} mm vs CoC {expected_mm} mm"
    );
}

/// A shape as a point-in-shape test.
type Inside = Box<dyn Fn(f64, f64) -> bool>;

/// Whether `(x, y)` lies in the regular hexagon of circumradius `r` with a vertex at angle `rot`.
fn in_hexagon(x: f64, y: f64, r: f64, rot: f64) -> bool {
    let apothem = r * (std::f64::consts::PI / 6.0).cos();
    (0..6).all(|k| {
        // Edge normals point between neighbouring vertices.
        let a = rot + std::f64::consts::PI / 6.0 + k as f64 * std::f64::consts::PI / 3.0;
        x * a.cos() + y * a.sin() <= apothem
    })
}

#[test]
fn a_six_blade_aperture_gives_a_hexagonal_bokeh() {
    let (f, n, focus, distance) = (50.0f64, 1.0f64, 400.0f64, 3000.0f64);
    let aperture = r#"aperture = { shape = "polygon", blades = 6, rotation_deg = 0.0 }"#;
    let mut desc = scene(&bokeh_scene(n as f32, 0.4, 3.0, 0.01, aperture, 96));
    desc.spp = 1024;
    let image = shoot(&desc, 2, 0);
    let w = weights(&image);
    let width = image.width as usize;
    let ((cx, cy), _, _) = moments(&image);
    let total: f64 = w.iter().sum();
    // The blades' vertices lie on the aperture's circle, so the blur is a hexagon whose
    // circumradius is half the circle of confusion.
    let pitch = 0.140625;
    let r = optics_core::dof::circle_of_confusion(f, n, focus, distance).unwrap() / 2.0 / pitch;
    // Predicted images: the hexagon, the same hexagon turned by 30 degrees, and a disk of the
    // same area; each covers pixels by 8 x 8 supersampling and carries the render's flux.
    let disk_r = r * (3.0 * 3f64.sqrt() / 2.0 / std::f64::consts::PI).sqrt();
    let shapes: [(&str, Inside); 3] = [
        ("hexagon", Box::new(move |x, y| in_hexagon(x, y, r, 0.0))),
        (
            "hexagon turned 30 degrees",
            Box::new(move |x, y| in_hexagon(x, y, r, std::f64::consts::PI / 6.0)),
        ),
        (
            "disk of equal area",
            Box::new(move |x, y| x.hypot(y) <= disk_r),
        ),
    ];
    let predictions: Vec<Vec<f64>> = shapes
        .iter()
        .map(|(_, inside)| {
            let coverage: Vec<f64> = (0..w.len())
                .map(|i| {
                    let (px, py) = ((i % width) as f64, (i / width) as f64);
                    let hits = (0..64)
                        .filter(|k| {
                            let sx = px + (k % 8) as f64 / 8.0 + 1.0 / 16.0;
                            let sy = py + (k / 8) as f64 / 8.0 + 1.0 / 16.0;
                            inside(sx - cx, cy - sy)
                        })
                        .count();
                    hits as f64 / 64.0
                })
                .collect();
            let scale = total / coverage.iter().sum::<f64>();
            coverage.iter().map(|c| c * scale).collect()
        })
        .collect();
    // Fit the render as `other + k (hexagon - other)`: k = 1 says the hexagon explains it,
    // k = 0 the other shape. Only pixels where the two differ count, so the noise of the
    // plateau averages out.
    let hexagon = &predictions[0];
    for (other, (name, _)) in predictions.iter().zip(&shapes).skip(1) {
        let (mut num, mut den) = (0.0, 0.0);
        for ((i, h), o) in w.iter().zip(hexagon).zip(other) {
            num += (i - o) * (h - o);
            den += (h - o) * (h - o);
        }
        let k = num / den;
        eprintln!("hexagon against {name}: k = {k:.3}");
        assert!(
            (0.6..=1.4).contains(&k),
            "the render is not the hexagon, against {name}: k = {k}"
        );
    }
}

#[test]
fn chromatic_aberration_strength_zero_is_the_plain_thin_lens() {
    let base = bokeh_scene(2.0, 0.5, 1.0, 0.05, "", 32);
    let plain = shoot(&scene(&base), 7, 0);
    let zero = shoot(
        &scene(&base.replace("f_number =", "chromatic_aberration = 0.0\nf_number =")),
        7,
        0,
    );
    assert_eq!(plain.rgb, zero.rgb);
    // And the parameter is live: a strength that is not zero changes the picture.
    let strong = shoot(
        &scene(&base.replace("f_number =", "chromatic_aberration = 0.5\nf_number =")),
        7,
        0,
    );
    assert_ne!(plain.rgb, strong.rgb);
}

#[test]
fn a_moving_sphere_smears_over_the_distance_it_travels() {
    // Pinhole, 50 mm lens, 36 mm x 9 mm film of 256 x 64 px; a sphere 2 m away moving 0.4 m
    // across during the shutter: its image moves 0.4 * 50 / 2000 m = 10 mm = 71.1 px.
    let text = |motion: f32| {
        format!(
            r#"
[film]
width = 256
height = 64
spp = 64
max_depth = 1

[camera]
position = [0.0, 0.0, 0.0]
target = [0.0, 0.0, -1.0]
focal_length_mm = 50.0
sensor_width_mm = 36.0
shutter = [0.0, 0.01]

[[shape]]
type = "sphere"
center = [{start}, 0.0, -2.0]
radius = 0.05
motion = [{motion}, 0.0, 0.0]
emission = {{ rgb = [1.0, 1.0, 1.0] }}
"#,
            start = -motion / 2.0
        )
    };
    let still = shoot(&scene(&text(0.0)), 3, 0);
    let moving = shoot(&scene(&text(0.4)), 3, 0);
    let pitch = 36.0 / 256.0;
    let expected_px = 0.4 * 50.0 / 2.0 / pitch;
    // A uniform sweep convolves the still image with a box of the travel: variance + L^2 / 12.
    let ((cx, _), vx_still, _) = moments(&still);
    let ((mx, _), vx_moving, _) = moments(&moving);
    let measured_px = (12.0 * (vx_moving - vx_still)).sqrt();
    eprintln!("smear {measured_px:.2} px, travel {expected_px:.2} px");
    assert!(
        (measured_px / expected_px - 1.0).abs() < 0.02,
        "{measured_px} vs {expected_px}"
    );
    // Centred where the still sphere is (it moves symmetrically about it).
    assert!((cx - mx).abs() < 0.5, "{cx} vs {mx}");
    // A shape that does not move costs no time samples: the still render is the same at any
    // shutter (time is not drawn), so it matches a render with the shutter closed.
    let closed = shoot(
        &scene(&text(0.0).replace("shutter = [0.0, 0.01]", "shutter = [0.0, 0.0]")),
        3,
        0,
    );
    assert_eq!(still.rgb, closed.rgb);
}

#[test]
fn the_same_seed_gives_the_same_image_at_any_thread_count() {
    let desc = host_tracer::tracer::scene_file::load("cornell-box").unwrap();
    let mut s = RenderSettings::for_scene(&desc);
    (s.width, s.height, s.spp) = (40, 24, 4);
    s.threads = 1;
    let one = render(&desc, &s).unwrap();
    s.threads = 2;
    let two = render(&desc, &s).unwrap();
    assert_eq!(one.rgb, two.rgb);
    s.seed = 1;
    let other = render(&desc, &s).unwrap();
    assert_ne!(one.rgb, other.rgb);
}

#[test]
fn a_distorted_camera_puts_a_point_where_brown_conrady_says() {
    // Pinhole (so the image distance is f = 50 mm), 36 x 24 mm film of 240 x 160 px; a small
    // emitter at (0.5, 0.3, -2) m lands at x_u = (0.25, -0.15) (OpenCV's y points down).
    let coefficients = [-0.25, 0.08, 0.001, -0.002, 0.0];
    let text = |distortion: &str| {
        format!(
            r#"
[film]
width = 240
height = 160
spp = 16
max_depth = 1

[camera]
position = [0.0, 0.0, 0.0]
target = [0.0, 0.0, -1.0]
focal_length_mm = 50.0
sensor_width_mm = 36.0
{distortion}

[[shape]]
type = "sphere"
center = [0.5, 0.3, -2.0]
radius = 0.004
emission = {{ rgb = [1.0, 1.0, 1.0] }}
"#
        )
    };
    let to_px = |[x, y]: [f64; 2]| {
        [
            (x * 50.0 / 36.0 + 0.5) * 240.0,
            (0.5 + y * 50.0 / 24.0) * 160.0,
        ]
    };
    let straight = shoot(&scene(&text("")), 5, 0);
    let ((sx, sy), _, _) = moments(&straight);
    let [ex, ey] = to_px([0.25, -0.15]);
    assert!(
        (sx - ex).abs() < 0.2 && (sy - ey).abs() < 0.2,
        "({sx}, {sy}) vs ({ex}, {ey})"
    );
    let bent = shoot(
        &scene(&text(&format!("distortion = {coefficients:?}"))),
        5,
        0,
    );
    let ((bx, by), _, _) = moments(&bent);
    let model = optics_core::distortion::BrownConrady::from_opencv(coefficients).unwrap();
    let [dx, dy] = to_px(model.distort([0.25, -0.15]).unwrap());
    eprintln!("distorted point at ({bx:.2}, {by:.2}) px, Brown-Conrady says ({dx:.2}, {dy:.2})");
    assert!(
        (bx - dx).abs() < 0.2 && (by - dy).abs() < 0.2,
        "({bx}, {by}) vs ({dx}, {dy})"
    );
    // Barrel distortion pulls it towards the centre.
    assert!((bx - 120.0).abs() < (sx - 120.0).abs());
}

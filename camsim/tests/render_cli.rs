//! `camsim render` and scene files as a user meets them: the built-in scenes, the files
//! written (EXR read back by an independent reader, the `exr` crate), and errors that name the
//! file, the line and the field.

mod common;
use common::{camsim, temp_dir};
use std::path::Path;

use host_tracer::tracer::geometry::Shape;
use host_tracer::tracer::scene::Colour;
use host_tracer::tracer::scene_file::{load, parse};

fn read_exr(path: &Path) -> (usize, usize, Vec<[f32; 3]>) {
    use exr::prelude::*;
    let image = read_first_rgba_layer_from_file(
        path,
        |size, _| {
            (
                size.width(),
                vec![[0.0f32; 3]; size.width() * size.height()],
            )
        },
        |(w, px): &mut (usize, Vec<[f32; 3]>), pos, (r, g, b, _a): (f32, f32, f32, f32)| {
            px[pos.y() * *w + pos.x()] = [r, g, b];
        },
    )
    .unwrap();
    let size = image.layer_data.size;
    let (_, pixels) = image.layer_data.channel_data.pixels;
    (size.width(), size.height(), pixels)
}

#[test]
fn render_writes_linear_exr_and_an_srgb_preview() {
    let dir = temp_dir("render-cli");
    let (exr, png) = (dir.join("cb.exr"), dir.join("cb.png"));
    let (ok, stdout, stderr) = camsim(&[
        "render",
        "--scene",
        "cornell-box",
        "--width",
        "48",
        "--height",
        "32",
        "--spp",
        "8",
        "--seed",
        "3",
        "--linear",
        exr.to_str().unwrap(),
        "--preview",
        png.to_str().unwrap(),
        "--json",
    ]);
    assert!(ok, "{stderr}");
    let report: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(report["scene"], "cornell-box");
    assert_eq!(report["mode"], "rgb");
    assert_eq!(report["camera"], "pinhole");
    assert!(report["samples_per_s"].as_f64().unwrap() > 0.0);
    let (w, h, pixels) = read_exr(&exr);
    assert_eq!((w, h), (48, 32));
    // The report's mean is the EXR's mean: the file holds the rendered radiance.
    for c in 0..3 {
        let mean = pixels.iter().map(|p| p[c] as f64).sum::<f64>() / pixels.len() as f64;
        let reported = report["mean_rgb"][c].as_f64().unwrap();
        assert!(
            (mean - reported).abs() < 1e-6 * reported.max(1.0),
            "{mean} vs {reported}"
        );
    }
    // The light is in the top middle: the brightest pixel there, far above 1.
    let (brightest, _) = pixels
        .iter()
        .enumerate()
        .max_by(|a, b| a.1[0].total_cmp(&b.1[0]))
        .unwrap();
    assert!(
        brightest / w < h / 4 && (brightest % w).abs_diff(w / 2) < 6,
        "brightest at {brightest}"
    );
    assert!(pixels[brightest][0] > 5.0);
    // Red wall on the left, green on the right.
    let row = h / 2;
    let left = pixels[row * w + w / 4];
    let right = pixels[row * w + 3 * w / 4];
    assert!(
        left[0] > 2.0 * left[1] && right[1] > 2.0 * right[0],
        "{left:?} {right:?}"
    );
    let preview = raw_formats::image::read(&png).unwrap();
    assert_eq!(
        (
            preview.width,
            preview.height,
            preview.channels,
            preview.bits
        ),
        (48, 32, 3, 8)
    );
}

#[test]
fn render_refuses_bad_requests_with_clear_messages() {
    let dir = temp_dir("render-cli-errors");
    let out = dir.join("x.exr");
    let out = out.to_str().unwrap();
    for (args, expected) in [
        (vec!["render", "--scene", "cornell-box"], "nothing to write"),
        (
            vec!["render", "--scene", "no-such-scene", "--linear", out],
            "no-such-scene",
        ),
        (
            vec![
                "render",
                "--scene",
                "cornell-box",
                "--camera",
                "thinlens",
                "--linear",
                out,
            ],
            "needs --aperture-radius",
        ),
        (
            vec![
                "render",
                "--scene",
                "cornell-box",
                "--camera",
                "fisheye",
                "--linear",
                out,
            ],
            "pinhole or thinlens",
        ),
        (
            vec![
                "render",
                "--scene",
                "cornell-box",
                "--width",
                "0",
                "--linear",
                out,
            ],
            "width and height",
        ),
        (
            vec![
                "render",
                "--scene",
                "cornell-box",
                "--spp",
                "0",
                "--linear",
                out,
            ],
            "spp",
        ),
        (
            vec![
                "render",
                "--scene",
                "cornell-box",
                "--aperture-radius",
                "-1",
                "--linear",
                out,
            ],
            "--aperture-radius must be > 0",
        ),
        (
            vec![
                "render",
                "--scene",
                "cornell-box",
                "--aperture-radius",
                "0.1",
                "--focus-distance",
                "0.01",
                "--linear",
                out,
            ],
            "focus distance",
        ),
    ] {
        let (ok, _, stderr) = camsim(&args);
        assert!(!ok, "{args:?} succeeded");
        assert!(stderr.contains(expected), "{args:?}: {stderr}");
    }
}

#[test]
fn the_built_in_cornell_box_is_mitsubas() {
    // data/scenes/cornell-box.json: Mitsuba 3's cornell_box() in plain numbers.
    let json: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../data/scenes/cornell-box.json"
        ))
        .unwrap(),
    )
    .unwrap();
    let scene = load("cornell-box").unwrap();
    let v3 = |v: &serde_json::Value| -> [f32; 3] {
        std::array::from_fn(|i| v[i].as_f64().unwrap() as f32)
    };
    for (name, m) in json["materials"].as_object().unwrap() {
        let (_, colour) = scene.materials.iter().find(|(n, _)| n == name).unwrap();
        assert_eq!(*colour, Colour::Rgb(v3(&m["reflectance_rgb"])), "{name}");
    }
    for shape in json["shapes"].as_array().unwrap() {
        let name = shape["name"].as_str().unwrap();
        let ours = scene.shapes.iter().find(|s| s.name == name).unwrap();
        let material = &scene.materials[ours.material].0;
        assert_eq!(material, shape["material"].as_str().unwrap(), "{name}");
        match shape["type"].as_str().unwrap() {
            "quad" => {
                let corners: Vec<[f32; 3]> = shape["corners"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .map(v3)
                    .collect();
                let [Shape::Parallelogram(q)] = ours.geometry[..] else {
                    panic!("{name}: {:?}", ours.geometry)
                };
                let near = |a: glam::Vec3, b: [f32; 3]| (a - glam::Vec3::from(b)).length() < 1e-6;
                assert!(near(q.p0, corners[0]), "{name}");
                assert!(near(q.p0 + q.e1, corners[1]), "{name}");
                assert!(near(q.p0 + q.e1 + q.e2, corners[2]), "{name}");
                assert!(near(q.p0 + q.e2, corners[3]), "{name}");
                assert!(
                    (q.normal - glam::Vec3::from(v3(&shape["normal"]))).length() < 1e-6,
                    "{name}"
                );
            }
            "box" => {
                // Eight corners of the mapped cube, and volume from the matrix's determinant.
                let rows = shape["to_world_row_major"].as_array().unwrap();
                let m = |r: usize, c: usize| rows[r][c].as_f64().unwrap() as f32;
                let corner = glam::Vec3::new(
                    m(0, 0) + m(0, 1) + m(0, 2) + m(0, 3),
                    m(1, 0) + m(1, 1) + m(1, 2) + m(1, 3),
                    m(2, 0) + m(2, 1) + m(2, 2) + m(2, 3),
                );
                let found = ours.geometry.iter().any(|g| match g {
                    Shape::Parallelogram(q) => [q.p0, q.p0 + q.e1, q.p0 + q.e2, q.p0 + q.e1 + q.e2]
                        .iter()
                        .any(|p| (*p - corner).length() < 1e-5),
                    _ => false,
                });
                assert!(found && ours.geometry.len() == 6, "{name}");
            }
            other => panic!("unexpected shape type {other}"),
        }
        match &shape["emitter"] {
            serde_json::Value::Null => assert!(ours.emission.is_none(), "{name}"),
            e => assert_eq!(
                ours.emission,
                Some(Colour::Rgb(v3(&e["radiance_rgb"]))),
                "{name}"
            ),
        }
    }
    let cam = &json["camera"];
    assert_eq!(scene.camera.position.to_array(), v3(&cam["origin"]));
    assert_eq!(scene.camera.target.to_array(), v3(&cam["target"]));
    let sensor = scene.camera.sensor_mm(256, 256);
    let fov = 2.0 * (sensor.y / 2.0 / scene.camera.focal_length_mm).atan();
    assert!((fov.to_degrees() - cam["fov_deg"].as_f64().unwrap() as f32).abs() < 1e-4);
    assert_eq!(scene.max_depth, 8);
    assert_eq!(scene.film, (256, 256));
}

#[test]
fn the_demo_scene_is_spectral_and_uses_every_effect() {
    let scene = load("demo").unwrap();
    assert!(scene.is_spectral());
    assert!(scene.has_motion());
    assert!(scene.camera.aperture_radius_mm > 0.0 && scene.camera.chromatic_aberration > 0.0);
    let patches = scene
        .materials
        .iter()
        .filter(|(n, _)| n.starts_with("patch"))
        .count();
    assert_eq!(patches, 24);
}

fn error_of(text: &str) -> String {
    parse(text, "scene.toml", Path::new("."))
        .unwrap_err()
        .to_string()
}

const CAMERA: &str = "[camera]\nposition = [0, 0, 5]\ntarget = [0, 0, 0]\n";

#[test]
fn scene_file_errors_name_the_file_line_and_field() {
    let cases: Vec<(String, &str, &str)> = vec![
        (format!("{CAMERA}fov = 40\n"), "scene.toml:4:", "unknown field `fov`"),
        ("[camera]\nposition = [0, 0]\ntarget = [0, 0, 0]\n".into(), "scene.toml:2:", "position = [0, 0]"),
        (format!("{CAMERA}f_number = -2\n"), "scene.toml:1:", "camera: f_number: must be > 0"),
        (format!("{CAMERA}fov_deg = 200\n"), "scene.toml:1:", "camera: fov_deg"),
        (format!("{CAMERA}f_number = 2\nfocus_distance = 0.01\n"), "scene.toml:1:", "focus distance"),
        (format!("{CAMERA}aperture = {{ shape = \"star\" }}\n"), "scene.toml:1:", "aperture.shape: unknown shape \"star\""),
        (format!("{CAMERA}aperture = {{ shape = \"polygon\", blades = 2 }}\n"), "scene.toml:1:", "aperture.blades"),
        (format!("{CAMERA}distortion = [0.1]\n"), "scene.toml:1:", "camera: distortion"),
        (
            format!("{CAMERA}\n[materials]\nm = {{ rgb = [0.5, 0.5, 0.5] }}\n\n[[shape]]\ntype = \"sphere\"\nmaterial = \"m\"\ncenter = [0, 0, 0]\nradius = -1\n"),
            "scene.toml:8:",
            "shape[0] (sphere): radius: expected a number > 0",
        ),
        (
            format!("{CAMERA}\n[[shape]]\ntype = \"sphere\"\nmaterial = \"nope\"\ncenter = [0, 0, 0]\nradius = 1\n"),
            "scene.toml:5:",
            "material: unknown material \"nope\"",
        ),
        (
            format!("{CAMERA}\n[[shape]]\ntype = \"cone\"\nmaterial = \"m\"\n"),
            "scene.toml:5:",
            "type: unknown shape type \"cone\"",
        ),
        (
            format!("{CAMERA}\n[[shape]]\ntype = \"quad\"\nemission = {{ rgb = [1, 1, 1] }}\ncorners = [[0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0]]\n"),
            "scene.toml:5:",
            "corners: the quad is degenerate",
        ),
        (
            format!("{CAMERA}\n[[shape]]\ntype = \"sphere\"\nradius = 1\ncenter = [0, 0, 0]\ncorners = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]\nemission = {{ rgb = [1, 1, 1] }}\n"),
            "scene.toml:5:",
            "corners: not a field of a sphere",
        ),
        (
            format!("{CAMERA}\n[materials]\nm = {{ colorchecker = \"mauve\" }}\n"),
            "scene.toml:6:",
            "materials.m: unknown ColorChecker patch \"mauve\"",
        ),
        (
            format!("{CAMERA}\n[materials]\nm = {{ rgb = [1.5, 0, 0] }}\n"),
            "scene.toml:6:",
            "rgb reflectance must be in [0, 1]",
        ),
        (
            format!("{CAMERA}\n[environment]\nilluminant = \"D99\"\n"),
            "scene.toml:5:",
            "environment: unknown illuminant \"D99\"",
        ),
        (
            format!("{CAMERA}\n[[shape]]\ntype = \"mesh\"\nmaterial = \"m\"\nobj = \"missing.obj\"\n[materials]\nm = {{ rgb = [0.5, 0.5, 0.5] }}\n"),
            "scene.toml:5:",
            "obj: ",
        ),
        (format!("{CAMERA}\n[film]\nspp = 0\n"), "scene.toml:5:", "film: spp must be in"),
    ];
    for (text, place, message) in cases {
        let e = error_of(&text);
        assert!(
            e.starts_with(place) && e.contains(message),
            "for\n{text}\ngot: {e}\nexpected {place} ... {message}"
        );
    }
}

#[test]
fn scene_files_load_meshes_masks_and_spectra() {
    let dir = temp_dir("scene-files");
    // A tetrahedron in OBJ, a 4 x 4 mask PNG with a cross cut out.
    std::fs::write(
        dir.join("tet.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n",
    )
    .unwrap();
    let mask = raw_formats::image::Image {
        width: 4,
        height: 4,
        channels: 1,
        bits: 8,
        data: vec![
            0, 255, 255, 0, 255, 255, 255, 255, 255, 255, 255, 255, 0, 255, 255, 0,
        ],
    };
    raw_formats::image::write(&dir.join("mask.png"), &mask).unwrap();
    let text = r#"
[camera]
position = [0, 0, 5]
target = [0, 0, 0]
f_number = 2.8
aperture = { shape = "mask", png = "mask.png" }

[materials]
grey = { spectrum = { wavelengths_nm = [400, 700], values = [0.2, 0.8] } }
skin = { colorchecker = "Dark Skin" }

[[shape]]
type = "mesh"
obj = "tet.obj"
material = "grey"
scale = 2.0
translate = [1, 0, 0]

[[shape]]
type = "box"
min = [-1, -1, -1]
max = [0, 0, 0]
material = "skin"
motion = [0, 1, 0]

[[shape]]
type = "quad"
corners = [[0, 3, 0], [1, 3, 0], [1, 3, 1], [0, 3, 1]]
emission = { illuminant = "D65", luminance = 3.0 }
"#;
    let file = dir.join("scene.toml");
    std::fs::write(&file, text).unwrap();
    let scene = load(file.to_str().unwrap()).unwrap();
    assert_eq!(scene.name, "scene");
    assert_eq!(scene.shapes[0].geometry.len(), 4);
    assert!(scene.is_spectral() && scene.has_motion());
    let Some(Colour::Bands(light)) = &scene.shapes[2].emission else {
        panic!("{:?}", scene.shapes[2].emission)
    };
    // Scaled to the luminance asked for.
    let w = host_tracer::spectra::xyz_weights();
    let y: f32 = light.iter().zip(&w).map(|(v, w)| v * w[1]).sum();
    assert!((y - 3.0).abs() < 1e-4, "{y}");
    assert!(matches!(
        scene.camera.aperture,
        host_tracer::tracer::scene::ApertureDesc::Mask {
            width: 4,
            height: 4,
            ..
        }
    ));
    let mut settings = host_tracer::tracer::render::RenderSettings::for_scene(&scene);
    (settings.width, settings.height, settings.spp) = (16, 16, 2);
    let image = host_tracer::tracer::render::render(&scene, &settings).unwrap();
    assert_eq!(image.bands.len(), 16 * 16 * host_tracer::spectra::BANDS);
    assert!(image.rgb.iter().all(|v| v.is_finite()));
}

#[test]
fn bench_render_reports_every_feature_against_the_pinhole() {
    let (ok, out, err) = camsim(&[
        "bench",
        "render",
        "--width",
        "8",
        "--height",
        "8",
        "--spp",
        "1",
        "--repeats",
        "1",
        "--json",
    ]);
    assert!(ok, "{err}");
    let rows: serde_json::Value = serde_json::from_str(&out).unwrap();
    let rows = rows.as_array().unwrap();
    let names: Vec<&str> = rows
        .iter()
        .map(|r| r["variant"].as_str().unwrap())
        .collect();
    for want in [
        "pinhole",
        "thin lens",
        "thin lens, CA 0.15",
        "camera motion",
        "object motion",
        "spectral",
        "distortion",
        "everything",
    ] {
        assert!(names.contains(&want), "{want} missing from {names:?}");
    }
    assert_eq!(rows[0]["relative_time"].as_f64(), Some(1.0));
    for r in rows {
        assert!(r["msamples_per_s"].as_f64().unwrap() > 0.0, "{r}");
        assert!(r["what"].as_str().is_some_and(|w| !w.is_empty()), "{r}");
    }
    // Errors are one clear line, and nothing is printed to stdout.
    for (args, says) in [
        (vec!["--repeats", "0"], "--repeats"),
        (vec!["--aperture-radius", "-1"], "--aperture-radius"),
        (vec!["--spp", "0"], "spp"),
        (vec!["--scene", "no-such-scene"], "no-such-scene"),
    ] {
        let mut all = vec!["bench", "render", "--width", "4", "--height", "4"];
        all.extend(args);
        let (ok, out, err) = camsim(&all);
        assert!(
            !ok && out.is_empty() && err.contains(says),
            "{all:?}: {err}"
        );
    }
}

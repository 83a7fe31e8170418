//! The scene generators: a ColorChecker on a board, a slanted edge, a checkerboard, random
//! primitives, and a textured plane from an image set, each a pure function of its random streams. Scene units are metres; the
//! camera looks down -z at the subject at the origin from `subject_distance_m`; every light is
//! D65 (the sample's illuminant relights it, as `camsim demo --illuminant` does).

use std::path::{Path, PathBuf};

use glam::{Mat4, Quat, Vec3};
use host_tracer::random::Rng;
use host_tracer::spectra::{bands_from_grid, illuminant_bands, xyz_weights, Table, COLORCHECKER};
use host_tracer::tracer::geometry::{cube, quad, Shape, Sphere};
use host_tracer::tracer::scene::{
    ApertureDesc, CameraDesc, Colour, SceneDesc, SensorSize, ShapeDesc,
};
use serde_json::{json, Map, Value};

use super::spec::{pick, uniform};
use crate::error::Error;

/// The aperture shapes a spec may name, with their blade count (0: disk, 1: heart).
pub const APERTURES: [(&str, u32); 7] = [
    ("disk", 0),
    ("heart", 1),
    ("triangle", 3),
    ("square", 4),
    ("pentagon", 5),
    ("hexagon", 6),
    ("octagon", 8),
];

/// Sensor width of the generated scenes' camera, mm (full frame).
const SENSOR_WIDTH_MM: f32 = 36.0;
/// The area light's luminance and the environment's, cd/m^2: the demo scene's studio.
const LIGHT_NITS: f32 = 3200.0;
const ENVIRONMENT_NITS: f32 = 8.0;

/// `.png` files in `folder`, sorted by name (the order indices draw from).
pub fn image_files(folder: &Path) -> Result<Vec<PathBuf>, Error> {
    let entries = std::fs::read_dir(folder).map_err(|e| raw_formats::FormatError::io(folder, e))?;
    let mut files: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e.eq_ignore_ascii_case("png")))
        .collect();
    files.sort();
    Ok(files)
}

/// D65 at `nits` cd/m^2.
fn d65(nits: f32) -> Result<Colour, Error> {
    let bands = illuminant_bands("D65").map_err(Error::Simulation)?;
    let weights = xyz_weights();
    let y: f32 = bands.iter().zip(&weights).map(|(v, w)| v * w[1]).sum();
    Ok(Colour::Bands(Box::new(bands.map(|v| v * nits / y))))
}

/// A scene under construction.
struct Builder {
    scene: SceneDesc,
}

impl Builder {
    /// An empty scene seen from `(0, 0, distance)`, lit by the environment and an area light
    /// above and in front, placed from `rng`.
    fn new(
        name: &str,
        distance: f32,
        rng: &mut Rng,
        record: &mut Map<String, Value>,
    ) -> Result<Self, Error> {
        let mut camera = CameraDesc::pinhole(Vec3::new(0.0, 0.0, distance), Vec3::ZERO, 40.0);
        camera.focal_length_mm = 50.0;
        camera.sensor = SensorSize::WidthMm(SENSOR_WIDTH_MM);
        let mut scene = SceneDesc {
            name: name.to_owned(),
            materials: Vec::new(),
            shapes: Vec::new(),
            environment: Some(d65(ENVIRONMENT_NITS)?),
            camera,
            film: (512, 512),
            spp: 16,
            max_depth: 4,
            illuminant: Some("D65".into()),
        };
        // The light: a square of side 0.6 d, 0.75 d above the axis, over the camera's half
        // of the space, turned to face the subject; the demo's at d = 1.2.
        let (lx, lz) = (
            (uniform(rng) as f32 - 0.5) * distance,
            (0.25 + 0.5 * uniform(rng) as f32) * distance,
        );
        let centre = Vec3::new(lx, 0.75 * distance, lz);
        let half = 0.3 * distance;
        let corners = [
            centre + Vec3::new(-half, 0.0, -half),
            centre + Vec3::new(half, 0.0, -half),
            centre + Vec3::new(half, 0.0, half),
            centre + Vec3::new(-half, 0.0, half),
        ];
        scene.shapes.push(ShapeDesc {
            name: "light".into(),
            geometry: quad(corners),
            material: 0,
            emission: Some(d65(LIGHT_NITS)?),
            motion: Vec3::ZERO,
        });
        scene
            .materials
            .push(("light".into(), Colour::Rgb([0.0; 3])));
        record.insert("light_centre_m".into(), json!(round3(centre)));
        Ok(Builder { scene })
    }

    fn material(&mut self, name: String, colour: Colour) -> usize {
        self.scene.materials.push((name, colour));
        self.scene.materials.len() - 1
    }

    fn shape(&mut self, name: String, geometry: Vec<Shape>, material: usize) {
        self.scene.shapes.push(ShapeDesc {
            name,
            geometry,
            material,
            emission: None,
            motion: Vec3::ZERO,
        });
    }

    /// A wall facing the camera at `z`, wide enough to fill the view, of a random grey-ish
    /// colour.
    fn wall(&mut self, z: f32, distance: f32, rng: &mut Rng, record: &mut Map<String, Value>) {
        let grey = 0.05 + 0.5 * uniform(rng) as f32;
        let rgb = [0, 1, 2].map(|_| (grey * (0.8 + 0.4 * uniform(rng) as f32)).min(0.9));
        let m = self.material("wall".into(), Colour::Rgb(rgb));
        let half = 2.0 * (distance - z);
        let corners = [
            Vec3::new(-half, -half, z),
            Vec3::new(half, -half, z),
            Vec3::new(half, half, z),
            Vec3::new(-half, half, z),
        ];
        self.shape("wall".into(), quad(corners), m);
        record.insert("wall_rgb".into(), json!(rgb.map(round3f)));
    }
}

fn round3f(v: f32) -> f64 {
    (v as f64 * 1000.0).round() / 1000.0
}

fn round3(v: Vec3) -> [f64; 3] {
    [round3f(v.x), round3f(v.y), round3f(v.z)]
}

/// Half the frame's width and height at `distance` for the generated scenes' 50 mm lens.
fn half_frame(distance: f32, aspect: f32) -> (f32, f32) {
    let half_w = distance * 0.5 * SENSOR_WIDTH_MM / 50.0;
    (half_w, half_w / aspect)
}

/// The ColorChecker's 24 patches in a 6 x 4 grid on a dark board in front of a wall, turned
/// and placed at random; the chart spans 35 to 80 % of the frame's width.
pub fn colorchecker(
    distance: f32,
    aspect: f32,
    rng: &mut Rng,
    record: &mut Map<String, Value>,
) -> Result<SceneDesc, Error> {
    let mut b = Builder::new("colorchecker", distance, rng, record)?;
    let (half_w, half_h) = half_frame(distance, aspect);
    let fraction = 0.35 + 0.45 * uniform(rng) as f32;
    // The chart is 0.42 x 0.28 of its own units: patches 0.06 on a pitch of 0.07.
    let scale = fraction * 2.0 * half_w / 0.42;
    let angle = (uniform(rng) as f32 - 0.5) * 40f32.to_radians();
    let room = ((1.0 - fraction) * half_w).max(0.0);
    let offset = Vec3::new(
        (uniform(rng) as f32 - 0.5) * room,
        (uniform(rng) as f32 - 0.5) * (half_h - 0.5 * 0.28 * scale).max(0.0),
        0.0,
    );
    let to_world = Mat4::from_scale_rotation_translation(
        Vec3::splat(scale),
        Quat::from_rotation_z(angle),
        offset,
    );
    let board_grey = 0.02 + 0.2 * uniform(rng) as f32;
    let board = b.material("board".into(), Colour::Rgb([board_grey; 3]));
    let board_box = to_world
        * Mat4::from_scale_rotation_translation(
            Vec3::new(0.23, 0.16, 0.01),
            Quat::IDENTITY,
            Vec3::new(0.0, 0.0, -0.0105),
        );
    b.shape("board".into(), cube(&board_box), board);
    let table = Table::parse(COLORCHECKER).map_err(Error::Simulation)?;
    for (i, name) in table.names().iter().enumerate().take(24) {
        let column = table
            .column_at(i)
            .ok_or_else(|| Error::Message("ColorChecker table lacks a column".into()))?;
        let m = b.material(
            format!("patch{:02}", i + 1),
            Colour::Bands(Box::new(bands_from_grid(column))),
        );
        let (col, row) = ((i % 6) as f32, (i / 6) as f32);
        let (cx, cy) = (-0.175 + 0.07 * col, 0.105 - 0.07 * row);
        let corners = [(-0.03, -0.03), (0.03, -0.03), (0.03, 0.03), (-0.03, 0.03)]
            .map(|(dx, dy)| to_world.transform_point3(Vec3::new(cx + dx, cy + dy, 0.0)));
        b.shape(name.clone(), quad(corners), m);
    }
    b.wall(-0.3 * distance, distance, rng, record);
    record.insert("chart_width_fraction".into(), json!(round3f(fraction)));
    record.insert(
        "chart_rotation_deg".into(),
        json!(round3f(angle.to_degrees())),
    );
    record.insert("chart_offset_m".into(), json!(round3(offset)));
    record.insert("board_grey".into(), json!(round3f(board_grey)));
    Ok(b.scene)
}

/// A plate facing the camera (tilted up to `max_tilt_deg` about each axis, at random), its
/// transform from plate units (the plate spans `[-1, 1]^2` times `half`) to the scene.
fn plate(half: f32, max_tilt_deg: f32, rng: &mut Rng, record: &mut Map<String, Value>) -> Mat4 {
    let tilt = [0, 1].map(|_| (uniform(rng) as f32 - 0.5) * 2.0 * max_tilt_deg.to_radians());
    let roll = (uniform(rng) as f32 - 0.5) * 2.0 * max_tilt_deg.to_radians();
    record.insert(
        "tilt_deg".into(),
        json!([round3f(tilt[0].to_degrees()), round3f(tilt[1].to_degrees())]),
    );
    record.insert("roll_deg".into(), json!(round3f(roll.to_degrees())));
    Mat4::from_scale_rotation_translation(
        Vec3::new(half, half, 1.0),
        Quat::from_euler(glam::EulerRot::XYZ, tilt[0], tilt[1], roll),
        Vec3::ZERO,
    )
}

/// The quad `[x0, x1] x [y0, y1]` of plate units at height `z` (metres: a mark printed on the
/// plate stands 1 mm proud of it, clear of the tracer's self-intersection offset), through
/// `to_world`.
fn plate_quad(to_world: &Mat4, x0: f32, x1: f32, y0: f32, y1: f32, z: f32) -> Vec<Shape> {
    quad(
        [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]
            .map(|(x, y)| to_world.transform_point3(Vec3::new(x, y, z))),
    )
}

/// An ISO 12233-style slanted edge: a dark square turned 2 to 10 degrees on a white plate
/// that fills the frame, for measuring sharpness (the MTF) through the lens, sensor and ISP.
pub fn slanted_edge(
    distance: f32,
    aspect: f32,
    rng: &mut Rng,
    record: &mut Map<String, Value>,
) -> Result<SceneDesc, Error> {
    let mut b = Builder::new("slanted-edge", distance, rng, record)?;
    let (half_w, half_h) = half_frame(distance, aspect);
    let to_world = plate(1.5 * half_w.max(half_h), 10.0, rng, record);
    let white = b.material("white".into(), Colour::Rgb([0.8; 3]));
    let black = b.material("black".into(), Colour::Rgb([0.05; 3]));
    b.shape(
        "plate".into(),
        plate_quad(&to_world, -1.0, 1.0, -1.0, 1.0, 0.0),
        white,
    );
    let slant = (2.0 + 8.0 * uniform(rng) as f32) * if uniform(rng) < 0.5 { -1.0 } else { 1.0 };
    let side = 0.2 + 0.2 * uniform(rng) as f32;
    let square = to_world
        * Mat4::from_rotation_z(slant.to_radians())
        * Mat4::from_scale(Vec3::new(side, side, 1.0));
    b.shape(
        "edge".into(),
        plate_quad(&square, -1.0, 1.0, -1.0, 1.0, 1e-3),
        black,
    );
    record.insert("slant_deg".into(), json!(round3f(slant)));
    record.insert("square_half_side".into(), json!(round3f(side)));
    Ok(b.scene)
}

/// A checkerboard of 5 to 12 columns on a plate tilted up to 30 degrees, as for calibrating a
/// camera's geometry (distortion, pose).
pub fn checkerboard(
    distance: f32,
    aspect: f32,
    rng: &mut Rng,
    record: &mut Map<String, Value>,
) -> Result<SceneDesc, Error> {
    let mut b = Builder::new("checkerboard", distance, rng, record)?;
    let (half_w, _) = half_frame(distance, aspect);
    let columns = 5 + pick(rng, 8);
    let rows = (columns as f32 * (0.55 + 0.3 * uniform(rng) as f32))
        .round()
        .max(3.0) as usize;
    let fraction = 0.5 + 0.4 * uniform(rng) as f32;
    let to_world = plate(fraction * half_w, 30.0, rng, record);
    let white = b.material("white".into(), Colour::Rgb([0.85; 3]));
    let black = b.material("black".into(), Colour::Rgb([0.04; 3]));
    // Squares of 2 / columns plate units; a white margin of one square around them.
    let step = 2.0 / columns as f32;
    let (x_start, y_start) = (-1.0, rows as f32 * step / 2.0);
    b.shape(
        "board".into(),
        plate_quad(
            &to_world,
            -1.0 - step,
            1.0 + step,
            -y_start - step,
            y_start + step,
            0.0,
        ),
        white,
    );
    for r in 0..rows {
        for c in (0..columns).filter(|c| (c + r) % 2 == 0) {
            let (x0, y1) = (x_start + c as f32 * step, y_start - r as f32 * step);
            b.shape(
                format!("square{c}_{r}"),
                plate_quad(&to_world, x0, x0 + step, y1 - step, y1, 1e-3),
                black,
            );
        }
    }
    b.wall(-0.5 * distance, distance, rng, record);
    record.insert("squares".into(), json!([columns, rows]));
    record.insert("board_width_fraction".into(), json!(round3f(fraction)));
    Ok(b.scene)
}

/// `objects` spheres and boxes of ColorChecker spectra or random reflectances, at depths from
/// half to 1.6 times the subject distance, in front of a wall at twice it.
pub fn primitives(
    distance: f32,
    aspect: f32,
    objects: u32,
    rng: &mut Rng,
    record: &mut Map<String, Value>,
) -> Result<SceneDesc, Error> {
    let mut b = Builder::new("primitives", distance, rng, record)?;
    let table = Table::parse(COLORCHECKER).map_err(Error::Simulation)?;
    let mut shapes = Vec::new();
    for i in 0..objects {
        // Depth first, then a place inside the view at that depth.
        let z = distance - distance * (0.5 + 1.1 * uniform(rng) as f32);
        let (half_w, half_h) = half_frame(distance - z, aspect);
        let size = distance * (0.03 + 0.09 * uniform(rng) as f32);
        let centre = Vec3::new(
            (2.0 * uniform(rng) as f32 - 1.0) * half_w,
            (2.0 * uniform(rng) as f32 - 1.0) * half_h,
            z,
        );
        let (colour, colour_name) = if uniform(rng) < 0.5 {
            let k = pick(rng, 24);
            let column = table
                .column_at(k)
                .ok_or_else(|| Error::Message("ColorChecker table lacks a column".into()))?;
            (
                Colour::Bands(Box::new(bands_from_grid(column))),
                json!(table.names()[k]),
            )
        } else {
            let rgb = [0, 1, 2].map(|_| 0.02 + 0.88 * uniform(rng) as f32);
            (Colour::Rgb(rgb), json!(rgb.map(round3f)))
        };
        let m = b.material(format!("object{i}"), colour);
        let is_sphere = uniform(rng) < 0.5;
        let rotation = Quat::from_euler(
            glam::EulerRot::XYZ,
            uniform(rng) as f32 * std::f32::consts::TAU,
            uniform(rng) as f32 * std::f32::consts::TAU,
            uniform(rng) as f32 * std::f32::consts::TAU,
        );
        let geometry = if is_sphere {
            vec![Shape::Sphere(Sphere {
                centre,
                radius: size,
            })]
        } else {
            cube(&Mat4::from_scale_rotation_translation(
                Vec3::splat(size),
                rotation,
                centre,
            ))
        };
        b.shape(format!("object{i}"), geometry, m);
        shapes.push(json!({
            "kind": if is_sphere { "sphere" } else { "box" },
            "centre_m": round3(centre),
            "size_m": round3f(size),
            "colour": colour_name,
        }));
    }
    b.wall(-distance, distance, rng, record);
    record.insert("objects".into(), Value::Array(shapes));
    Ok(b.scene)
}

/// An image from `images` on a plane filling the view, tilted up to 25 degrees about each
/// axis: reflectance is the image's linear value times 0.9, averaged over `cells` cells
/// across the image's longer side (each cell a quad of its own material; the tracer has no
/// textures).
pub fn textured_plane(
    distance: f32,
    aspect: f32,
    images: &Path,
    cells: u32,
    rng: &mut Rng,
    record: &mut Map<String, Value>,
) -> Result<SceneDesc, Error> {
    let mut b = Builder::new("textured-plane", distance, rng, record)?;
    let files = image_files(images)?;
    if files.is_empty() {
        return Err(Error::Message(format!("no .png in {}", images.display())));
    }
    let file = &files[pick(rng, files.len())];
    let image = raw_formats::image::read(file)?;
    let (iw, ih) = (image.width, image.height);
    let (gw, gh) = if iw >= ih {
        (cells as usize, ((cells as usize * ih) / iw).max(1))
    } else {
        (((cells as usize * iw) / ih).max(1), cells as usize)
    };
    let max = ((1u32 << image.bits) - 1) as f32;
    let linear = |x: usize, y: usize| -> [f32; 3] {
        let i = (y * iw + x) * image.channels;
        let c = |k: usize| {
            isp_core::srgb::decode(image.data[i + k.min(image.channels - 1)] as f32 / max)
        };
        [c(0), c(1), c(2)]
    };
    let tilt_x = (uniform(rng) as f32 - 0.5) * 50f32.to_radians();
    let tilt_y = (uniform(rng) as f32 - 0.5) * 50f32.to_radians();
    let (half_w, half_h) = half_frame(distance, aspect);
    // Large enough to cover the view when tilted: 1.6 x the frame, at the image's aspect.
    let cover = 1.6 * half_w.max(half_h);
    let (pw, ph) = if iw as f32 / ih as f32 >= half_w / half_h {
        (cover * iw as f32 / ih as f32, cover)
    } else {
        (cover, cover * ih as f32 / iw as f32)
    };
    let to_world = Mat4::from_quat(Quat::from_euler(glam::EulerRot::XYZ, tilt_x, tilt_y, 0.0));
    for gy in 0..gh {
        for gx in 0..gw {
            let (x0, x1) = (gx * iw / gw, ((gx + 1) * iw / gw).max(gx * iw / gw + 1));
            let (y0, y1) = (gy * ih / gh, ((gy + 1) * ih / gh).max(gy * ih / gh + 1));
            let mut sum = [0.0f32; 3];
            for y in y0..y1.min(ih) {
                for x in x0..x1.min(iw) {
                    let p = linear(x, y);
                    for c in 0..3 {
                        sum[c] += p[c];
                    }
                }
            }
            let n = ((y1.min(ih) - y0) * (x1.min(iw) - x0)).max(1) as f32;
            let rgb = sum.map(|s| (0.9 * s / n).clamp(0.0, 0.9));
            let m = b.material(format!("cell{gx}_{gy}"), Colour::Rgb(rgb));
            let u0 = -pw + 2.0 * pw * gx as f32 / gw as f32;
            let u1 = -pw + 2.0 * pw * (gx + 1) as f32 / gw as f32;
            let v0 = ph - 2.0 * ph * gy as f32 / gh as f32;
            let v1 = ph - 2.0 * ph * (gy + 1) as f32 / gh as f32;
            let corners = [(u0, v1), (u1, v1), (u1, v0), (u0, v0)]
                .map(|(u, v)| to_world.transform_point3(Vec3::new(u, v, 0.0)));
            b.shape(format!("cell{gx}_{gy}"), quad(corners), m);
        }
    }
    let name = file
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    record.insert("image".into(), json!(name));
    record.insert("cells".into(), json!([gw, gh]));
    record.insert(
        "tilt_deg".into(),
        json!([round3f(tilt_x.to_degrees()), round3f(tilt_y.to_degrees())]),
    );
    Ok(b.scene)
}

/// The aperture called `name` ([`APERTURES`]).
pub fn aperture(name: &str) -> ApertureDesc {
    match APERTURES
        .iter()
        .find(|(n, _)| n.eq_ignore_ascii_case(name))
        .map_or(0, |(_, b)| *b)
    {
        0 => ApertureDesc::Disk,
        1 => ApertureDesc::Heart,
        blades => ApertureDesc::Polygon {
            blades,
            rotation: 0.0,
        },
    }
}

//! `camsim bench render`: what each optical feature costs the path tracer.
//!
//! One scene rendered again and again with one feature turned on at a time (and all together),
//! all in this process at the same size, samples, depth and thread count, so the samples per
//! second are comparable. Each variant's cost is its time per sample over the pinhole's. A
//! feature that is off must cost nothing: the variants that set a feature's parameter to its
//! "off" value (chromatic aberration 0, a shutter with nothing moving) sit beside the ones
//! that turn it on.

use glam::Vec3;

use crate::error::{Error, Result};
use crate::tracer::render::{render, RenderSettings};
use crate::tracer::scene::{ApertureDesc, Colour, SceneDesc, SensorSize};

/// Sizes and repeats of one benchmark run.
#[derive(Debug, Clone, PartialEq)]
pub struct BenchSettings {
    /// Image width and height.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Samples per pixel of each render.
    pub spp: u32,
    /// Seed of every render.
    pub seed: u64,
    /// Worker threads (0: one per core).
    pub threads: usize,
    /// Renders per variant; the fastest counts (the others absorb warm-up and interference).
    pub repeats: u32,
    /// Aperture radius of the thin-lens variants, in scene units.
    pub aperture_radius: f32,
}

/// One variant's figures (serialised as they are for `camsim bench render --json`).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct FeatureRow {
    /// Short name of the variant.
    pub variant: &'static str,
    /// What the variant changes in the scene and what the renderer does for it per sample.
    pub what: &'static str,
    /// Camera samples per second (million), best of the repeats.
    pub msamples_per_s: f64,
    /// Time per sample relative to the pinhole variant.
    pub relative_time: f64,
    /// Mean linear RGB of the image (a check that the feature did something).
    pub mean_rgb: [f64; 3],
}

type Edit = fn(&mut SceneDesc, &BenchSettings);

fn thin_lens(scene: &mut SceneDesc, b: &BenchSettings) {
    scene.camera.aperture_radius_mm = b.aperture_radius / scene.camera.units_per_mm;
}

fn hexagon(scene: &mut SceneDesc, b: &BenchSettings) {
    thin_lens(scene, b);
    scene.camera.aperture = ApertureDesc::Polygon {
        blades: 6,
        rotation: 0.0,
    };
}

fn chromatic_off(scene: &mut SceneDesc, b: &BenchSettings) {
    thin_lens(scene, b);
    scene.camera.chromatic_aberration = 0.0;
}

fn chromatic(scene: &mut SceneDesc, b: &BenchSettings) {
    thin_lens(scene, b);
    scene.camera.chromatic_aberration = 0.15;
}

fn shutter_still(scene: &mut SceneDesc, _: &BenchSettings) {
    scene.camera.shutter = (0.0, 1.0 / 60.0);
}

fn camera_motion(scene: &mut SceneDesc, _: &BenchSettings) {
    let c = &scene.camera;
    let shift = (c.target - c.position).length() * 0.02 * Vec3::X;
    scene.camera.end = Some((c.position + shift, c.target + shift));
}

fn object_motion(scene: &mut SceneDesc, _: &BenchSettings) {
    // The last shape (the Cornell box's tall box) slides sideways by a tenth of its size.
    if let Some(shape) = scene.shapes.iter_mut().rev().find(|s| s.emission.is_none()) {
        let (lo, hi) =
            shape
                .geometry
                .iter()
                .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), g| {
                    let (a, b) = g.bounds();
                    (lo.min(a), hi.max(b))
                });
        shape.motion = Vec3::X * 0.1 * (hi - lo).max_element();
    }
}

fn spectral(scene: &mut SceneDesc, _: &BenchSettings) {
    let bands = |c: &mut Colour| {
        if let Colour::Rgb(rgb) = c {
            *c = Colour::Bands(Box::new(crate::tracer::color::bands_from_rgb(*rgb)));
        }
    };
    scene.materials.iter_mut().for_each(|(_, c)| bands(c));
    for shape in &mut scene.shapes {
        if let Some(e) = shape.emission.as_mut() {
            bands(e);
        }
    }
    if let Some(e) = scene.environment.as_mut() {
        bands(e);
    }
}

fn distortion(scene: &mut SceneDesc, _: &BenchSettings) {
    scene.camera.distortion = Some([-0.2, 0.05, 0.0, 0.0, 0.0]);
}

fn everything(scene: &mut SceneDesc, b: &BenchSettings) {
    hexagon(scene, b);
    scene.camera.chromatic_aberration = 0.15;
    camera_motion(scene, b);
    object_motion(scene, b);
    spectral(scene, b);
    distortion(scene, b);
}

const VARIANTS: [(&str, &str, Edit); 11] = [
    (
        "pinhole",
        "no lens, no motion, RGB: the cheap path every other row is measured against",
        |_, _| {},
    ),
    (
        "shutter, nothing moves",
        "a 1/60 s shutter with a still scene: no time sample is drawn, so no cost",
        shutter_still,
    ),
    (
        "thin lens",
        "disk aperture: one 2D lens sample and the ray through the focus plane",
        thin_lens,
    ),
    (
        "thin lens, hexagon",
        "6-blade polygon aperture instead of the disk",
        hexagon,
    ),
    (
        "thin lens, CA 0",
        "chromatic aberration strength 0 (off): must cost what the thin lens costs",
        chromatic_off,
    ),
    (
        "thin lens, CA 0.15",
        "three shifted apertures: a channel choice and two more aperture densities",
        chromatic,
    ),
    (
        "camera motion",
        "the camera slides 2% of the subject distance over the shutter: a time sample and a pose",
        camera_motion,
    ),
    (
        "object motion",
        "one box moves: a time sample, swept bounds in the BVH, a shifted ray at its leaves",
        object_motion,
    ),
    (
        "spectral",
        "every colour as 31 bands (400-700 nm): 31 channels per path instead of 3",
        spectral,
    ),
    (
        "distortion",
        "Brown-Conrady k1 -0.2, k2 0.05: an undistortion (f64 Newton) per camera sample",
        distortion,
    ),
    (
        "everything",
        "hexagonal thin lens, CA, camera and object motion, spectral and distortion together",
        everything,
    ),
];

/// Renders `scene` once per variant (each `repeats` times) and reports each one's speed and
/// its time per sample relative to the pinhole. `progress` hears each variant's name.
pub fn bench(
    scene: &SceneDesc,
    settings: &BenchSettings,
    progress: &mut dyn FnMut(&str),
) -> Result<Vec<FeatureRow>> {
    if settings.repeats == 0 {
        return Err(Error::out_of_range("--repeats", 0, "at least 1"));
    }
    if !(settings.aperture_radius.is_finite() && settings.aperture_radius > 0.0) {
        return Err(Error::out_of_range(
            "--aperture-radius",
            settings.aperture_radius,
            "> 0",
        ));
    }
    // The base: the scene with every feature off.
    let mut base = scene.clone();
    base.camera.aperture_radius_mm = 0.0;
    base.camera.aperture = ApertureDesc::Disk;
    base.camera.chromatic_aberration = 0.0;
    base.camera.end = None;
    base.camera.distortion = None;
    base.shapes.iter_mut().for_each(|s| s.motion = Vec3::ZERO);
    if base.is_spectral() {
        return Err(Error::out_of_range(
            format!("scene {:?}", scene.name),
            "spectral colours",
            "an RGB scene (the pinhole baseline renders RGB)",
        ));
    }
    let mut rows: Vec<FeatureRow> = Vec::new();
    for (variant, what, edit) in VARIANTS {
        progress(variant);
        let mut desc = base.clone();
        edit(&mut desc, settings);
        let mut render_settings = RenderSettings::for_scene(&desc);
        render_settings.width = settings.width;
        render_settings.height = settings.height;
        render_settings.spp = settings.spp;
        render_settings.threads = settings.threads;
        render_settings.seed = settings.seed;
        let mut best = 0.0f64;
        let mut mean_rgb = [0.0f64; 3];
        for _ in 0..settings.repeats {
            let image = render(&desc, &render_settings)?;
            best = best.max(image.samples_per_second());
            mean_rgb = [0, 1, 2].map(|c| {
                image
                    .rgb
                    .iter()
                    .skip(c)
                    .step_by(3)
                    .map(|&v| v as f64)
                    .sum::<f64>()
                    / (image.rgb.len() / 3).max(1) as f64
            });
        }
        let baseline = rows.first().map_or(best, |r| r.msamples_per_s * 1e6);
        rows.push(FeatureRow {
            variant,
            what,
            msamples_per_s: best / 1e6,
            relative_time: baseline / best,
            mean_rgb,
        });
    }
    Ok(rows)
}

/// One lens's figures beside a thin lens of the same focal length, f-number and framing
/// (serialised as they are for `camsim bench render --lens ... --json`).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct LensRow {
    /// The lens's name.
    pub lens: String,
    /// Its focal length, mm, and the f-number rendered at (its widest).
    pub efl_mm: f64,
    /// The f-number.
    pub f_number: f64,
    /// The half field of view framed (the lens file's `field_deg`, else the scene's), degrees.
    pub half_field_deg: f64,
    /// Camera samples per second (million) through the lens, best of the repeats.
    pub lens_msamples_per_s: f64,
    /// The same through the thin lens.
    pub thin_msamples_per_s: f64,
    /// Time per sample through the lens over the thin lens's.
    pub relative_time: f64,
    /// The share of camera samples the lens stopped (vignetting, and the exit pupil's bounds
    /// being a rectangle round a round pupil).
    pub vignetted_fraction: f64,
    /// The render's noise: RMS difference of two seeds' images over `sqrt 2`, relative to the
    /// mean, through the lens (in tone-mapped values `x / (1 + x)`, so the few pixels that see
    /// a light do not decide it).
    pub lens_noise: f64,
    /// The same through the thin lens.
    pub thin_noise: f64,
    /// The lens's noise at the thin lens's render time, over the thin lens's: noise falls as
    /// the square root of time, so this is `lens_noise / thin_noise * sqrt(relative_time)`.
    pub noise_at_equal_time: f64,
}

/// Renders `scene` through each lens of `lenses` and through a thin lens of the same focal
/// length, f-number (the lens's widest) and framing (the lens file's half field across the
/// image diagonal, else the scene's), each twice (two seeds, for the noise) and `repeats`
/// times (for the speed). `progress` hears each lens's name.
pub fn bench_lenses(
    scene: &SceneDesc,
    lenses: &[crate::lens_file::LensFile],
    settings: &BenchSettings,
    progress: &mut dyn FnMut(&str),
) -> Result<Vec<LensRow>> {
    if settings.repeats == 0 {
        return Err(Error::out_of_range("--repeats", 0, "at least 1"));
    }
    let mut rows = Vec::new();
    for file in lenses {
        progress(&file.name);
        let mut thin = scene.clone();
        let diagonal_px = f64::from(settings.width).hypot(f64::from(settings.height));
        let mut lensed = scene.clone();
        let f_number = lensed.camera.use_lens(file.clone())?;
        let efl = f64::from(lensed.camera.focal_length_mm);
        let half_field_deg = match file.field_deg {
            Some(f) => f,
            None => {
                let s = lensed.camera.sensor_mm(settings.width, settings.height);
                (f64::from(s.length()) / 2.0 / efl).atan().to_degrees()
            }
        };
        let width_mm =
            2.0 * efl * half_field_deg.to_radians().tan() * f64::from(settings.width) / diagonal_px;
        lensed.camera.sensor = SensorSize::WidthMm(width_mm as f32);
        thin.camera.sensor = lensed.camera.sensor;
        thin.camera.focal_length_mm = lensed.camera.focal_length_mm;
        thin.camera.aperture_radius_mm = lensed.camera.aperture_radius_mm;
        thin.camera.aperture = ApertureDesc::Disk;
        thin.camera.chromatic_aberration = 0.0;
        thin.camera.distortion = None;
        let run = |desc: &SceneDesc| -> Result<(f64, f64, f64)> {
            let mut rs = RenderSettings::for_scene(desc);
            rs.width = settings.width;
            rs.height = settings.height;
            rs.spp = settings.spp;
            rs.threads = settings.threads;
            rs.seed = settings.seed;
            let mut best = 0.0f64;
            let mut first = None;
            for _ in 0..settings.repeats {
                let image = render(desc, &rs)?;
                best = best.max(image.samples_per_second());
                first.get_or_insert(image);
            }
            let a = first.ok_or_else(|| Error::out_of_range("--repeats", 0, "at least 1"))?;
            rs.seed = settings.seed.wrapping_add(1);
            let b = render(desc, &rs)?;
            // In tone-mapped values (x / (1 + x)), so a few pixels that see the light do not
            // decide the figure.
            let tone = |v: f32| f64::from(v) / (1.0 + f64::from(v));
            let mean = a.rgb.iter().map(|&v| tone(v)).sum::<f64>() / a.rgb.len() as f64;
            let diff2 = a
                .rgb
                .iter()
                .zip(&b.rgb)
                .map(|(&x, &y)| (tone(x) - tone(y)).powi(2))
                .sum::<f64>()
                / a.rgb.len() as f64;
            let noise = (diff2 / 2.0).sqrt() / mean.max(1e-12);
            let lost = a.lost_samples as f64 / a.samples.max(1) as f64;
            Ok((best, noise, lost))
        };
        let (thin_speed, thin_noise, _) = run(&thin)?;
        let (lens_speed, lens_noise, lost) = run(&lensed)?;
        let relative_time = thin_speed / lens_speed;
        rows.push(LensRow {
            lens: file.name.clone(),
            efl_mm: efl,
            f_number,
            half_field_deg,
            lens_msamples_per_s: lens_speed / 1e6,
            thin_msamples_per_s: thin_speed / 1e6,
            relative_time,
            vignetted_fraction: lost,
            lens_noise,
            thin_noise,
            noise_at_equal_time: lens_noise / thin_noise * relative_time.sqrt(),
        });
    }
    Ok(rows)
}

/// The lens rows as a table.
pub fn lens_table(rows: &[LensRow]) -> String {
    let mut out = format!(
        "{:<38} {:>8} {:>6} {:>6} {:>11} {:>11} {:>7} {:>10} {:>12}\n",
        "lens (thin lens alike)",
        "EFL mm",
        "f/",
        "field",
        "lens Ms/s",
        "thin Ms/s",
        "time x",
        "vignetted",
        "noise equal t"
    );
    for r in rows {
        out.push_str(&format!(
            "{:<38} {:>8.2} {:>6.2} {:>6.1} {:>11.3} {:>11.3} {:>7.2} {:>9.1}% {:>12.2}\n",
            r.lens,
            r.efl_mm,
            r.f_number,
            r.half_field_deg,
            r.lens_msamples_per_s,
            r.thin_msamples_per_s,
            r.relative_time,
            100.0 * r.vignetted_fraction,
            r.noise_at_equal_time
        ));
    }
    out
}

/// The rows as a table.
pub fn table(rows: &[FeatureRow], scene: &str, settings: &BenchSettings) -> String {
    let mut out = format!(
        "scene {scene}, {} x {}, {} spp, {} thread(s), best of {}\n{:<24} {:>10} {:>10}  {}\n",
        settings.width,
        settings.height,
        settings.spp,
        if settings.threads == 0 {
            "all".to_string()
        } else {
            settings.threads.to_string()
        },
        settings.repeats,
        "variant",
        "Msamples/s",
        "time x",
        "what it adds"
    );
    for r in rows {
        out.push_str(&format!(
            "{:<24} {:>10.3} {:>10.2}  {}\n",
            r.variant, r.msamples_per_s, r.relative_time, r.what
        ));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_variant_renders_and_changes_what_it_should() {
        let scene = crate::tracer::scene_file::load("cornell-box").unwrap();
        let settings = BenchSettings {
            width: 16,
            height: 16,
            spp: 2,
            seed: 0,
            threads: 1,
            repeats: 1,
            aperture_radius: 0.1,
        };
        let mut seen = Vec::new();
        let rows = bench(&scene, &settings, &mut |v| seen.push(v.to_string())).unwrap();
        assert_eq!(rows.len(), VARIANTS.len());
        assert_eq!(seen.len(), VARIANTS.len());
        assert_eq!(rows[0].relative_time, 1.0);
        for r in &rows {
            assert!(r.msamples_per_s > 0.0 && r.relative_time > 0.0, "{r:?}");
            assert!(
                r.mean_rgb.iter().all(|v| v.is_finite() && *v > 0.0),
                "{r:?}"
            );
        }
        // A still scene with a shutter renders exactly the pinhole image (no time sample).
        assert_eq!(rows[1].mean_rgb, rows[0].mean_rgb);
        // Chromatic aberration 0 is exactly the thin lens.
        assert_eq!(rows[4].mean_rgb, rows[2].mean_rgb);
        // Turning a feature on changes the picture.
        for k in [2, 5, 6, 7, 8, 9, 10] {
            assert_ne!(rows[k].mean_rgb, rows[0].mean_rgb, "{}", rows[k].variant);
        }
        let text = table(&rows, "cornell-box", &settings);
        assert!(text.contains("everything") && text.contains("time x"));
    }

    #[test]
    fn lenses_bench_beside_their_thin_lens() {
        let scene = crate::tracer::scene_file::load("cornell-box").unwrap();
        let settings = BenchSettings {
            width: 24,
            height: 24,
            spp: 4,
            seed: 0,
            threads: 1,
            repeats: 1,
            aperture_radius: 0.1,
        };
        let tessar = crate::lens_file::LensFile::from_toml(include_str!(
            "../../camsim/lenses/tessar-f4.5.toml"
        ))
        .unwrap();
        let rows = bench_lenses(&scene, &[tessar], &settings, &mut |_| {}).unwrap();
        let r = &rows[0];
        assert!(
            (r.efl_mm - 101.54).abs() < 0.01 && (r.f_number - 4.5).abs() < 0.01,
            "{r:?}"
        );
        assert!(r.lens_msamples_per_s > 0.0 && r.thin_msamples_per_s > 0.0);
        assert!(
            r.vignetted_fraction > 0.0 && r.vignetted_fraction < 0.9,
            "{r:?}"
        );
        assert!(r.lens_noise > 0.0 && r.thin_noise > 0.0 && r.noise_at_equal_time.is_finite());
        assert!(lens_table(&rows).contains("Tessar"));
    }

    #[test]
    fn bad_settings_are_refused() {
        let scene = crate::tracer::scene_file::load("cornell-box").unwrap();
        let mut settings = BenchSettings {
            width: 8,
            height: 8,
            spp: 1,
            seed: 0,
            threads: 1,
            repeats: 0,
            aperture_radius: 0.1,
        };
        assert!(bench(&scene, &settings, &mut |_| {})
            .unwrap_err()
            .to_string()
            .contains("--repeats"));
        settings.repeats = 1;
        settings.aperture_radius = f32::NAN;
        assert!(bench(&scene, &settings, &mut |_| {})
            .unwrap_err()
            .to_string()
            .contains("--aperture-radius"));
        settings.aperture_radius = 0.1;
        settings.spp = 0;
        assert!(bench(&scene, &settings, &mut |_| {})
            .unwrap_err()
            .to_string()
            .contains("spp"));
    }
}

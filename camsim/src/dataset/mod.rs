//! `camsim dataset`: synthetic raw datasets, one sample per index, each a pure function of
//! (spec, dataset seed, index).
//!
//! A sample is the scene a generator draws (or a built-in scene), rendered, captured through
//! the sensor model with the drawn camera and sensor parameters, and written into its own
//! folder `OUT/NNNNNN/`:
//!
//! | file | what |
//! |---|---|
//! | `raw.dng` | the raw CFA frame, with colour calibration, AsShotNeutral and NoiseProfile |
//! | `truth_camera.exr` | the truth in linear camera RGB (no noise, shading or defects) |
//! | `truth_srgb.exr` | the truth in linear sRGB on the ISP's output scale, as `camsim demo` |
//! | `srgb.png` | the ISP's output (float path, the demo's defaults), when the spec asks |
//! | `record.json` | every drawn parameter, what the sensor did, and each file's size and hash |
//!
//! Every draw comes from its own random stream, keyed by the dataset seed, the index and the
//! parameter's name, so a sample does not depend on which other samples run, in what order,
//! on how many threads (the renderer's pixels have their own streams) or in which process.
//! A sample is written into a temporary folder and renamed into place, and a folder with a
//! `record.json` is complete: an index already done is skipped, and two workers given the
//! same index leave one copy. The spec is copied to `OUT/spec.toml`; a folder holding
//! another spec's samples is refused.
//!
//! Bytes are the same on any machine running the same build; across builds or platforms the
//! render's floating point may differ in the last bits (the system's `libm`).

mod manifest;
mod scenes;
mod spec;

use std::path::{Path, PathBuf};
use std::time::Instant;

use host_tracer::random::Rng;
use host_tracer::sensor::{DefectConfig, SensorConfig, ShadingConfig};
use host_tracer::tracer::scene::SceneDesc;
use host_tracer::tracer::scene_file;
use raw_formats::{exr, FormatError, Image};
use serde_json::{json, Map, Value};

use crate::demo::{self, DemoSettings, SensorPreset};
use crate::develop;
use crate::error::Error;

pub use manifest::{index_manifest, ManifestReport};
pub use scenes::{image_files, APERTURES};
pub use spec::{Draw, Spec, CAMERA_KEYS, GENERATORS, SENSOR_KEYS};

/// The folder of sample `index` (six digits at least).
pub fn sample_dir(out: &Path, index: u64) -> PathBuf {
    out.join(format!("{index:06}"))
}

/// What became of one index.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Outcome {
    /// Written now, with where its time went.
    Written(Timings),
    /// Already complete (by an earlier run or another worker): nothing written.
    Present,
}

/// Seconds spent on one sample, by step.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
pub struct Timings {
    /// Scene generation and the render (with its BVH).
    pub render_s: f64,
    /// The sensor model, calibration and white balance.
    pub sensor_s: f64,
    /// The ISP (0 unless the spec asks for `srgb.png`).
    pub isp_s: f64,
    /// Encoding, hashing and writing the files.
    pub write_s: f64,
    /// All of it.
    pub total_s: f64,
}

/// Indices to generate: `--index`, `--range`, `--shard`, or all.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Selection {
    /// One index.
    Index(u64),
    /// `start..end`, end excluded.
    Range(u64, u64),
    /// Shard `k` of `n` (0-based): every index `i` with `i % n == k`.
    Shard(u64, u64),
    /// `0..count`.
    All,
}

impl Selection {
    /// The indices this selects of a dataset of `count`, checked against it.
    pub fn indices(self, count: u64) -> Result<Vec<u64>, Error> {
        let bad = |option: &'static str, value: String, allowed: String| Error::Option {
            option,
            value,
            allowed,
        };
        Ok(match self {
            Selection::Index(i) if i < count => vec![i],
            Selection::Index(i) => {
                return Err(bad(
                    "--index",
                    i.to_string(),
                    format!("below the spec's count, {count}"),
                ))
            }
            Selection::Range(a, b) if a <= b && b <= count => (a..b).collect(),
            Selection::Range(a, b) => {
                return Err(bad(
                    "--range",
                    format!("{a}..{b}"),
                    format!("A..B with A <= B <= the spec's count, {count}"),
                ))
            }
            Selection::Shard(k, n) if n >= 1 && k < n => (k..count).step_by(n as usize).collect(),
            Selection::Shard(k, n) => {
                return Err(bad(
                    "--shard",
                    format!("{k}/{n}"),
                    "K/N with 0 <= K < N".into(),
                ))
            }
            Selection::All => (0..count).collect(),
        })
    }
}

/// The random stream of parameter `name` for sample `index`.
fn stream(seed: u64, index: u64, name: &str) -> Rng {
    Rng::new(seed ^ fnv1a(name.as_bytes()), index)
}

/// FNV-1a, 64 bits: names to stream keys, and the files' checksums in the records.
pub(crate) fn fnv1a(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    h
}

/// Writes `bytes` to `path` through a temporary name in the same folder, renamed into place.
fn write_atomically(path: &Path, bytes: &[u8]) -> Result<(), Error> {
    let tmp = path.with_extension(format!("tmp-{}", std::process::id()));
    std::fs::write(&tmp, bytes).map_err(|e| FormatError::io(&tmp, e))?;
    std::fs::rename(&tmp, path).map_err(|e| FormatError::io(path, e))?;
    Ok(())
}

/// Makes `out` a folder for `spec`'s samples: creates it and copies the spec to
/// `spec.toml`, or checks that the copy there is this spec.
pub fn prepare_out(spec: &Spec, out: &Path) -> Result<(), Error> {
    std::fs::create_dir_all(out).map_err(|e| FormatError::io(out, e))?;
    keep_one(out, "spec.toml", Some(&spec.text), "spec")?;
    // The tuning, if any, is part of what the samples are: one per folder too.
    let tuning = match &spec.tuning {
        Some(path) => Some(std::fs::read_to_string(path).map_err(|e| FormatError::io(path, e))?),
        None => None,
    };
    keep_one(out, "tuning.toml", tuning.as_deref(), "tuning")
}

/// Writes `text` to `out/name` (`None`: the file must not exist), or checks that what is
/// there is the same: a folder holds the samples of one spec and one tuning.
fn keep_one(out: &Path, name: &str, text: Option<&str>, what: &str) -> Result<(), Error> {
    let copy = out.join(name);
    let refuse = || {
        Error::Message(format!(
            "{} holds samples of another {what} ({} differs): give another --out",
            out.display(),
            copy.display()
        ))
    };
    match (std::fs::read_to_string(&copy), text) {
        (Ok(there), Some(text)) if there == text => Ok(()),
        (Ok(_), _) => Err(refuse()),
        (Err(e), None) if e.kind() == std::io::ErrorKind::NotFound => Ok(()),
        (Err(e), Some(text)) if e.kind() == std::io::ErrorKind::NotFound => {
            write_atomically(&copy, text.as_bytes())?;
            // Two workers may both have written it; what is there must be this one.
            match std::fs::read_to_string(&copy) {
                Ok(there) if there == text => Ok(()),
                _ => Err(Error::Message(format!(
                    "{} was written by another {what} at the same time",
                    copy.display()
                ))),
            }
        }
        (Err(e), _) => Err(FormatError::io(&copy, e).into()),
    }
}

/// The parameters drawn for one sample.
struct Drawn {
    record: Map<String, Value>,
    scene: SceneDesc,
    spectral_illuminant: String,
    config: SensorConfig,
    noise: SensorPreset,
    render_seed: u64,
}

/// Draws sample `index`'s scene and parameters.
fn draw(spec: &Spec, index: u64) -> Result<Drawn, Error> {
    let seed = spec.seed;
    let mut record = Map::new();
    let number = |key: &str, default: f64| -> f64 {
        spec.param(key)
            .map_or(default, |d| d.number(&mut stream(seed, index, key)))
    };
    let text = |key: &str, default: &str| -> String {
        spec.param(key).map_or(default.to_owned(), |d| {
            d.text(&mut stream(seed, index, key))
        })
    };

    // The scene.
    let generator = spec.scene.text(&mut stream(seed, index, "scene"));
    let aspect = spec.width as f32 / spec.height as f32;
    let distance = spec.subject_distance_m.as_ref().map_or(1.2, |d| {
        d.number(&mut stream(seed, index, "subject_distance_m"))
    }) as f32;
    let mut scene_record = Map::new();
    scene_record.insert("generator".into(), json!(generator));
    let mut rng = stream(seed, index, "scene-layout");
    let generated = GENERATORS.contains(&generator.as_str());
    let mut scene = match generator.as_str() {
        "colorchecker" => scenes::colorchecker(distance, aspect, &mut rng, &mut scene_record)?,
        "slanted-edge" => scenes::slanted_edge(distance, aspect, &mut rng, &mut scene_record)?,
        "checkerboard" => scenes::checkerboard(distance, aspect, &mut rng, &mut scene_record)?,
        "primitives" => {
            let objects = spec
                .objects
                .number(&mut stream(seed, index, "objects"))
                .round() as u32;
            scenes::primitives(
                distance,
                aspect,
                objects.max(1),
                &mut rng,
                &mut scene_record,
            )?
        }
        "textured-plane" => {
            let folder = spec.images.as_deref().ok_or_else(|| {
                Error::Message(
                    "dataset spec: scene.images: the textured-plane generator needs a folder"
                        .into(),
                )
            })?;
            scenes::textured_plane(
                distance,
                aspect,
                folder,
                spec.texture_cells,
                &mut rng,
                &mut scene_record,
            )?
        }
        name => {
            let built_in = scene_file::BUILT_IN.iter().any(|(n, _)| *n == name);
            let path = if built_in {
                name.to_owned()
            } else {
                spec.dir.join(name).display().to_string()
            };
            scene_file::load(&path)?
        }
    };
    if generated {
        scene_record.insert("subject_distance_m".into(), json!(distance as f64));
    }
    scene.max_depth = spec.max_depth.unwrap_or(scene.max_depth);
    record.insert("scene".into(), Value::Object(scene_record));

    // The lens: the generated scenes take every parameter (with defaults); a scene file keeps
    // its own camera where the spec says nothing.
    let mut lens = Map::new();
    let cam = &mut scene.camera;
    let given = |key: &str| generated || spec.param(key).is_some();
    if given("focal_length_mm") {
        cam.focal_length_mm = number("focal_length_mm", 50.0) as f32;
    }
    if given("f_number") {
        let n = number("f_number", 8.0);
        cam.aperture_radius_mm = if n > 0.0 {
            (cam.focal_length_mm as f64 / (2.0 * n)) as f32
        } else {
            0.0
        };
        lens.insert("f_number".into(), json!(n));
    }
    if given("focus_ratio") {
        let ratio = number("focus_ratio", 1.0);
        let subject = (cam.target - cam.position).length();
        cam.focus_distance = Some(subject * ratio as f32);
        lens.insert("focus_ratio".into(), json!(ratio));
    }
    if given("aperture") {
        let name = text("aperture", "disk");
        cam.aperture = scenes::aperture(&name);
        lens.insert("aperture".into(), json!(name.to_ascii_lowercase()));
    }
    if given("chromatic_aberration") {
        let ca = number("chromatic_aberration", 0.0);
        cam.chromatic_aberration = ca as f32;
        lens.insert("chromatic_aberration".into(), json!(ca));
    }
    if given("distortion_k1") {
        let k1 = number("distortion_k1", 0.0);
        cam.distortion = (k1 != 0.0).then_some([k1, 0.0, 0.0, 0.0, 0.0]);
        lens.insert("distortion_k1".into(), json!(k1));
    }
    if given("motion_blur_px") {
        let px = number("motion_blur_px", 0.0);
        let angle = 2.0
            * std::f64::consts::PI
            * spec::uniform(&mut stream(seed, index, "motion-direction"));
        if px > 0.0 {
            // A pan that moves the image by `px` pixels over the shutter: the target moves
            // across the view at its distance by px / width of the frame's width there.
            let forward = (cam.target - cam.position).normalize();
            let right = forward.cross(cam.up).normalize();
            let up = right.cross(forward);
            let subject = (cam.target - cam.position).length();
            let sensor = cam.sensor_mm(spec.width, spec.height);
            let frame_width = subject * sensor.x / cam.focal_length_mm;
            let shift = frame_width * px as f32 / spec.width as f32;
            let dir = right * angle.cos() as f32 + up * angle.sin() as f32;
            cam.end = Some((cam.position, cam.target + dir * shift));
        } else {
            cam.end = None;
        }
        lens.insert("motion_blur_px".into(), json!(px));
        lens.insert("motion_direction_deg".into(), json!(angle.to_degrees()));
    }
    lens.insert("focal_length_mm".into(), json!(cam.focal_length_mm as f64));
    record.insert("lens".into(), Value::Object(lens));

    // The sensor.
    let noise = match text("noise", "realistic").to_ascii_lowercase().as_str() {
        "ideal" => SensorPreset::Ideal,
        _ => SensorPreset::Realistic,
    };
    let mut config = match noise {
        SensorPreset::Realistic => SensorConfig::realistic(),
        SensorPreset::Ideal => SensorConfig::ideal(),
    };
    config.camera = text("camera", "nikon-5100");
    let illuminant = text("illuminant", "D65");
    config.iso = number("iso", 100.0);
    config.exposure_s = spec
        .param("exposure_s")
        .map(|d| d.number(&mut stream(seed, index, "exposure_s")));
    let pattern = text("pattern", "RGGB").to_ascii_uppercase();
    config.pattern = pattern
        .parse()
        .map_err(|_| Error::Message(format!("dataset spec: unknown pattern {pattern}")))?;
    config.adc_bits = number("bits", 12.0) as u8;
    let shading = number("shading", 1.0);
    let realistic = SensorConfig::realistic();
    config.shading = if shading > 0.0 {
        ShadingConfig {
            cos4: true,
            colour: realistic.shading.colour.map(|c| c * shading),
        }
    } else {
        ShadingConfig::default()
    };
    let per_million = match (spec.param("defects_per_million"), noise) {
        (Some(d), _) => d.number(&mut stream(seed, index, "defects_per_million")),
        (None, SensorPreset::Realistic) => 170.0,
        (None, SensorPreset::Ideal) => 0.0,
    };
    config.defects = DefectConfig {
        hot_per_million: per_million * 10.0 / 17.0,
        dead_per_million: per_million * 5.0 / 17.0,
        stuck_per_million: per_million * 2.0 / 17.0,
    };
    let mut seeds = stream(seed, index, "seeds");
    let mut next = || u64::from(seeds.next_u32()) << 32 | u64::from(seeds.next_u32());
    let render_seed = next();
    config.seed = next();
    config.frame_seed = next();
    record.insert(
        "sensor".into(),
        json!({
            "camera": config.camera,
            "illuminant": illuminant,
            "iso": config.iso,
            "exposure_metered": config.exposure_s.is_none(),
            "noise": noise.name(),
            "shading": shading,
            "defects_per_million": per_million,
            "pattern": pattern,
            "bits": config.adc_bits,
            "fixed_pattern_seed": config.seed,
            "frame_seed": config.frame_seed,
        }),
    );
    Ok(Drawn {
        record,
        scene,
        spectral_illuminant: illuminant,
        config,
        noise,
        render_seed,
    })
}

/// Generates sample `index` of `spec` into `out` (see the module docs), with `threads`
/// render threads (0: every core). `out` must have been prepared ([`prepare_out`]).
pub fn generate(spec: &Spec, out: &Path, index: u64, threads: usize) -> Result<Outcome, Error> {
    // Refused as `--index` refuses it.
    Selection::Index(index).indices(spec.count)?;
    let dir = sample_dir(out, index);
    if dir.join("record.json").is_file() {
        return Ok(Outcome::Present);
    }
    let start = Instant::now();
    let drawn = draw(spec, index)?;
    let Drawn {
        mut record,
        scene,
        spectral_illuminant,
        config,
        noise,
        render_seed,
    } = drawn;
    let spectral = scene.is_spectral();
    if !spectral {
        // An RGB scene keeps its own lights (`render.illuminant` says what they are): the
        // drawn illuminant was not used, so the record does not claim it.
        if let Some(sensor) = record.get_mut("sensor").and_then(Value::as_object_mut) {
            sensor.insert("illuminant".into(), Value::Null);
        }
    }
    let settings = DemoSettings {
        scene: scene.name.clone(),
        output: out.to_path_buf(),
        camera: config.camera.clone(),
        sensor: noise,
        // An RGB scene is lit by its own lights (an illuminant is a spectrum).
        illuminant: spectral.then(|| spectral_illuminant.clone()),
        width: Some(spec.width),
        height: Some(spec.height),
        spp: Some(spec.spp),
        threads,
        seed: render_seed,
        iso: config.iso,
        exposure: config.exposure_s,
        bits: config.adc_bits,
        pattern: config.pattern,
        tuning: spec.tuning.clone(),
        ..DemoSettings::default()
    };
    let drawn_s = start.elapsed().as_secs_f64();
    let captured = demo::capture_scene(scene, &settings, &config, &|_| {})?;
    // The render with the scene's generation; the sensor with calibration, white balance and
    // the truth.
    let render_s = drawn_s + captured.render_s;
    let sensor_s = (start.elapsed().as_secs_f64() - render_s).max(0.0);
    let (w, h) = (captured.width(), captured.height());
    let capture = &captured.capture;

    // The ISP's output, if asked: the demo's configuration on the float path.
    let isp_start = Instant::now();
    // A frame the ISP cannot develop (its colour matrix out of isp-core's range) is still a
    // raw with its truth: written without `srgb.png`, the record saying why.
    let developed = if spec.isp && captured.ccm.is_ok() {
        let denoise = captured.default_denoise();
        let config = captured.isp_config(
            develop::DEFAULT_METHOD,
            denoise,
            develop::default_chroma_denoise(denoise),
        )?;
        let raw = capture.raw.frame()?;
        let (_, image) = develop::execute(
            raw.into(),
            &config,
            false,
            8,
            develop::RunOptions::default(),
        )?;
        Some(Image { bits: 8, ..image })
    } else {
        None
    };
    let isp_s = if spec.isp {
        isp_start.elapsed().as_secs_f64()
    } else {
        0.0
    };

    // Files, into a temporary folder renamed into place.
    let write_start = Instant::now();
    let tmp = out.join(format!(
        ".partial-{index:06}-{}-{}",
        std::process::id(),
        std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos())
    ));
    std::fs::create_dir_all(&tmp).map_err(|e| FormatError::io(&tmp, e))?;
    let written = (|| -> Result<(), Error> {
        let dng = captured.dng();
        dng.write(&tmp.join("raw.dng"))?;
        exr::write_rgb(&tmp.join("truth_camera.exr"), w, h, &capture.truth_camera)?;
        exr::write_rgb(&tmp.join("truth_srgb.exr"), w, h, &captured.truth_linear)?;
        let mut names = vec!["raw.dng", "truth_camera.exr", "truth_srgb.exr"];
        if let Some(image) = &developed {
            raw_formats::image::write(&tmp.join("srgb.png"), image)?;
            names.push("srgb.png");
        }
        let mut files = Map::new();
        for name in names {
            let path = tmp.join(name);
            let bytes = std::fs::read(&path).map_err(|e| FormatError::io(&path, e))?;
            files.insert(
                name.into(),
                json!({ "bytes": bytes.len(), "fnv1a64": format!("{:016x}", fnv1a(&bytes)) }),
            );
        }
        record.insert("index".into(), json!(index));
        record.insert("dataset_seed".into(), json!(spec.seed));
        record.insert("camsim_version".into(), json!(env!("CARGO_PKG_VERSION")));
        record.insert(
            "render".into(),
            json!({
                "width": w,
                "height": h,
                "spp": captured.spp,
                "seed": render_seed,
                "spectral": captured.spectral,
                "illuminant": captured.illuminant,
            }),
        );
        let raw = &capture.raw;
        record.insert(
            "capture".into(),
            json!({
                "exposure_s": capture.exposure_s,
                "black_level": raw.black_level,
                "white_level": raw.white_level,
                "noise_profile": develop::Noise::File(capture.noise_profile).to_json(),
                "defects": captured.defects.len(),
                "as_shot_neutral": captured.awb.neutral,
                "awb_angular_error_deg": captured.awb_angular_error_deg,
                "ccm": captured.ccm.ok(),
            }),
        );
        if let Some((_, cct)) = &captured.tuning {
            record.insert(
                "tuning".into(),
                json!({ "file": "tuning.toml", "cct_k": cct }),
            );
        }
        if let Err(e) = captured.ccm {
            let why = Error::in_stage("colour matrix", e).to_string();
            record.insert("isp_refused".into(), json!(why));
        }
        record.insert("files".into(), Value::Object(files));
        let text = serde_json::to_string_pretty(&Value::Object(record.clone()))
            .map_err(|e| Error::Message(e.to_string()))?
            + "\n";
        let path = tmp.join("record.json");
        std::fs::write(&path, text).map_err(|e| FormatError::io(&path, e))?;
        Ok(())
    })();
    if let Err(e) = written {
        let _ = std::fs::remove_dir_all(&tmp);
        return Err(e);
    }
    if let Err(e) = std::fs::rename(&tmp, &dir) {
        let _ = std::fs::remove_dir_all(&tmp);
        // Another worker finished this index first: its copy is the same sample.
        if dir.join("record.json").is_file() {
            return Ok(Outcome::Present);
        }
        return Err(FormatError::io(&dir, e).into());
    }
    let write_s = write_start.elapsed().as_secs_f64();
    Ok(Outcome::Written(Timings {
        render_s,
        sensor_s,
        isp_s,
        write_s,
        total_s: start.elapsed().as_secs_f64(),
    }))
}

//! `camsim demo` and `camsim calibrate`: the whole camera in one command.
//!
//! `camsim demo` renders a scene (the built-in `demo` by default), captures it through the
//! sensor model, writes the raw DNG, reads it back and runs the ISP on it (float and fixed
//! path), and writes into one folder:
//!
//! | file | what |
//! |---|---|
//! | `raw.dng` | the raw CFA frame with its colour calibration and as-shot white balance |
//! | `raw.png` | the same mosaic as a 16-bit PNG, for tools that want plain files |
//! | `srgb.png`, `srgb_fixed.png` | the ISP's output, float reference and fixed-point path |
//! | `truth.png` | the ground truth encoded to sRGB (noise-free, no shading, no defects) |
//! | `truth_srgb.exr`, `truth_camera.exr` | the ground truth, linear sRGB and linear camera RGB |
//! | `comparison.png` | truth, float ISP and fixed ISP side by side |
//! | `report.json`, `report.txt` | times, PSNR, ColorChecker CIE 2000 error, AWB error, CCT |
//!
//! The truth is scaled to the ISP's output: the scene's linear sRGB times the factor that makes
//! a neutral under the scene illuminant come out of a perfect ISP at the same level.

use std::path::PathBuf;
use std::time::Instant;

use clap::Args;
use isp_core::ccm::Calibration;
use isp_core::colour::{self, Mat3};
use isp_core::dpc::{Defect, DpcConfig};
use isp_core::frame::RawFrame;
use isp_core::lsc::LensShading;
use isp_core::pipeline::IspConfig;
use isp_core::wb;
use isp_core::CfaPattern;

use crate::calibrate::{self, CalibrationFile};
use crate::dng::{Dng, Illuminant};
use crate::exr;
use crate::imageio::{self, Image};
use crate::isp_cmd::{self, neutral_cct};
use crate::sensor::{self, LensGeometry, Response, SensorConfig};
use crate::tracer::render::{render, RenderSettings};
use crate::tracer::scene::SceneDesc;
use crate::tracer::scene_file;

/// Options of `camsim demo`.
#[derive(Args, Debug, Clone)]
pub struct DemoArgs {
    /// Scene: a built-in name (demo, cornell-box) or a TOML file.
    #[arg(long, default_value = "demo")]
    pub scene: String,
    /// Output folder (created if missing).
    #[arg(long, default_value = "camsim-demo")]
    pub output: PathBuf,
    /// Camera response: nikon-5100, canon-eos-5d-mark-ii, sigma-sdmerill or cie1931.
    #[arg(long, default_value = "nikon-5100")]
    pub camera: String,
    /// Sensor preset: realistic (noise, shading, defects on) or ideal (all off).
    #[arg(long, default_value = "realistic")]
    pub sensor: String,
    /// The scene's illuminant (for the truth's scale and the AWB error): A, D50, D65, FL2, ...
    #[arg(long, default_value = "D65")]
    pub illuminant: String,
    /// Calibration file from `camsim calibrate` [default: calibrate under A and D65 now].
    #[arg(long)]
    pub calibration: Option<PathBuf>,
    /// Image width [default: the scene's].
    #[arg(long)]
    pub width: Option<u32>,
    /// Image height [default: the scene's].
    #[arg(long)]
    pub height: Option<u32>,
    /// Samples per pixel [default: the scene's].
    #[arg(long)]
    pub spp: Option<u32>,
    /// Render threads; 0 uses every core.
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// Seed of the render and the sensor's noise.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// ISO (analog gain; 100 is the base).
    #[arg(long, default_value_t = 100.0)]
    pub iso: f64,
    /// Exposure time in seconds [default: automatic].
    #[arg(long)]
    pub exposure: Option<f64>,
    /// ADC bits, 8..=16.
    #[arg(long, default_value_t = 12)]
    pub bits: u8,
    /// CFA pattern: RGGB, BGGR, GRBG or GBRG.
    #[arg(long, default_value = "RGGB")]
    pub pattern: String,
    /// AWB method: grey-world, white-patch, shades-of-grey or grey-edge.
    #[arg(long, default_value = "white-patch")]
    pub awb: String,
    /// Demosaicing: nearest, bilinear or mhc.
    #[arg(long, default_value = "mhc")]
    pub demosaic: String,
    /// Print the JSON report instead of the readable one.
    #[arg(long)]
    pub json: bool,
}

/// Options of `camsim calibrate`.
#[derive(Args, Debug, Clone)]
pub struct CalibrateArgs {
    /// Camera: nikon-5100, canon-eos-5d-mark-ii, sigma-sdmerill or cie1931.
    #[arg(long, default_value = "nikon-5100")]
    pub camera: String,
    /// Illuminant(s), comma-separated, at most two (the DNG's ColorMatrix1/2): A, D50, D65, ...
    #[arg(long, default_value = "A,D65")]
    pub illuminant: String,
    /// Where to write the calibration (TOML) [default: CAMERA-calibration.toml].
    #[arg(long)]
    pub output: Option<PathBuf>,
}

/// Runs `camsim calibrate`; returns the report.
pub fn run_calibrate(args: &CalibrateArgs) -> Result<String, String> {
    let illuminants: Vec<&str> = args.illuminant.split(',').map(str::trim).collect();
    if illuminants.is_empty() || illuminants.len() > 2 {
        return Err(format!(
            "--illuminant: give one or two illuminants, comma-separated (got {:?})",
            args.illuminant
        ));
    }
    let mut results = Vec::new();
    let mut text = String::new();
    for name in &illuminants {
        let c = calibrate::calibrate(&args.camera, name)?;
        text += &calibrate::report_text(&args.camera, &c);
        results.push(c);
    }
    if results.len() == 2 && (results[0].cct_k - results[1].cct_k).abs() < 1.0 {
        return Err("--illuminant: the two illuminants must differ in colour temperature".into());
    }
    let out = args
        .output
        .clone()
        .unwrap_or_else(|| PathBuf::from(format!("{}-calibration.toml", args.camera)));
    std::fs::write(&out, calibrate::to_toml(&args.camera, &results))
        .map_err(|e| format!("{}: {e}", out.display()))?;
    text += &format!(
        "wrote {} (use it with camsim isp --calibration or camsim demo --calibration)\n",
        out.display()
    );
    Ok(text)
}

/// The demo's measurements, as the JSON report holds them.
#[derive(Debug, Clone, serde::Serialize)]
pub struct DemoReport {
    /// Scene name.
    pub scene: String,
    /// Camera response.
    pub camera: String,
    /// Sensor preset.
    pub sensor: String,
    /// Width and height.
    pub width: usize,
    /// Height.
    pub height: usize,
    /// Samples per pixel.
    pub spp: u32,
    /// Render time, s.
    pub render_s: f64,
    /// Sensor simulation time, s.
    pub sensor_s: f64,
    /// Exposure time used, s.
    pub exposure_s: f64,
    /// ISP stage times (float path), ms, in pipeline order.
    pub isp_stage_ms: Vec<(String, f64)>,
    /// ISP stage times (fixed path), ms.
    pub isp_fixed_stage_ms: Vec<(String, f64)>,
    /// Whole ISP, float path, ms.
    pub isp_total_ms: f64,
    /// Whole ISP, fixed path, ms.
    pub isp_fixed_total_ms: f64,
    /// PSNR of the float ISP's 8-bit sRGB against the truth's, dB.
    pub psnr_db: f64,
    /// PSNR of the fixed ISP's output against the truth, dB.
    pub psnr_fixed_db: f64,
    /// Mean CIE 2000 error over the ColorChecker patches found in the frame (float ISP).
    pub delta_e_2000_mean: Option<f64>,
    /// Largest patch error.
    pub delta_e_2000_max: Option<f64>,
    /// Angle between the AWB's neutral and the true illuminant's, camera RGB, degrees.
    pub awb_angular_error_deg: f64,
    /// The AWB's correlated colour temperature, kelvin.
    pub cct_k: f64,
    /// Files written.
    pub files: Vec<String>,
}

fn step(n: usize, what: &str) {
    eprintln!("[{n}/6] {what}");
}

fn parse_pattern(text: &str) -> Result<CfaPattern, String> {
    crate::isp_options::pattern(text, "--pattern")
}

/// The calibration to use: from a file, or fitted now under A and D65.
fn calibration_for(args: &DemoArgs) -> Result<(Vec<(Illuminant, Mat3)>, Calibration), String> {
    let entries: Vec<(String, f64, Mat3)> = match &args.calibration {
        Some(path) => {
            let file = CalibrationFile::read(path)?;
            if file.camera != args.camera {
                return Err(format!(
                    "{}: calibrated for {}, but --camera is {}",
                    path.display(),
                    file.camera,
                    args.camera
                ));
            }
            file.entries
        }
        None => ["A", "D65"]
            .iter()
            .map(|i| {
                calibrate::calibrate(&args.camera, i)
                    .map(|c| (c.illuminant, c.cct_k, c.camera_to_xyz))
            })
            .collect::<Result<_, _>>()?,
    };
    let file = CalibrationFile {
        camera: args.camera.clone(),
        entries: entries.clone(),
    };
    let isp = file.to_isp()?;
    // DNG's ColorMatrix: XYZ to camera, scaled so the illuminant's white has a largest
    // camera channel of 1 (Adobe's convention).
    let mut dng = Vec::new();
    for (name, _, m) in &entries {
        let illuminant = Illuminant::from_name(name).unwrap_or(Illuminant::Other(0));
        let xyz_to_camera = colour::mat3_inverse(m).map_err(|e| e.to_string())?;
        let white = calibrate::bands_xyz(&calibrate::illuminant_bands(name)?);
        let cam = colour::mat3_mul_vec(&xyz_to_camera, white);
        let peak = cam.iter().copied().fold(0.0, f64::max);
        let scaled = xyz_to_camera.map(|r| r.map(|v| v / peak.max(1e-12)));
        dng.push((illuminant, scaled));
    }
    Ok((dng, isp))
}

fn psnr_u8(a: &[u16], b: &[u16]) -> f64 {
    let mse = a
        .iter()
        .zip(b)
        .map(|(x, y)| {
            let d = *x as f64 - *y as f64;
            d * d
        })
        .sum::<f64>()
        / a.len().max(1) as f64;
    10.0 * (255.0 * 255.0 / mse.max(1e-12)).log10()
}

/// Centres of the ColorChecker patches (materials `patch01`..`patch24`) in pixels, projected
/// through the scene's camera (the chief ray: a pinhole at the lens centre).
fn patch_centres(desc: &SceneDesc, width: usize, height: usize) -> Vec<(usize, [f64; 2])> {
    let cam = &desc.camera;
    let forward = (cam.target - cam.position).normalize();
    let right = forward.cross(cam.up).normalize();
    let up = right.cross(forward);
    let sensor = cam.sensor_mm(width as u32, height as u32);
    let f = cam.focal_length_mm;
    let mut out = Vec::new();
    for shape in &desc.shapes {
        let Some((name, _)) = desc.materials.get(shape.material) else {
            continue;
        };
        let Some(index) = name
            .strip_prefix("patch")
            .and_then(|n| n.parse::<usize>().ok())
            .filter(|n| (1..=24).contains(n))
        else {
            continue;
        };
        let (mut lo, mut hi) = (glam::Vec3::splat(f32::MAX), glam::Vec3::splat(f32::MIN));
        for g in &shape.geometry {
            let (a, b) = g.bounds();
            lo = lo.min(a);
            hi = hi.max(b);
        }
        let d = 0.5 * (lo + hi) - cam.position;
        let z = d.dot(forward);
        if z <= 0.0 {
            continue;
        }
        let x = width as f32 * (0.5 + d.dot(right) / z * f / sensor.x);
        let y = height as f32 * (0.5 - d.dot(up) / z * f / sensor.y);
        out.push((index - 1, [x as f64, y as f64]));
    }
    out
}

/// Mean linear sRGB over a box around `centre`, from 8-bit sRGB samples.
fn mean_linear(
    image: &[u16],
    width: usize,
    height: usize,
    centre: [f64; 2],
    half: usize,
) -> Option<[f64; 3]> {
    let (cx, cy) = (centre[0] as isize, centre[1] as isize);
    let half = half as isize;
    if cx - half < 0 || cy - half < 0 || cx + half >= width as isize || cy + half >= height as isize
    {
        return None;
    }
    let mut sum = [0.0f64; 3];
    let mut n = 0.0;
    for y in cy - half..=cy + half {
        for x in cx - half..=cx + half {
            let i = 3 * (y as usize * width + x as usize);
            for c in 0..3 {
                sum[c] += isp_core::srgb::decode(image[i + c] as f32 / 255.0) as f64;
            }
            n += 1.0;
        }
    }
    Some(sum.map(|v| v / n))
}

fn angle_deg(a: [f64; 3], b: [f64; 3]) -> f64 {
    let dot: f64 = (0..3).map(|i| a[i] * b[i]).sum();
    let na = a.iter().map(|v| v * v).sum::<f64>().sqrt();
    let nb = b.iter().map(|v| v * v).sum::<f64>().sqrt();
    (dot / (na * nb)).clamp(-1.0, 1.0).acos().to_degrees()
}

/// Runs `camsim demo`; returns the report (readable or JSON).
pub fn run(args: &DemoArgs) -> Result<String, String> {
    let started = Instant::now();
    let mut config = match args.sensor.as_str() {
        "realistic" => SensorConfig::realistic(),
        "ideal" => SensorConfig::ideal(),
        other => {
            return Err(format!(
                "--sensor: unknown preset {other:?}; expected realistic or ideal"
            ))
        }
    };
    config.camera = args.camera.clone();
    config.pattern = parse_pattern(&args.pattern)?;
    config.adc_bits = args.bits;
    config.iso = args.iso;
    config.exposure_s = args.exposure;
    config.frame_seed = args.seed;
    config.validate().map_err(|e| e.replace("sensor ", "--"))?;
    let awb_method = crate::isp_options::awb(&args.awb, "--awb")?;
    let demosaic = crate::isp_options::demosaic(&args.demosaic, "--demosaic")?;
    std::fs::create_dir_all(&args.output).map_err(|e| format!("{}: {e}", args.output.display()))?;
    let out = |name: &str| args.output.join(name);

    // 1. Render.
    let scene = scene_file::load(&args.scene)?;
    let mut settings = RenderSettings::for_scene(&scene);
    settings.width = args.width.unwrap_or(settings.width);
    settings.height = args.height.unwrap_or(settings.height);
    settings.spp = args.spp.unwrap_or(settings.spp);
    settings.threads = args.threads;
    settings.seed = args.seed;
    step(
        1,
        &format!(
            "rendering {} at {} x {}, {} spp",
            scene.name, settings.width, settings.height, settings.spp
        ),
    );
    let image = render(&scene, &settings)?;
    let (w, h) = (image.width as usize, image.height as usize);

    // 2. Sensor.
    step(
        2,
        &format!(
            "sensor: {} ({}), {}-bit ADC",
            args.camera, args.sensor, args.bits
        ),
    );
    let sensor_start = Instant::now();
    let response = Response::named(&args.camera)?;
    let spectral = !image.bands.is_empty();
    let camera_rgb = response.camera_rgb(&image.bands, &image.rgb);
    let lens = LensGeometry::of_camera(&scene.camera, image.width, image.height);
    let capture = sensor::capture(&camera_rgb, w, h, lens, &config)?;
    let sensor_s = sensor_start.elapsed().as_secs_f64();

    // 3. Calibration and white balance.
    step(3, "colour calibration and white balance");
    let (dng_matrices, calibration) = if spectral {
        calibration_for(args)?
    } else {
        // The RGB path: camera RGB is linear sRGB.
        let m = colour::LINEAR_SRGB_TO_XYZ;
        let inv = colour::mat3_inverse(&m).map_err(|e| e.to_string())?;
        (
            vec![(Illuminant::D65, inv)],
            Calibration::single(6504.0, m).map_err(|e| e.to_string())?,
        )
    };
    let black4 = [capture.black_level; 4];
    let raw_frame = RawFrame::new(
        &capture.raw,
        w,
        h,
        w,
        capture.bits,
        capture.pattern,
        black4,
        capture.white_level,
    )
    .map_err(|e| e.to_string())?;
    let to_xyz = calibration
        .camera_to_xyz(6504.0)
        .map_err(|e| e.to_string())?;
    let mut awb = wb::estimate(&raw_frame, awb_method, &to_xyz).map_err(|e| e.to_string())?;
    awb.cct_k = neutral_cct(&calibration, awb.neutral)?;
    let (_, true_neutral) = if spectral {
        calibrate::illuminant_colour(&args.illuminant, &response)?
    } else {
        ([0.0; 3], [1.0; 3])
    };
    let awb_angular_error_deg = angle_deg(awb.neutral.map(|v| v as f64), true_neutral);

    // 4. Files: DNG, plain mosaic, truth.
    step(4, "writing raw.dng, raw.png and the ground truth");
    let dng = Dng {
        width: w,
        height: h,
        pattern: capture.pattern,
        black_level: black4,
        white_level: capture.white_level,
        raw: capture.raw.clone(),
        camera_model: format!("camsim {}", response.name()),
        calibrations: dng_matrices,
        as_shot_neutral: Some(awb.neutral.map(|v| v as f64)),
    };
    dng.write(&out("raw.dng"))?;
    imageio::write(
        &out("raw.png"),
        &Image {
            width: w,
            height: h,
            channels: 1,
            bits: 16,
            data: capture.raw.clone(),
        },
    )?;
    // The truth's scale: a neutral under the scene illuminant with camera green g (in ISP
    // units) comes out of a perfect ISP with luminance g.
    let green_per_luminance = if spectral {
        let bands = calibrate::illuminant_bands(&args.illuminant)
            .map_err(|e| format!("--illuminant: {e}"))?;
        response.of_bands(&bands)[1] as f64 / calibrate::bands_xyz(&bands)[1]
    } else {
        1.0
    };
    let scale = (capture.units_per_radiance * green_per_luminance) as f32;
    let truth_linear: Vec<f32> = image.rgb.iter().map(|v| v * scale).collect();
    exr::write_rgb(&out("truth_srgb.exr"), w, h, &truth_linear)?;
    exr::write_rgb(&out("truth_camera.exr"), w, h, &capture.truth_camera)?;
    let truth8: Vec<u16> = truth_linear
        .iter()
        .map(|v| (isp_core::srgb::encode(v.clamp(0.0, 1.0)) * 255.0).round() as u16)
        .collect();

    // 5. ISP, read back from the DNG as `camsim isp` would.
    step(5, "ISP: float reference and fixed-point paths");
    let back = Dng::read(&out("raw.dng"))?;
    if back.raw != capture.raw {
        return Err("raw.dng did not read back the same samples".into());
    }
    let raw_back = RawFrame::new(
        &back.raw,
        w,
        h,
        w,
        capture.bits,
        back.pattern,
        back.black_level,
        back.white_level,
    )
    .map_err(|e| e.to_string())?;
    let gains = awb.gains;
    let ccm = calibration
        .ccm(awb.cct_k, gains)
        .map_err(|e| format!("colour matrix: {e}"))?;
    let defects: Vec<Defect> = capture
        .defects
        .iter()
        .map(|&(x, y, _)| Defect {
            x: x as u16,
            y: y as u16,
        })
        .collect();
    let grid = if capture.shading.is_active() {
        Some(capture.shading.correction_grid(17, 13, capture.pattern))
    } else {
        None
    };
    let noisy = config.noise != sensor::NoiseConfig::default();
    let isp_config = IspConfig {
        dpc: DpcConfig {
            static_defects: &defects,
            dynamic_threshold: None,
        },
        lsc: grid
            .as_ref()
            .map(|g| LensShading::new(17, 13, g))
            .transpose()
            .map_err(|e| e.to_string())?,
        wb_gains: gains,
        demosaic,
        denoise: if noisy { 0.01 } else { 0.0 },
        ccm,
        ..IspConfig::default()
    };
    let (float_report, float_rgb) = isp_cmd::execute(&raw_back, &isp_config, false, 8)?;
    let (fixed_report, fixed_rgb) = isp_cmd::execute(&raw_back, &isp_config, true, 8)?;
    let to8 = |img: &Image| Image {
        bits: 8,
        ..img.clone()
    };
    imageio::write(&out("srgb.png"), &to8(&float_rgb))?;
    imageio::write(&out("srgb_fixed.png"), &to8(&fixed_rgb))?;
    let truth_img = Image {
        width: w,
        height: h,
        channels: 3,
        bits: 8,
        data: truth8.clone(),
    };
    imageio::write(&out("truth.png"), &truth_img)?;
    let mut side = Vec::with_capacity(w * h * 9);
    for y in 0..h {
        for img in [&truth8, &float_rgb.data, &fixed_rgb.data] {
            side.extend_from_slice(&img[3 * w * y..3 * w * (y + 1)]);
        }
    }
    imageio::write(
        &out("comparison.png"),
        &Image {
            width: 3 * w,
            height: h,
            channels: 3,
            bits: 8,
            data: side,
        },
    )?;

    // 6. Measure.
    step(6, "measuring");
    let psnr_db = psnr_u8(&float_rgb.data, &truth8);
    let psnr_fixed_db = psnr_u8(&fixed_rgb.data, &truth8);
    let white = colour::xy_to_xyz(colour::D65_XY).map_err(|e| e.to_string())?;
    let mut errors = Vec::new();
    for (_, centre) in patch_centres(&scene, w, h) {
        let (Some(ours), Some(truth)) = (
            mean_linear(&float_rgb.data, w, h, centre, 6),
            mean_linear(&truth8, w, h, centre, 6),
        ) else {
            continue;
        };
        let lab = |rgb: [f64; 3]| {
            colour::xyz_to_lab(
                colour::mat3_mul_vec(&colour::LINEAR_SRGB_TO_XYZ, rgb),
                white,
            )
            .map_err(|e| e.to_string())
        };
        errors.push(colour::delta_e_2000(lab(ours)?, lab(truth)?));
    }
    let (delta_e_2000_mean, delta_e_2000_max) = if errors.is_empty() {
        (None, None)
    } else {
        let (m, x) = calibrate::mean_max(&errors);
        (Some(m), Some(x))
    };
    let names = [
        "raw.dng",
        "raw.png",
        "srgb.png",
        "srgb_fixed.png",
        "truth.png",
        "truth_srgb.exr",
        "truth_camera.exr",
        "comparison.png",
        "report.json",
        "report.txt",
    ];
    let report = DemoReport {
        scene: scene.name.clone(),
        camera: response.name().to_owned(),
        sensor: args.sensor.clone(),
        width: w,
        height: h,
        spp: settings.spp,
        render_s: (image.elapsed + image.prepare).as_secs_f64(),
        sensor_s,
        exposure_s: capture.exposure_s,
        isp_stage_ms: float_report
            .stage_ms
            .iter()
            .map(|(n, ms)| (n.to_string(), *ms))
            .collect(),
        isp_fixed_stage_ms: fixed_report
            .stage_ms
            .iter()
            .map(|(n, ms)| (n.to_string(), *ms))
            .collect(),
        isp_total_ms: float_report.total_ms,
        isp_fixed_total_ms: fixed_report.total_ms,
        psnr_db,
        psnr_fixed_db,
        delta_e_2000_mean,
        delta_e_2000_max,
        awb_angular_error_deg,
        cct_k: awb.cct_k,
        files: names.iter().map(|n| out(n).display().to_string()).collect(),
    };
    let json = report_json(&report);
    let text = report_text(
        &report,
        started.elapsed().as_secs_f64(),
        &float_report.stages,
    );
    std::fs::write(out("report.json"), &json).map_err(|e| e.to_string())?;
    std::fs::write(out("report.txt"), &text).map_err(|e| e.to_string())?;
    Ok(if args.json { json } else { text })
}

fn report_json(r: &DemoReport) -> String {
    let stages = |v: &[(String, f64)]| {
        serde_json::Value::Object(
            v.iter()
                .map(|(n, ms)| (n.clone(), serde_json::json!(ms)))
                .collect(),
        )
    };
    let value = serde_json::json!({
        "scene": r.scene,
        "camera": r.camera,
        "sensor": r.sensor,
        "width": r.width,
        "height": r.height,
        "spp": r.spp,
        "render_s": r.render_s,
        "sensor_s": r.sensor_s,
        "exposure_s": r.exposure_s,
        "isp_stage_ms": stages(&r.isp_stage_ms),
        "isp_fixed_stage_ms": stages(&r.isp_fixed_stage_ms),
        "isp_total_ms": r.isp_total_ms,
        "isp_fixed_total_ms": r.isp_fixed_total_ms,
        "psnr_db": r.psnr_db,
        "psnr_fixed_db": r.psnr_fixed_db,
        "delta_e_2000_mean": r.delta_e_2000_mean,
        "delta_e_2000_max": r.delta_e_2000_max,
        "awb_angular_error_deg": r.awb_angular_error_deg,
        "cct_k": r.cct_k,
        "files": r.files,
    });
    serde_json::to_string_pretty(&value).unwrap_or_default() + "\n"
}

fn report_text(r: &DemoReport, total_s: f64, stages: &[&str]) -> String {
    let mut t = format!(
        "camsim demo: {} through a simulated {} ({} sensor), {} x {}, {} spp\n",
        r.scene, r.camera, r.sensor, r.width, r.height, r.spp
    );
    t += &format!(
        "  render            {:8.2} s\n  sensor            {:8.2} s (exposure {:.4} s)\n  ISP float / fixed {:8.1} / {:.1} ms\n",
        r.render_s, r.sensor_s, r.exposure_s, r.isp_total_ms, r.isp_fixed_total_ms
    );
    t += &format!("  ISP stages: {}\n", stages.join(" -> "));
    for (name, ms) in &r.isp_stage_ms {
        t += &format!("    {name:<28} {ms:>8.2} ms\n");
    }
    t += &format!(
        "  PSNR against the truth: float {:.2} dB, fixed {:.2} dB\n",
        r.psnr_db, r.psnr_fixed_db
    );
    match (r.delta_e_2000_mean, r.delta_e_2000_max) {
        (Some(m), Some(x)) => {
            t += &format!("  ColorChecker CIE 2000 error: mean {m:.2}, max {x:.2}\n")
        }
        _ => t += "  ColorChecker: not in this scene\n",
    }
    t += &format!(
        "  AWB: estimated {:.0} K, {:.2} degrees from the true illuminant\n",
        r.cct_k, r.awb_angular_error_deg
    );
    t += &format!("  total {total_s:.1} s; files:\n");
    for f in &r.files {
        t += &format!("    {f}\n");
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn angles() {
        assert!(angle_deg([1.0, 0.0, 0.0], [0.0, 1.0, 0.0]) - 90.0 < 1e-9);
        assert!(angle_deg([1.0, 1.0, 1.0], [2.0, 2.0, 2.0]).abs() < 1e-6);
    }

    #[test]
    fn method_names_parse() {
        let _: isp_core::wb::AwbMethod = crate::isp_options::awb("grey-world", "--awb").unwrap();
        let _: isp_core::demosaic::Method =
            crate::isp_options::demosaic("mhc", "--demosaic").unwrap();
    }
}

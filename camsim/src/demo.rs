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
//! | `corrected.png`, `lens_comparison.png` | with `--lens`: the float development with the corrections derived from the lens's prescription ([`lens_corrections`]), and beside `srgb.png` |
//! | `report.json`, `report.txt` | times, PSNR, ColorChecker CIE 2000 error, AWB error, CCT |
//!
//! The truth is scaled to the ISP's output: the scene's linear sRGB times the factor that makes
//! a neutral under the scene illuminant come out of a perfect ISP at the same level. Its 8-bit
//! encoding (`truth.png`, the one PSNR is measured against) renders colours brighter than white
//! as the ISP's highlight stage intends, faded to white (a light above white has no recorded
//! colour); the EXR files keep the scene's values.
//!
//! This is library code: it reports each step through a callback and returns the report; the
//! command line prints.

use std::path::PathBuf;
use std::time::Instant;

use host_tracer::calibrate;
use host_tracer::sensor::{self, LensGeometry, Response, SensorConfig};
use host_tracer::spectra::{bands_xyz, illuminant_bands};
use host_tracer::tracer::render::{render_with_progress, RenderProgress, RenderSettings, Rendered};
use host_tracer::tracer::scene::SceneDesc;
use host_tracer::tracer::scene_file;
use isp_core::ccm::Calibration;
use isp_core::colour;
use isp_core::demosaic::Method;
use isp_core::dpc::{Defect, DpcConfig};
use isp_core::lens_correction::{
    DistortionFit, IlluminationTable, LensCorrectionError, LensCorrections, SensorFraming,
    RENDER_COLOURS_NM,
};
use isp_core::lsc::LensShading;
use isp_core::metrics::{angular_error_deg, mean_max, psnr};
use isp_core::pipeline::IspConfig;
use isp_core::wb::{self, AwbMethod};
use raw_formats::calibration::{CalibrationEntry, CalibrationFile};
use raw_formats::dng::{ColourCalibration, Dng, DngColour, Illuminant};
use raw_formats::{exr, Image};

use crate::develop;
use crate::error::Error;

/// Which sensor preset the demo simulates.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SensorPreset {
    /// [`SensorConfig::realistic`]: noise, shading and defects on.
    Realistic,
    /// [`SensorConfig::ideal`]: all off.
    Ideal,
}

impl SensorPreset {
    /// The name the command line and the report use.
    pub fn name(self) -> &'static str {
        match self {
            SensorPreset::Realistic => "realistic",
            SensorPreset::Ideal => "ideal",
        }
    }
}

/// What `camsim demo` runs; [`DemoSettings::default`] is its defaults.
#[derive(Debug, Clone, PartialEq)]
pub struct DemoSettings {
    /// Scene: a built-in name (demo, cornell-box) or a TOML file.
    pub scene: String,
    /// Output folder (created if missing).
    pub output: PathBuf,
    /// Camera response: nikon-5100, canon-eos-5d-mark-ii, sigma-sdmerill or cie1931.
    pub camera: String,
    /// Sensor preset.
    pub sensor: SensorPreset,
    /// The illuminant the scene is lit by (A, D50, D65, FL2, FL11, LED-B3): the lights of the
    /// scene illuminant take its spectrum ([`SceneDesc::relight`]); `None`: the scene's own
    /// (D65 for an RGB scene, whose lights are linear sRGB).
    pub illuminant: Option<String>,
    /// Calibration file from `camsim calibrate`; `None`: calibrate under A and D65 now.
    pub calibration: Option<PathBuf>,
    /// Tuning file from `camsim tune`: the frame is calibrated, white-balanced (through the
    /// locus) and developed with it, and `raw.dng` carries it ([`crate::tune::carry_in_dng`]);
    /// `None`: the sensor's factory calibration and the AWB.
    pub tuning: Option<PathBuf>,
    /// Image width; `None`: the scene's.
    pub width: Option<u32>,
    /// Image height; `None`: the scene's.
    pub height: Option<u32>,
    /// Samples per pixel; `None`: the scene's.
    pub spp: Option<u32>,
    /// Render threads; 0 uses every core.
    pub threads: usize,
    /// Seed of the render and the sensor's noise.
    pub seed: u64,
    /// ISO (analog gain; 100 is the base).
    pub iso: f64,
    /// Exposure time in seconds; `None`: automatic.
    pub exposure: Option<f64>,
    /// ADC bits, 8..=16.
    pub bits: u8,
    /// CFA pattern.
    pub pattern: isp_core::CfaPattern,
    /// AWB method.
    pub awb: AwbMethod,
    /// Demosaicing method (one the pipeline runs).
    pub demosaic: Method,
    /// Noise reduction's strength (a multiplier on the profile's default); `None`: 1 where the
    /// sensor is noisy, else 0.
    pub denoise: Option<f32>,
    /// Chroma noise reduction's strength; `None`: 1 where noise reduction is on, else 0.
    pub chroma_denoise: Option<f32>,
    /// A lens file to render through instead of the scene's thin lens
    /// ([`host_tracer::tracer::scene::CameraDesc::use_lens`]).
    pub lens: Option<PathBuf>,
}

impl Default for DemoSettings {
    fn default() -> Self {
        Self {
            scene: "demo".into(),
            output: "camsim-demo".into(),
            camera: "nikon-5100".into(),
            sensor: SensorPreset::Realistic,
            illuminant: None,
            calibration: None,
            tuning: None,
            width: None,
            height: None,
            spp: None,
            threads: 0,
            seed: 1,
            iso: 100.0,
            exposure: None,
            bits: 12,
            pattern: isp_core::CfaPattern::Rggb,
            awb: AwbMethod::WhitePatch { percentile: 99.0 },
            demosaic: develop::DEFAULT_METHOD,
            denoise: None,
            lens: None,
            chroma_denoise: None,
        }
    }
}

/// Where the demo is, for progress reports.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum DemoProgress<'a> {
    /// Step `n` of [`DemoProgress::STEPS`] starts, doing `what`.
    Step {
        /// 1-based.
        n: usize,
        /// What it does.
        what: &'a str,
    },
    /// The render (step 1) has finished this much.
    Render(RenderProgress),
}

impl DemoProgress<'_> {
    /// Steps in all.
    pub const STEPS: usize = 6;
}

/// The demo's measurements, serialised as `report.json` holds them.
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
    /// The real lens rendered through (name and f-number), if any.
    pub lens: Option<(String, f64)>,
    /// The share of camera samples the lens stopped (vignetting).
    pub vignetted_fraction: f64,
    /// The corrections derived from the real lens's prescription (`corrected.png` is developed
    /// with them), if the scene renders through one.
    pub lens_correction: Option<LensCorrectionReport>,
    /// Sensor simulation time, s.
    pub sensor_s: f64,
    /// Exposure time used, s.
    pub exposure_s: f64,
    /// ISO the sensor ran at.
    pub iso: f64,
    /// Whether the exposure was metered (no `--exposure`): it then falls as ISO rises.
    pub exposure_metered: bool,
    /// ISP stage times (float path), ms, in pipeline order (a JSON object).
    #[serde(serialize_with = "stage_map")]
    pub isp_stage_ms: Vec<(String, f64)>,
    /// ISP stage times (fixed path), ms.
    #[serde(serialize_with = "stage_map")]
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
    /// The illuminant the scene was lit by.
    pub illuminant: String,
    /// Angle between the AWB's neutral and the true illuminant's, camera RGB, degrees.
    pub awb_angular_error_deg: f64,
    /// Why the AWB is off, where the scene's brightest surface is not neutral: its name, its
    /// colour against the light and its angle from neutral (degrees); `None` when it is
    /// within a degree of neutral or the AWB within two of the light.
    pub awb_reason: Option<AwbReason>,
    /// The AWB's correlated colour temperature, kelvin.
    pub cct_k: f64,
    /// The tuning file the frame was calibrated and developed with (`--tuning`), if any.
    pub tuning: Option<String>,
    /// The sensor's noise profile as raw.dng states it: `source`, `scale` and `offset` per
    /// colour (`var = S x + O`, `x` a fraction of white above black).
    pub noise_profile: serde_json::Value,
    /// Files written.
    pub files: Vec<String>,
}

/// What `camsim demo --lens` derived from the lens's prescription and developed
/// `corrected.png` with ([`lens_corrections`]).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct LensCorrectionReport {
    /// The focal length the distortion model goes with, mm.
    pub focal_length_mm: f64,
    /// OpenCV's radial coefficients `[k1, k2, k3]` (camera matrix `fx = fy = focal length /
    /// pitch`, the centre at the frame's).
    pub k: [f64; 3],
    /// Red's and blue's largest scale against green (lateral colour), as `[red, blue]`.
    pub lateral_colour_scale: [f64; 2],
    /// The largest gain of the lens's shading grid (its vignetting at the corners).
    pub shading_max_gain: f64,
    /// Deriving them, ms.
    pub derive_ms: f64,
}

/// What [`lens_corrections`] derives for a real lens: the stages' own types and the report.
#[derive(Debug, Clone)]
pub struct DerivedLensCorrections {
    /// The distortion mesh with the lateral colour composed in, its focal length and
    /// coefficients.
    pub corrections: LensCorrections,
    /// The lens's own shading grid (Q4.12, RGGB-block layout of [`LensShading`]), to
    /// multiply with the sensor's.
    pub shading_gains: Vec<u16>,
    /// What the demo's report says of them.
    pub report: LensCorrectionReport,
}

/// The ISP's corrections for the real lens a scene renders through, derived from its
/// prescription as rendered (stopped down, focused) on a `width` x `height` frame with the
/// CFA `pattern`: the distortion mesh with the lateral colour composed in (a Brown-Conrady
/// fit to where each field's light lands on the film, 33 x 33 pupil points a field, fitted
/// out to 1.4 times the corner's field) and the lens's shading grid (`grid` nodes, Q4.12, from
/// relative illumination over a 64 x 64 rear-element grid at 49 radii a colour). The
/// channels are taken at the renderer's RGB wavelengths
/// ([`isp_core::lens_correction::RENDER_COLOURS_NM`]). `None` for a thin lens.
pub fn lens_corrections(
    scene: &SceneDesc,
    width: usize,
    height: usize,
    pattern: isp_core::CfaPattern,
    grid: (usize, usize),
) -> Result<Option<DerivedLensCorrections>, Error> {
    let started = Instant::now();
    let Some(rendered) = scene.camera.lens_as_rendered(width as u32, height as u32)? else {
        return Ok(None);
    };
    let fail = |e: LensCorrectionError| {
        Error::Message(format!(
            "deriving the corrections for {}: {e}",
            rendered.name
        ))
    };
    let lens = optics_core::prescription::Prescription::new(&rendered.surfaces)
        .map_err(|e| fail(e.into()))?;
    let framing =
        SensorFraming::new(width, height, rendered.pitch_mm, rendered.film_mm).map_err(fail)?;
    let efl = lens
        .paraxial(RENDER_COLOURS_NM[1])
        .map_err(|e| fail(e.into()))?
        .efl;
    let max_field = (1.4 * framing.corner_mm() / efl).atan().min(1.4);
    let fix = LensCorrections::derive(
        &lens,
        &framing,
        max_field,
        DistortionFit::Centroids { pupil_points: 33 },
    )
    .map_err(fail)?;
    let mut scratch = rendered.surfaces.clone();
    let table: IlluminationTable =
        IlluminationTable::derive(&lens, &framing, 64, &mut scratch).map_err(fail)?;
    let mut gains = vec![0u16; grid.0 * grid.1 * 4];
    table
        .fill_grid(&framing, pattern.block(), &mut gains, grid.0, grid.1)
        .map_err(fail)?;
    let lca = fix.distortion.lateral_colour();
    let mut scale = [1.0f64; 2];
    if let Some(lca) = lca {
        for k in 0..isp_core::lateral_colour::NODES {
            for (c, s) in scale.iter_mut().enumerate() {
                let v = lca.node_scale(c, k).unwrap_or(1.0);
                if (v - 1.0).abs() > (*s - 1.0).abs() {
                    *s = v;
                }
            }
        }
    }
    let shading_max_gain = gains
        .iter()
        .map(|&g| f64::from(g) / 4096.0)
        .fold(1.0, f64::max);
    let report = LensCorrectionReport {
        focal_length_mm: fix.focal_length_mm,
        k: fix.k,
        lateral_colour_scale: scale,
        shading_max_gain,
        derive_ms: started.elapsed().as_secs_f64() * 1e3,
    };
    Ok(Some(DerivedLensCorrections {
        corrections: fix,
        shading_gains: gains,
        report,
    }))
}

fn stage_map<S: serde::Serializer>(stages: &[(String, f64)], s: S) -> Result<S::Ok, S::Error> {
    s.collect_map(stages.iter().map(|(name, ms)| (name, ms)))
}

/// The scene's brightest surface, when it is why the AWB lands off (see
/// [`DemoReport::awb_reason`]).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct AwbReason {
    /// The surface's material.
    pub surface: String,
    /// Its camera RGB over the light's, green 1.
    pub rgb: [f64; 3],
    /// Its angle from neutral, degrees.
    pub angle_deg: f64,
}

/// The scene's brightest diffuse surface under its light, as the white balance sees it: its
/// name, its camera RGB over the light's (green 1) and that colour's angle from neutral. A
/// white-patch or grey estimate takes the brightest surfaces for white, so it lands about
/// that far off where they are not neutral (the Cornell box's white paint is warm). `None`
/// without a known light or surface.
fn brightest_surface(
    scene: &SceneDesc,
    response: &Response,
    illuminant: &str,
    light: Option<([f64; 3], [f64; 3])>,
    spectral: bool,
) -> Option<(String, [f64; 3], f64)> {
    use host_tracer::tracer::scene::Colour;
    let (_, light_rgb) = light?;
    let bands = if spectral {
        Some(illuminant_bands(illuminant).ok()?)
    } else {
        None
    };
    let luminance = |c: [f64; 3]| 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
    let mut best: Option<(String, [f64; 3])> = None;
    for (name, colour) in &scene.materials {
        let relative = match (colour, &bands) {
            // Camera RGB is linear sRGB on the RGB path, and the light's colour divides out.
            (Colour::Rgb(rgb), _) => rgb.map(f64::from),
            (Colour::Bands(reflectance), Some(light_bands)) => {
                let lit: Vec<f32> = reflectance
                    .iter()
                    .zip(light_bands.iter())
                    .map(|(r, e)| r * e)
                    .collect();
                let camera = response.of_bands(&lit);
                std::array::from_fn(|c| f64::from(camera[c]) / light_rgb[c])
            }
            (Colour::Bands(_), None) => continue,
        };
        if best
            .as_ref()
            .is_none_or(|(_, b)| luminance(relative) > luminance(*b))
        {
            best = Some((name.clone(), relative));
        }
    }
    let (name, rgb) = best?;
    // Also refuses NaN.
    if rgb[1].partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return None;
    }
    let rgb = rgb.map(|v| v / rgb[1]);
    Some((name, rgb, angular_error_deg(rgb, [1.0; 3])))
}

/// The render of `scene` seen by a camera of spectral `response` through the sensor model
/// (`config`), with the scene camera's lens for vignetting: the raw frame and what the sensor
/// knows of it.
pub fn expose(
    scene: &SceneDesc,
    image: &Rendered,
    response: &Response,
    config: &SensorConfig,
) -> Result<sensor::Capture, Error> {
    let camera_rgb = response.camera_rgb(&image.bands, &image.rgb);
    let (focal_mm, aperture_mm, sensor_mm) = scene.camera.lens_mm(image.width, image.height);
    let lens = LensGeometry::thin_lens(focal_mm, aperture_mm, sensor_mm);
    let (w, h) = (image.width as usize, image.height as usize);
    Ok(sensor::capture(&camera_rgb, w, h, lens, config)?)
}

/// The calibration to use, from a file or fitted now under A and D65: the DNG's colour tags
/// and isp-core's calibration.
///
/// The fit under A and D65 renders and fits a chart twice; it depends only on the camera, so
/// it is kept for the process's life (a dataset calibrates each camera once).
pub(crate) fn calibration_for(
    camera: &str,
    calibration: Option<&std::path::Path>,
) -> Result<(DngColour, Calibration), Error> {
    static FITTED: std::sync::Mutex<Vec<(String, DngColour, Calibration)>> =
        std::sync::Mutex::new(Vec::new());
    let fitted = |camera: &str| {
        let cache = FITTED.lock().unwrap_or_else(|e| e.into_inner());
        cache
            .iter()
            .find(|(c, ..)| c == camera)
            .map(|(_, d, c)| (d.clone(), *c))
    };
    if calibration.is_none() {
        if let Some(found) = fitted(camera) {
            return Ok(found);
        }
    }
    let file = match calibration {
        Some(path) => {
            let file = CalibrationFile::read(path)?;
            if file.camera != camera {
                return Err(Error::Option {
                    option: "--calibration",
                    value: format!("{} (calibrated for {})", path.display(), file.camera),
                    allowed: format!("a calibration of --camera {camera}"),
                });
            }
            file
        }
        None => CalibrationFile {
            camera: camera.to_owned(),
            entries: ["A", "D65"]
                .iter()
                .map(|i| {
                    calibrate::calibrate(camera, i).map(|c| CalibrationEntry {
                        illuminant: c.illuminant,
                        cct_k: c.cct_k,
                        camera_to_xyz: c.camera_to_xyz,
                        delta_e_2000_mean: None,
                        delta_e_2000_max: None,
                    })
                })
                .collect::<Result<_, _>>()?,
        },
    };
    let isp = file.to_isp()?;
    let mut dng = DngColour::default();
    for e in &file.entries {
        let illuminant = Illuminant::from_name(&e.illuminant).unwrap_or(Illuminant::Other(0));
        let white = bands_xyz(&illuminant_bands(&e.illuminant)?);
        dng.calibrations.push(ColourCalibration::from_camera_to_xyz(
            illuminant,
            &e.camera_to_xyz,
            white,
        )?);
    }
    if calibration.is_none() {
        let mut cache = FITTED.lock().unwrap_or_else(|e| e.into_inner());
        if !cache.iter().any(|(c, ..)| c == camera) {
            cache.push((camera.to_owned(), dng.clone(), isp));
        }
    }
    Ok((dng, isp))
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

/// What the demo produced: the report, as text and as JSON (both also written to the folder).
#[derive(Debug, Clone)]
pub struct DemoOutcome {
    /// The measurements.
    pub report: DemoReport,
    /// `report.txt`.
    pub text: String,
    /// `report.json`.
    pub json: String,
}

/// A scene rendered, captured and calibrated as `camsim demo` does before its ISP: the raw
/// frame with the sensor's factory calibration (defect map, shading grid), the AWB's white
/// balance and the colour matrix it selects, and the ground truth (what a perfect camera
/// would output, 8-bit sRGB).
pub struct Captured {
    /// The scene as rendered (relit if asked).
    pub scene: SceneDesc,
    /// The illuminant it was lit by.
    pub illuminant: String,
    /// Whether it rendered spectrally (else camera RGB is linear sRGB).
    pub spectral: bool,
    /// Samples per pixel of the render.
    pub spp: u32,
    /// Render time, s.
    pub render_s: f64,
    /// The share of camera samples the lens stopped (vignetting; 0 for a thin lens).
    pub vignetted_fraction: f64,
    /// Sensor simulation time, s.
    pub sensor_s: f64,
    /// The sensor's output.
    pub capture: sensor::Capture,
    /// The ISO it was shot at.
    pub iso: f64,
    /// The camera's response.
    pub response: Response,
    /// The DNG's colour tags (without AsShotNeutral).
    pub dng_colour: DngColour,
    /// The AWB estimate (with its CCT).
    pub awb: wb::AwbEstimate,
    /// Its angle to the true illuminant's neutral, degrees.
    pub awb_angular_error_deg: f64,
    /// The scene's brightest surface (name, camera RGB relative to the light's, degrees from
    /// neutral): what a white-patch or grey estimate takes for white, and why one lands off
    /// when that surface is not neutral.
    pub brightest_surface: Option<(String, [f64; 3], f64)>,
    /// The colour matrix for the AWB's white balance, or why the ISP cannot have one (a
    /// camera and light whose matrix needs coefficients beyond isp-core's range): the raw
    /// frame and the truth are good either way.
    pub ccm: Result<[[f32; 3]; 3], isp_core::IspError>,
    /// The factory defect map.
    pub defects: Vec<Defect>,
    /// The factory shading grid (17 x 13 nodes, Q4.12), if the sensor shades; with a tuning,
    /// the tuning's at the frame's colour temperature.
    pub shading_grid: Option<Vec<u16>>,
    /// The shading grid's nodes across and down.
    pub shading_size: (usize, usize),
    /// The tuning file the frame was calibrated with, if any, and the colour temperature its
    /// locus gave, K.
    pub tuning: Option<(PathBuf, f64)>,
    /// The DNG opcode lists `raw.dng` carries (a tuning's defect map and shading), else empty.
    pub dng_opcodes: [Vec<raw_formats::dng::opcodes::Opcode>; 3],
    /// Whether the sensor adds noise (the demo then reduces it, as its profile says).
    pub noisy: bool,
    /// The truth, linear sRGB on the ISP's output scale.
    pub truth_linear: Vec<f32>,
    /// The truth, 8-bit sRGB.
    pub truth8: Vec<u16>,
}

impl Captured {
    /// Image width.
    pub fn width(&self) -> usize {
        self.capture.raw.width
    }

    /// Image height.
    pub fn height(&self) -> usize {
        self.capture.raw.height
    }

    /// The raw DNG of this frame, as `camsim demo` and `camsim dataset` write it: the colour
    /// calibration, the AWB's neutral as AsShotNeutral, and the noise the sensor implies as
    /// NoiseProfile (so a developer of it needs no estimate).
    pub fn dng(&self) -> Dng {
        Dng {
            image: self.capture.raw.clone(),
            camera_model: format!("camsim {}", self.response.name()),
            colour: DngColour {
                as_shot_neutral: Some(self.awb.neutral.map(f64::from)),
                ..self.dng_colour.clone()
            },
            framing: Default::default(),
            processing: raw_formats::dng::Processing {
                noise_profile: Some(self.capture.noise_profile),
                opcode_lists: self.dng_opcodes.clone(),
                exposure_time_s: Some(self.capture.exposure_s),
                iso: Some(self.iso.round().clamp(1.0, 65535.0) as u16),
                ..Default::default()
            },
        }
    }

    /// Calibrates the frame with the tuning file at `path` instead of the sensor's factory
    /// calibration and the AWB: its black level, defect map, noise profile at the tuned ISO
    /// nearest `iso`, the white balance `awb` estimates moved into the locus (its angle to
    /// `true_neutral` measured again), and shading and colour matrix at the colour temperature
    /// the locus gives; the DNG's colour tags and opcode lists from it.
    fn retune(
        &mut self,
        path: &std::path::Path,
        awb: AwbMethod,
        iso: f64,
        true_neutral: [f64; 3],
    ) -> Result<(), Error> {
        let tuning = crate::tune::Tuning::read(path)?;
        let mut dng = self.dng();
        let applied = crate::tune::carry_in_dng(&tuning, &mut dng, awb, Some(iso))
            .map_err(|e| e.in_file(path))?;
        let options = applied.options;
        self.capture.raw.black_level = dng.image.black_level;
        self.capture.raw.white_level = dng.image.white_level;
        self.defects = options.defects.unwrap_or_default();
        if let Some(grid) = options.lsc {
            self.shading_size = (grid.width, grid.height);
            self.shading_grid = Some(grid.gains_q12);
        }
        if let Some(noise) = options.noise_profile {
            self.capture.noise_profile = noise;
        }
        if let Some(ccm) = options.ccm {
            self.ccm = Ok(ccm);
        }
        self.awb.gains = applied.gains;
        self.awb.neutral = applied.gains.map(|g| 1.0 / g);
        self.awb.cct_k = applied.cct;
        self.awb_angular_error_deg =
            angular_error_deg(self.awb.neutral.map(f64::from), true_neutral);
        self.dng_colour = DngColour {
            as_shot_neutral: None,
            ..dng.colour
        };
        self.dng_opcodes = dng.processing.opcode_lists;
        self.tuning = Some((path.to_path_buf(), applied.cct));
        Ok(())
    }

    /// The demo's noise-reduction strength: the profile's default (1) where the sensor is
    /// noisy, off where it is not.
    pub fn default_denoise(&self) -> f32 {
        if self.noisy {
            1.0
        } else {
            0.0
        }
    }

    /// The ISP configuration `camsim demo` runs on this frame, with `demosaic`, `denoise` and
    /// `chroma_denoise`.
    pub fn isp_config(
        &self,
        demosaic: Method,
        denoise: f32,
        chroma_denoise: f32,
    ) -> Result<IspConfig<'_>, Error> {
        let ccm = self.ccm.map_err(|e| Error::in_stage("colour matrix", e))?;
        Ok(IspConfig {
            dpc: DpcConfig {
                static_defects: &self.defects,
                dynamic_threshold: None,
            },
            lsc: self
                .shading_grid
                .as_ref()
                .map(|g| LensShading::new(self.shading_size.0, self.shading_size.1, g))
                .transpose()?,
            wb_gains: self.awb.gains,
            demosaic,
            denoise,
            noise: Some(self.capture.noise_profile),
            highlight_knee: develop::DEFAULT_HIGHLIGHT_KNEE,
            ccm,
            chroma_denoise,
            ..IspConfig::default()
        })
    }
}

/// Steps 1 to 3 of the demo: renders the scene under the illuminant asked for, captures it
/// through the sensor, calibrates and white-balances, and computes the truth; writes nothing.
pub fn capture(
    args: &DemoSettings,
    progress: &(dyn Fn(DemoProgress<'_>) + Sync),
) -> Result<Captured, Error> {
    let mut config = match args.sensor {
        SensorPreset::Realistic => SensorConfig::realistic(),
        SensorPreset::Ideal => SensorConfig::ideal(),
    };
    config.camera = args.camera.clone();
    config.pattern = args.pattern;
    config.adc_bits = args.bits;
    config.iso = args.iso;
    config.exposure_s = args.exposure;
    config.frame_seed = args.seed;
    let mut scene = scene_file::load(&args.scene)?;
    if let Some(path) = &args.lens {
        scene.camera.use_lens_file(path)?;
    }
    capture_scene(scene, args, &config, progress)
}

/// [`capture`] of a scene already built, through the sensor `config` (whose camera, pattern,
/// bits, ISO, exposure and seeds are used; `args`' are not): what `camsim dataset` runs on the
/// scenes it generates. `args.scene` is not read.
pub fn capture_scene(
    mut scene: SceneDesc,
    args: &DemoSettings,
    config: &SensorConfig,
    progress: &(dyn Fn(DemoProgress<'_>) + Sync),
) -> Result<Captured, Error> {
    let step = |n: usize, what: &str| progress(DemoProgress::Step { n, what });
    config.validate()?;

    // 1. Render, under the illuminant asked for.
    let illuminant = match (&args.illuminant, &scene.illuminant) {
        (None, own) => own.clone().unwrap_or_else(|| "D65".into()),
        (Some(asked), Some(_)) if scene.is_spectral() => {
            scene.relight(asked)?;
            asked.clone()
        }
        (Some(asked), _) if asked == "D65" => asked.clone(),
        (Some(asked), _) => {
            return Err(Error::Option {
                option: "--illuminant",
                value: asked.clone(),
                allowed: format!(
                    "D65 for scene {} (no light of it is a named illuminant; an RGB scene's \
                     lights are linear sRGB)",
                    scene.name
                ),
            })
        }
    };
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
    let image = render_with_progress(&scene, &settings, &|p| progress(DemoProgress::Render(p)))?;

    // 2. Sensor.
    step(
        2,
        &format!(
            "sensor: {} ({}), {}-bit ADC",
            config.camera,
            args.sensor.name(),
            config.adc_bits
        ),
    );
    let sensor_start = Instant::now();
    let response = Response::named(&config.camera)?;
    let spectral = !image.bands.is_empty();
    let capture = expose(&scene, &image, &response, config)?;
    let sensor_s = sensor_start.elapsed().as_secs_f64();

    // 3. Calibration and white balance.
    step(3, "colour calibration and white balance");
    let (dng_colour, calibration) = if spectral {
        calibration_for(&config.camera, args.calibration.as_deref())?
    } else {
        // The RGB path: camera RGB is linear sRGB.
        let m = colour::LINEAR_SRGB_TO_XYZ;
        let inv = colour::mat3_inverse(&m)?;
        (
            DngColour {
                calibrations: vec![ColourCalibration::new(Illuminant::D65, inv)],
                ..DngColour::default()
            },
            Calibration::single(6504.0, m)?,
        )
    };
    let raw_frame = capture.raw.frame()?;
    let to_xyz = calibration.camera_to_xyz(6504.0)?;
    let mut awb = wb::estimate(&raw_frame, args.awb, &to_xyz)?;
    awb.cct_k = calibration.cct_of_neutral(awb.neutral)?;
    // The scene's light as (its white in XYZ, its colour in camera RGB): a named illuminant's
    // spectrum through the observer and the camera, or an RGB scene's emitters' colour in linear
    // sRGB, which is camera RGB on the RGB path. `None`: an RGB scene with no light of its own.
    let light: Option<([f64; 3], [f64; 3])> = if spectral {
        let bands = illuminant_bands(&illuminant)?;
        Some((bands_xyz(&bands), response.of_bands(&bands).map(f64::from)))
    } else {
        scene.light_rgb().map(|l| {
            let rgb = l.map(f64::from);
            (colour::mat3_mul_vec(&colour::LINEAR_SRGB_TO_XYZ, rgb), rgb)
        })
    };
    if light.is_some_and(|(xyz, rgb)| !(xyz[1] > 0.0 && rgb[1] > 0.0)) {
        return Err(Error::Message(format!(
            "the scene's light ({illuminant}) has no light in 400..700 nm"
        )));
    }
    // The neutral a perfect AWB finds.
    let true_neutral = light.map_or([1.0; 3], |(_, rgb)| rgb.map(|v| v / rgb[1]));
    let brightest_surface = brightest_surface(&scene, &response, &illuminant, light, spectral);
    let illuminant = match light {
        Some((_, l)) if !spectral && (l[0] != l[1] || l[1] != l[2]) => format!(
            "the scene's light, linear sRGB {:.3} {:.3} {:.3}",
            l[0] / l[1],
            1.0,
            l[2] / l[1]
        ),
        _ => illuminant,
    };
    let awb_angular_error_deg = angular_error_deg(awb.neutral.map(|v| v as f64), true_neutral);
    let ccm = calibration.ccm_for_white_balance(awb.gains).map(|c| c.ccm);

    // The truth is the scene as a perfectly white-balanced camera shows it, scaled so that a
    // neutral with camera green g (in ISP units) comes out of a perfect ISP at g.
    // - An RGB scene (camera RGB is linear sRGB, and the colour matrix is the identity): the
    //   ISP's white balance divides each channel by the light's, so the truth is the render
    //   with channel c times L_g / L_c (von Kries in the render's own space). An RGB render is
    //   linear per channel, so that is exactly the scene under a white light of the same green.
    // - A spectral scene under another light than D65: its colours adapted (Bradford) from
    //   the light's white to sRGB's D65 white, which is what the white balance and the colour
    //   matrix aim at, at the luminance of the neutral's camera green.
    let upr = capture.units_per_radiance;
    let (scale, adapt) = match light {
        Some((_, rgb)) if !spectral => {
            let diag = [
                [rgb[1] / rgb[0], 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0, 0.0, rgb[1] / rgb[2]],
            ];
            (upr, Some(diag))
        }
        Some((white, rgb)) if illuminant != "D65" => {
            let to_d65 = colour::bradford_adaptation(
                white.map(|v| v / white[1]),
                colour::xy_to_xyz(colour::D65_XY)?,
            )?;
            let m = colour::mat3_mul(
                &colour::XYZ_TO_LINEAR_SRGB,
                &colour::mat3_mul(&to_d65, &colour::LINEAR_SRGB_TO_XYZ),
            );
            (upr * rgb[1] / white[1], Some(m))
        }
        Some((white, rgb)) => (upr * rgb[1] / white[1], None),
        None => (upr, None),
    };
    let scale = scale as f32;
    // The truth is what reaches the pixels: after the optical low-pass filter, if the sensor
    // has one (it is part of the optics, as the lens's blur is part of the render).
    let seen = match config.olpf {
        true => std::borrow::Cow::Owned(sensor::olpf(
            &image.rgb,
            image.width as usize,
            image.height as usize,
        )),
        false => std::borrow::Cow::Borrowed(&image.rgb),
    };
    let truth_linear: Vec<f32> = match adapt {
        None => seen.iter().map(|v| v * scale).collect(),
        Some(m) => seen
            .chunks_exact(3)
            .flat_map(|p| {
                colour::mat3_mul_vec(&m, [p[0], p[1], p[2]].map(f64::from))
                    .map(|v| v as f32 * scale)
            })
            .collect(),
    };
    // Encoded as the ISP renders what it cannot record: a colour brighter than white fades to
    // white by the highlight stage's rule (a perfect camera clips too, and a red light above
    // white shown as pure red would only measure how far the scene is out of range).
    let truth8: Vec<u16> = truth_linear
        .chunks_exact(3)
        .flat_map(|p| {
            let rgb = [p[0], p[1], p[2]];
            let top = rgb[0].max(rgb[1]).max(rgb[2]);
            isp_core::highlights::neutralise_f32(rgb, top, develop::DEFAULT_HIGHLIGHT_KNEE)
                .map(|v| (isp_core::srgb::encode(v.clamp(0.0, 1.0)) * 255.0).round() as u16)
        })
        .collect();
    let defects = capture
        .defects
        .iter()
        .map(|&(x, y, _)| Defect {
            x: x as u16,
            y: y as u16,
        })
        .collect();
    let shading_grid = capture
        .shading
        .is_active()
        .then(|| capture.shading.correction_grid(17, 13, capture.raw.pattern));
    let mut captured = Captured {
        scene,
        illuminant,
        spectral,
        spp: settings.spp,
        render_s: (image.elapsed + image.prepare).as_secs_f64(),
        vignetted_fraction: image.lost_samples as f64 / image.samples.max(1) as f64,
        sensor_s,
        noisy: config.noise != sensor::NoiseConfig::default(),
        capture,
        iso: config.iso,
        response,
        dng_colour,
        awb,
        awb_angular_error_deg,
        brightest_surface,
        ccm,
        defects,
        shading_grid,
        shading_size: (17, 13),
        tuning: None,
        dng_opcodes: Default::default(),
        truth_linear,
        truth8,
    };
    if let Some(path) = &args.tuning {
        captured.retune(path, args.awb, config.iso, true_neutral)?;
    }
    Ok(captured)
}

/// Runs the demo (see the module docs), reporting each step to `progress`.
pub fn run(
    args: &DemoSettings,
    progress: &(dyn Fn(DemoProgress<'_>) + Sync),
) -> Result<DemoOutcome, Error> {
    let started = Instant::now();
    let step = |n: usize, what: &str| progress(DemoProgress::Step { n, what });
    std::fs::create_dir_all(&args.output)
        .map_err(|e| raw_formats::FormatError::io(&args.output, e))?;
    let out = |name: &str| args.output.join(name);
    let captured = capture(args, progress)?;
    let Captured {
        ref scene,
        ref capture,
        ref response,
        ref awb,
        ref truth_linear,
        ref truth8,
        ..
    } = captured;
    let (w, h) = (captured.width(), captured.height());
    // The demo develops what it writes: a frame the ISP cannot develop fails before any file.
    if let Err(e) = captured.ccm {
        return Err(Error::in_stage("colour matrix", e));
    }

    // 4. Files: DNG, plain mosaic, truth.
    step(4, "writing raw.dng, raw.png and the ground truth");
    let dng = captured.dng();
    dng.write(&out("raw.dng"))?;
    raw_formats::image::write(
        &out("raw.png"),
        &Image {
            width: w,
            height: h,
            channels: 1,
            bits: 16,
            data: capture.raw.samples.clone(),
        },
    )?;
    exr::write_rgb(&out("truth_srgb.exr"), w, h, truth_linear)?;
    exr::write_rgb(&out("truth_camera.exr"), w, h, &capture.truth_camera)?;

    // 5. ISP, read back from the DNG as `camsim isp` would.
    step(5, "ISP: float reference and fixed-point paths");
    let back = Dng::read(&out("raw.dng"))?;
    if back.image != capture.raw || back.processing.noise_profile != Some(capture.noise_profile) {
        return Err(Error::Message(
            "raw.dng did not read back the same frame and noise profile".into(),
        ));
    }
    let noise = develop::Noise::File(capture.noise_profile);
    let raw_back = back.image.frame()?;
    let denoise = args.denoise.unwrap_or(captured.default_denoise());
    let chroma_denoise = args
        .chroma_denoise
        .unwrap_or(develop::default_chroma_denoise(denoise));
    let isp_config = captured.isp_config(args.demosaic, denoise, chroma_denoise)?;
    // The demo's report lists each stage's time: ablation on the demo's small frame.
    let run = develop::RunOptions {
        stage_times: true,
        ..develop::RunOptions::default()
    };
    let (float_report, float_rgb) = develop::execute(raw_back.into(), &isp_config, false, 8, run)?;
    let (fixed_report, fixed_rgb) = develop::execute(raw_back.into(), &isp_config, true, 8, run)?;
    let to8 = |img: &Image| Image {
        bits: 8,
        ..img.clone()
    };
    raw_formats::image::write(&out("srgb.png"), &to8(&float_rgb))?;
    raw_formats::image::write(&out("srgb_fixed.png"), &to8(&fixed_rgb))?;
    let truth_img = Image {
        width: w,
        height: h,
        channels: 3,
        bits: 8,
        data: truth8.clone(),
    };
    raw_formats::image::write(&out("truth.png"), &truth_img)?;
    write_side_by_side(
        &out("comparison.png"),
        w,
        h,
        &[truth8, &float_rgb.data, &fixed_rgb.data],
    )?;

    // With a real lens: develop again with the corrections derived from its prescription
    // (distortion and lateral colour in one resampling, its vignetting in the shading grid
    // on top of the sensor's), beside the uncorrected development.
    let lens_fix = lens_corrections(scene, w, h, capture.raw.pattern, captured.shading_size)?;
    if let Some(lens) = &lens_fix {
        let lens_gains = &lens.shading_gains;
        let (gw, gh) = captured.shading_size;
        let gains: Vec<u16> = match &captured.shading_grid {
            Some(sensor_gains) => sensor_gains
                .iter()
                .zip(lens_gains)
                .map(|(&a, &b)| ((u32::from(a) * u32::from(b) + 2048) >> 12).min(65535) as u16)
                .collect(),
            None => lens_gains.clone(),
        };
        let mut config = captured.isp_config(args.demosaic, denoise, chroma_denoise)?;
        config.lsc = Some(LensShading::new(gw, gh, &gains).map_err(|e| Error::in_stage("lsc", e))?);
        config.distortion = Some(lens.corrections.distortion);
        let (_, corrected) = develop::execute(raw_back.into(), &config, false, 8, run)?;
        raw_formats::image::write(&out("corrected.png"), &to8(&corrected))?;
        write_side_by_side(
            &out("lens_comparison.png"),
            w,
            h,
            &[&float_rgb.data, &corrected.data],
        )?;
    }

    // 6. Measure.
    step(6, "measuring");
    let psnr_db = psnr(&float_rgb.data, truth8, 255.0);
    let psnr_fixed_db = psnr(&fixed_rgb.data, truth8, 255.0);
    let white = colour::xy_to_xyz(colour::D65_XY)?;
    let mut errors = Vec::new();
    for (_, centre) in patch_centres(scene, w, h) {
        let (Some(ours), Some(truth)) = (
            mean_linear(&float_rgb.data, w, h, centre, 6),
            mean_linear(truth8, w, h, centre, 6),
        ) else {
            continue;
        };
        let lab = |rgb: [f64; 3]| {
            colour::xyz_to_lab(
                colour::mat3_mul_vec(&colour::LINEAR_SRGB_TO_XYZ, rgb),
                white,
            )
        };
        errors.push(colour::delta_e_2000(lab(ours)?, lab(truth)?));
    }
    let (delta_e_2000_mean, delta_e_2000_max) = if errors.is_empty() {
        (None, None)
    } else {
        let (m, x) = mean_max(&errors);
        (Some(m), Some(x))
    };
    let mut names = vec![
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
    if lens_fix.is_some() {
        names.extend(["corrected.png", "lens_comparison.png"]);
    }
    let report = DemoReport {
        scene: scene.name.clone(),
        camera: response.name().to_owned(),
        sensor: args.sensor.name().to_owned(),
        width: w,
        height: h,
        spp: captured.spp,
        render_s: captured.render_s,
        lens: scene.camera.lens.as_ref().map(|l| {
            (
                l.file.name.clone(),
                l.f_number.unwrap_or(
                    f64::from(scene.camera.focal_length_mm)
                        / (2.0 * f64::from(scene.camera.aperture_radius_mm)),
                ),
            )
        }),
        vignetted_fraction: captured.vignetted_fraction,
        lens_correction: lens_fix.map(|lens| lens.report),
        sensor_s: captured.sensor_s,
        exposure_s: capture.exposure_s,
        iso: args.iso,
        exposure_metered: args.exposure.is_none(),
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
        illuminant: captured.illuminant.clone(),
        awb_angular_error_deg: captured.awb_angular_error_deg,
        awb_reason: captured
            .brightest_surface
            .as_ref()
            .filter(|(_, _, angle)| *angle > 1.0 && captured.awb_angular_error_deg > 2.0)
            .map(|(surface, rgb, angle)| AwbReason {
                surface: surface.clone(),
                rgb: *rgb,
                angle_deg: *angle,
            }),
        cct_k: awb.cct_k,
        tuning: captured
            .tuning
            .as_ref()
            .map(|(p, _)| p.display().to_string()),
        noise_profile: noise.to_json(),
        files: names.iter().map(|n| out(n).display().to_string()).collect(),
    };
    let json = report_json(&report);
    let text = report_text(
        &report,
        started.elapsed().as_secs_f64(),
        &float_report.stages,
        &noise,
    );
    for (name, text) in [("report.json", &json), ("report.txt", &text)] {
        std::fs::write(out(name), text).map_err(|e| raw_formats::FormatError::io(out(name), e))?;
    }
    Ok(DemoOutcome { report, text, json })
}

/// Writes `w x h` 8-bit RGB images side by side, left to right, as one PNG.
fn write_side_by_side(
    path: &std::path::Path,
    w: usize,
    h: usize,
    images: &[&[u16]],
) -> Result<(), Error> {
    let mut side = Vec::with_capacity(w * h * 3 * images.len());
    for y in 0..h {
        for img in images {
            side.extend_from_slice(&img[3 * w * y..3 * w * (y + 1)]);
        }
    }
    raw_formats::image::write(
        path,
        &Image {
            width: images.len() * w,
            height: h,
            channels: 3,
            bits: 8,
            data: side,
        },
    )?;
    Ok(())
}

fn report_json(r: &DemoReport) -> String {
    serde_json::to_string_pretty(r).unwrap_or_default() + "\n"
}

fn report_text(r: &DemoReport, total_s: f64, stages: &[&str], noise: &develop::Noise) -> String {
    let mut t = format!(
        "camsim demo: {} through a simulated {} ({} sensor), {} x {}, {} spp\n",
        r.scene, r.camera, r.sensor, r.width, r.height, r.spp
    );
    let metered = if r.exposure_metered {
        "metered: it falls as ISO rises; --exposure sets it"
    } else {
        "as given"
    };
    t += &format!(
        "  render            {:8.2} s\n  sensor            {:8.2} s (ISO {}, exposure {:.4} s, {metered})\n  ISP float / fixed {:8.1} / {:.1} ms\n",
        r.render_s, r.sensor_s, r.iso, r.exposure_s, r.isp_total_ms, r.isp_fixed_total_ms
    );
    if let Some((name, n)) = &r.lens {
        t += &format!(
            "  lens              {name} at f/{n:.2}: {:.1} % of camera samples vignetted\n",
            100.0 * r.vignetted_fraction
        );
    }
    if let Some(c) = &r.lens_correction {
        t += &format!(
            "  lens corrections  derived in {:.0} ms: distortion k = [{:.5}, {:.5}, {:.5}] at \
             f = {:.3} mm; lateral colour: red x {:.5}, blue x {:.5} at most; shading gain up \
             to {:.3} (corrected.png)\n",
            c.derive_ms,
            c.k[0],
            c.k[1],
            c.k[2],
            c.focal_length_mm,
            c.lateral_colour_scale[0],
            c.lateral_colour_scale[1],
            c.shading_max_gain
        );
    }
    t += &format!("  {}\n", noise.to_text());
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
        "  AWB: estimated {:.0} K, {:.2} degrees from the true illuminant ({})\n",
        r.cct_k, r.awb_angular_error_deg, r.illuminant
    );
    if let Some(tuning) = &r.tuning {
        t += &format!(
            "  tuning: {tuning} (white balance through its locus; black level, defects, noise, \
             shading and colour matrix from it, and raw.dng carries them)\n"
        );
    }
    if let Some(reason) = &r.awb_reason {
        let [red, green, blue] = reason.rgb;
        t += &format!(
            "    why: the scene's brightest surface ('{}', {red:.3} {green:.3} {blue:.3} against its \
             light) is itself {:.1} degrees from neutral, and an estimate that takes the \
             brightest surfaces for white lands about that far off\n",
            reason.surface, reason.angle_deg
        );
    }
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
    fn defaults_are_the_command_lines() {
        let d = DemoSettings::default();
        assert_eq!(d.awb, AwbMethod::from_name("white-patch").unwrap());
        assert_eq!(d.demosaic, "directional".parse().unwrap());
        assert_eq!(d.sensor.name(), "realistic");
    }

    #[test]
    fn the_report_serialises_stage_times_as_an_object() {
        let report = DemoReport {
            scene: "s".into(),
            camera: "c".into(),
            sensor: "ideal".into(),
            width: 2,
            height: 2,
            spp: 1,
            render_s: 0.0,
            lens: None,
            vignetted_fraction: 0.0,
            lens_correction: None,
            sensor_s: 0.0,
            exposure_s: 0.0,
            iso: 100.0,
            exposure_metered: true,
            isp_stage_ms: vec![("colour matrix".into(), 1.5)],
            isp_fixed_stage_ms: vec![],
            isp_total_ms: 1.0,
            isp_fixed_total_ms: 1.0,
            psnr_db: 30.0,
            psnr_fixed_db: 30.0,
            delta_e_2000_mean: None,
            delta_e_2000_max: None,
            illuminant: "D65".into(),
            awb_angular_error_deg: 1.0,
            awb_reason: None,
            cct_k: 6500.0,
            tuning: None,
            noise_profile: develop::Noise::Unknown("test".into()).to_json(),
            files: vec![],
        };
        let v: serde_json::Value = serde_json::from_str(&report_json(&report)).unwrap();
        assert_eq!(v["isp_stage_ms"]["colour matrix"], 1.5);
        assert!(v["delta_e_2000_mean"].is_null());
        assert_eq!(v["noise_profile"]["source"], "none");
    }
}

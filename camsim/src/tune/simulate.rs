//! A tuning capture set shot with a simulated camera whose every parameter is known: the
//! other half of the closed loop (`camsim tune-captures`, and the tests that tune it and
//! compare).
//!
//! Frames are host-tracer's sensor model ([`host_tracer::sensor::capture`]) on radiance
//! composed here: a ColorChecker on a grey wall (each pixel the camera response to reflectance
//! times illuminant, averaged over 4 x 4 sub-samples so patch edges are antialiased), flat
//! fields (a perfect diffuser under the illuminant), dark frames, and photon-transfer pairs of
//! flat fields at rising levels. Every light gives [`STUDIO_LUX`] on the chart (the `1000l` of
//! the chart shots' names), so exposures are a camera's (about 0.1 s at ISO 100 and
//! f/4) and the dark charge what it would be; the darks are shot at the charts' exposure, as a
//! tuning set's darks should be. Flat patches under a uniform light are exactly what the path
//! tracer would compute for them, so no tracing is needed. Files are named as `camsim tune`
//! and Raspberry Pi's tuning tool read them.

use std::path::{Path, PathBuf};

use host_tracer::sensor::{self, DefectKind, LensGeometry, Response, SensorConfig, Shading};
use host_tracer::spectra::{self, Table, BANDS, COLORCHECKER};
use isp_core::noise::NoiseProfile;
use raw_formats::dng::{Dng, Processing};
use raw_formats::RawImage;

use super::chart::{self, ChartMap, Corners};
use crate::Error;

/// Where the chart sits in the chart frames.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ChartPlacement {
    /// Centre of the patch grid, as a fraction of the frame's width and height.
    pub centre: [f64; 2],
    /// The patch grid's width (six pitches) as a fraction of the frame's width.
    pub width_fraction: f64,
    /// Rotation, degrees, counter-clockwise as seen.
    pub rotation_deg: f64,
    /// Whether the chart has its black frame around the patches.
    pub border: bool,
}

impl ChartPlacement {
    /// The chart's map from chart units to pixels in a `width x height` frame.
    pub fn map(&self, width: usize, height: usize) -> ChartMap {
        let pitch = self.width_fraction * width as f64 / chart::COLUMNS as f64;
        let (c, s) = (
            self.rotation_deg.to_radians().cos(),
            self.rotation_deg.to_radians().sin(),
        );
        let (cx, cy) = (
            self.centre[0] * width as f64,
            self.centre[1] * height as f64,
        );
        let (gu, gv) = (chart::COLUMNS as f64 / 2.0, chart::ROWS as f64 / 2.0);
        // Counter-clockwise on screen, with y down: x' = c u + s v, y' = -s u + c v.
        ChartMap::affine([
            [pitch * c, pitch * s, cx - pitch * (c * gu + s * gv)],
            [-pitch * s, pitch * c, cy - pitch * (-s * gu + c * gv)],
        ])
    }
}

/// What to shoot.
#[derive(Debug, Clone, PartialEq)]
pub struct CaptureSetSpec {
    /// Frame width, pixels (even).
    pub width: usize,
    /// Frame height, pixels (even).
    pub height: usize,
    /// The sensor: response, pattern, bits, black level, noise, shading, defects, seed; its
    /// ISO is the charts' and flats' ISO.
    pub sensor: SensorConfig,
    /// The lens (f-number and focal length set exposure and vignetting).
    pub lens: LensGeometry,
    /// Illuminants of the chart shots (names in host-tracer's illuminant table).
    pub chart_illuminants: Vec<String>,
    /// Illuminants of the flat fields.
    pub flat_illuminants: Vec<String>,
    /// Flat frames per flat illuminant.
    pub flats_per_illuminant: usize,
    /// Dark frames, shot at the charts' mean exposure and the sensor's ISO.
    pub darks: usize,
    /// ISOs of the photon-transfer pairs (none: no pairs).
    pub ptc_isos: Vec<f64>,
    /// Levels of the photon-transfer pairs, as fractions of the range in the brightest channel.
    pub ptc_levels: Vec<f64>,
    /// The chart's placement.
    pub chart: ChartPlacement,
    /// The chart shots' exposure: the brightest patch's brightest channel at this fraction of
    /// the range at the centre (0.8; above 1 clips the bright patches).
    pub chart_level: f64,
    /// The BlackLevel tag written into every file, when it should differ from the sensor's
    /// true black (a camera whose metadata is off); `None`: the true black.
    pub dng_black_level: Option<u16>,
}

impl CaptureSetSpec {
    /// A set of 480 x 360 frames from `sensor`: charts under A, D65 and LED-B3 (the light
    /// between them), flats under A and D65, four darks, photon-transfer pairs at ISO 100 and
    /// 400 over eight levels, the chart a little rotated in the middle.
    pub fn standard(sensor: SensorConfig) -> Self {
        CaptureSetSpec {
            width: 480,
            height: 360,
            lens: LensGeometry {
                f_number: 4.0,
                focal_length_mm: 12.0,
                sensor_mm: [6.4, 4.8],
            },
            sensor,
            chart_illuminants: vec!["A".into(), "LED-B3".into(), "D65".into()],
            flat_illuminants: vec!["A".into(), "D65".into()],
            flats_per_illuminant: 2,
            darks: 4,
            ptc_isos: vec![100.0, 400.0],
            ptc_levels: vec![0.02, 0.05, 0.1, 0.2, 0.3, 0.45, 0.6, 0.75],
            chart: ChartPlacement {
                centre: [0.5, 0.5],
                width_fraction: 0.6,
                rotation_deg: 4.0,
                border: true,
            },
            chart_level: 0.8,
            dng_black_level: None,
        }
    }
}

/// What the set was shot with: the truth a tuning is checked against.
#[derive(Debug, Clone)]
pub struct CaptureTruth {
    /// The sensor's black level, DN (every CFA position).
    pub black: u16,
    /// The planted defects.
    pub defects: Vec<(usize, usize, DefectKind)>,
    /// The noise profile at each photon-transfer ISO (the pairs' exposure).
    pub noise: Vec<(f64, NoiseProfile)>,
    /// The noise profile of the chart shots and darks: the sensor's ISO at the darks' exposure
    /// (the charts' mean; the charts' own differ from it by the dark charge of the difference,
    /// a few thousandths of an electron squared).
    pub chart_noise: NoiseProfile,
    /// The shading every frame went through.
    pub shading: Shading,
    /// The chart's corners in pixels.
    pub chart_corners: Corners,
    /// Per chart illuminant: name, CCT as written in the file name, and the light's colour in
    /// camera RGB (green 1).
    pub illuminants: Vec<(String, f64, [f64; 3])>,
    /// The files written.
    pub files: Vec<PathBuf>,
}

/// The CCT written in file names for an illuminant of host-tracer's table (McCamy from its
/// XYZ on the band grid), kelvin.
pub fn illuminant_cct(name: &str) -> Result<f64, Error> {
    let bands = spectra::illuminant_bands(name)?;
    let xyz = spectra::bands_xyz(&bands);
    let xy = isp_core::colour::xyz_to_xy(xyz)?;
    Ok(isp_core::colour::xy_to_cct_mccamy(xy)?)
}

/// The illuminance of every light of a capture set on the chart or diffuser, lux.
pub const STUDIO_LUX: f64 = 1000.0;

/// Camera radiance of a perfect diffuser under [`STUDIO_LUX`], in the sensor model's luminance
/// units: `L = E / pi` (cd/m^2) for a Lambertian white.
fn studio_white() -> f64 {
    STUDIO_LUX / std::f64::consts::PI
}

/// Camera RGB of reflectance `reflectance` (bands) under `light` (bands), with the light's own
/// green (a perfect white) at 1.
fn seen(response: &Response, reflectance: &[f32; BANDS], light: &[f32; BANDS]) -> [f64; 3] {
    let white = response.of_bands(light)[1] as f64;
    let lit: [f32; BANDS] = std::array::from_fn(|b| reflectance[b] * light[b]);
    response.of_bands(&lit).map(|v| v as f64 / white)
}

/// The 24 patches as `camera` sees them under `illuminant`, noise-free and white-balanced
/// (each channel over the light's own): what a perfect capture hands a colour matrix, the
/// truth a tuned matrix is measured on.
pub fn balanced_patches(camera: &str, illuminant: &str) -> Result<Vec<[f64; 3]>, Error> {
    let response = Response::named(camera)?;
    let light = spectra::illuminant_bands(illuminant)?;
    let white = seen(&response, &[1.0; BANDS], &light);
    let table = Table::parse(COLORCHECKER)?;
    (0..chart::PATCHES)
        .map(|i| {
            let column = table.column_at(i).ok_or(Error::Message(format!(
                "ColorChecker table: column {i} missing"
            )))?;
            let rgb = seen(&response, &spectra::bands_from_grid(column), &light);
            Ok(std::array::from_fn(|k| rgb[k] / white[k]))
        })
        .collect()
}

/// The shading a correction leaves on colour `c` of a frame of `spec`'s size: the true
/// fall-off `shading` times `gain` (pixel -> the correction's gain), relative to the centre.
/// Returns (the largest at the four corners, the RMS over every fourth pixel), as fractions.
pub fn shading_residual(
    shading: &host_tracer::sensor::Shading,
    spec: &CaptureSetSpec,
    c: usize,
    gain: &dyn Fn(f64, f64) -> f64,
) -> (f64, f64) {
    let corrected = |x: f64, y: f64| shading.factor(x, y, c) * gain(x, y);
    let (w, h) = (spec.width, spec.height);
    let centre = corrected(w as f64 / 2.0, h as f64 / 2.0);
    let (mut sum2, mut n) = (0.0, 0.0);
    for y in (0..h).step_by(4) {
        for x in (0..w).step_by(4) {
            let r = corrected(x as f64, y as f64) / centre - 1.0;
            sum2 += r * r;
            n += 1.0;
        }
    }
    let (w1, h1) = ((w - 1) as f64, (h - 1) as f64);
    let corner = [(0.0, 0.0), (w1, 0.0), (0.0, h1), (w1, h1)]
        .iter()
        .map(|&(x, y)| (corrected(x, y) / centre - 1.0).abs())
        .fold(0.0f64, f64::max);
    (corner, (sum2 / n).sqrt())
}

/// The chart frame's camera radiance under `light` at [`STUDIO_LUX`], 3 per pixel.
fn chart_radiance(
    spec: &CaptureSetSpec,
    response: &Response,
    light: &[f32; BANDS],
) -> Result<Vec<f32>, Error> {
    let table = Table::parse(COLORCHECKER)?;
    let lit =
        |reflectance: &[f32; BANDS]| seen(response, reflectance, light).map(|v| v * studio_white());
    let mut patch_rgb = Vec::with_capacity(chart::PATCHES);
    for i in 0..chart::PATCHES {
        let column = table.column_at(i).ok_or(Error::Message(format!(
            "ColorChecker table: column {i} missing"
        )))?;
        patch_rgb.push(lit(&spectra::bands_from_grid(column)));
    }
    // The chart's frame: a flat 3.5 % black; the wall: a flat 30 % grey.
    let frame = lit(&[0.035; BANDS]);
    let wall = lit(&[0.30; BANDS]);
    let (w, h) = (spec.width, spec.height);
    let map = spec.chart.map(w, h);
    // Inverse of the affine map: pixel -> chart units.
    let o = map.apply([0.0, 0.0]);
    let eu = map.apply([1.0, 0.0]);
    let ev = map.apply([0.0, 1.0]);
    let (a, b, c, d) = (eu[0] - o[0], ev[0] - o[0], eu[1] - o[1], ev[1] - o[1]);
    let det = a * d - b * c;
    let to_chart = |x: f64, y: f64| -> [f64; 2] {
        let (dx, dy) = (x - o[0], y - o[1]);
        [(d * dx - b * dy) / det, (-c * dx + a * dy) / det]
    };
    let half = chart::PATCH_SIDE / 2.0;
    let border = if spec.chart.border {
        chart::BORDER
    } else {
        0.0
    };
    let mut out = vec![0.0f32; w * h * 3];
    const SUB: usize = 4;
    for y in 0..h {
        for x in 0..w {
            let mut sum = [0.0f64; 3];
            for sy in 0..SUB {
                for sx in 0..SUB {
                    let px = x as f64 + (sx as f64 + 0.5) / SUB as f64;
                    let py = y as f64 + (sy as f64 + 0.5) / SUB as f64;
                    let [u, v] = to_chart(px, py);
                    let in_grid = (0.0..chart::COLUMNS as f64).contains(&u)
                        && (0.0..chart::ROWS as f64).contains(&v);
                    let rgb = if in_grid {
                        let (col, row) = (u.floor(), v.floor());
                        let (fu, fv) = (u - col - 0.5, v - row - 0.5);
                        if fu.abs() < half && fv.abs() < half {
                            patch_rgb[row as usize * chart::COLUMNS + col as usize]
                        } else {
                            frame
                        }
                    } else if (-border..chart::COLUMNS as f64 + border).contains(&u)
                        && (-border..chart::ROWS as f64 + border).contains(&v)
                    {
                        frame
                    } else {
                        wall
                    };
                    for k in 0..3 {
                        sum[k] += rgb[k];
                    }
                }
            }
            for k in 0..3 {
                out[3 * (y * w + x) + k] = (sum[k] / (SUB * SUB) as f64) as f32;
            }
        }
    }
    Ok(out)
}

/// The exposure that puts camera radiance `peak` (the brightest channel) at `level` of the
/// range at the frame's centre.
fn exposure_for(sensor: &SensorConfig, lens: &LensGeometry, peak: f64, level: f64) -> f64 {
    let range = f64::from(sensor.white_level() - sensor.black());
    let sensitivity = sensor.sensitivity_e_per_lux_s * sensor.qe_scale;
    let per_second = sensor::pixel::signal_electrons(peak, lens.f_number, 1.0, sensitivity)
        * sensor.dn_per_electron()
        / range;
    level / per_second
}

/// The frame as a DNG with the tags a tuning tool reads: the camera, and the exposure and
/// ISO it was shot at (EXIF ExposureTime and ISOSpeedRatings, which Raspberry Pi's tool needs).
fn write_dng(
    spec: &CaptureSetSpec,
    raw: RawImage,
    exposure_s: f64,
    iso: f64,
    path: &Path,
) -> Result<(), Error> {
    let mut raw = raw;
    if let Some(black) = spec.dng_black_level {
        raw.black_level = [black; 4];
    }
    let dng = Dng {
        image: raw,
        camera_model: format!("camsim {}", spec.sensor.camera),
        colour: Default::default(),
        framing: Default::default(),
        processing: Processing {
            exposure_time_s: Some(exposure_s),
            iso: Some(iso.round().clamp(1.0, 65535.0) as u16),
            ..Processing::default()
        },
    };
    // Laid out as cameras write DNGs (a preview in IFD 0, the raw in a SubIFD): Raspberry Pi's
    // tool reads the raw's WhiteLevel from the first SubIFD only.
    let bytes = dng.encode_with_preview(&raw_formats::dng::EncodeOptions::default())?;
    std::fs::write(path, bytes).map_err(|e| raw_formats::FormatError::io(path, e))?;
    Ok(())
}

/// One chart frame under `illuminant` as the set would shoot it (the sensor's `frame_seed`).
pub fn chart_frame(spec: &CaptureSetSpec, illuminant: &str) -> Result<RawImage, Error> {
    let response = Response::named(&spec.sensor.camera)?;
    let light = spectra::illuminant_bands(illuminant)?;
    let radiance = chart_radiance(spec, &response, &light)?;
    let peak = radiance.iter().fold(0.0f32, |a, &b| a.max(b)) as f64;
    let config = SensorConfig {
        exposure_s: Some(exposure_for(
            &spec.sensor,
            &spec.lens,
            peak,
            spec.chart_level,
        )),
        ..spec.sensor.clone()
    };
    Ok(sensor::capture(&radiance, spec.width, spec.height, spec.lens, &config)?.raw)
}

/// Shoots the set into `dir` (created if missing), reporting each file to `progress`.
pub fn write_capture_set(
    spec: &CaptureSetSpec,
    dir: &Path,
    progress: &mut dyn FnMut(&str),
) -> Result<CaptureTruth, Error> {
    spec.sensor.validate()?;
    if spec.width < 64
        || spec.height < 64
        || !spec.width.is_multiple_of(2)
        || !spec.height.is_multiple_of(2)
    {
        return Err(Error::Option {
            option: "capture set size",
            value: format!("{} x {}", spec.width, spec.height),
            allowed: "even sides of at least 64 pixels".into(),
        });
    }
    std::fs::create_dir_all(dir).map_err(|e| raw_formats::FormatError::io(dir, e))?;
    let response = Response::named(&spec.sensor.camera)?;
    let (w, h) = (spec.width, spec.height);
    let mut files = Vec::new();
    let mut frame_seed = spec.sensor.frame_seed;
    let mut shoot = |radiance: &[f32],
                     sensor: SensorConfig,
                     name: String,
                     progress: &mut dyn FnMut(&str)|
     -> Result<sensor::Capture, Error> {
        frame_seed = frame_seed.wrapping_add(1);
        let config = SensorConfig {
            frame_seed,
            ..sensor
        };
        let capture = sensor::capture(radiance, w, h, spec.lens, &config)?;
        let path = dir.join(&name);
        write_dng(
            spec,
            capture.raw.clone(),
            capture.exposure_s,
            config.iso,
            &path,
        )?;
        progress(&name);
        files.push(path);
        Ok(capture)
    };
    let mut illuminants = Vec::new();
    let mut chart_exposures = Vec::new();
    let mut shading = None;
    let mut defects = Vec::new();
    for name in &spec.chart_illuminants {
        let light = spectra::illuminant_bands(name)?;
        let cct = illuminant_cct(name)?.round();
        let radiance = chart_radiance(spec, &response, &light)?;
        let peak = radiance.iter().fold(0.0f32, |a, &b| a.max(b)) as f64;
        let exposure = exposure_for(&spec.sensor, &spec.lens, peak, spec.chart_level);
        let sensor = SensorConfig {
            exposure_s: Some(exposure),
            ..spec.sensor.clone()
        };
        let capture = shoot(
            &radiance,
            sensor,
            format!("chart_{name}_{cct}k_{}l.dng", STUDIO_LUX.round()),
            progress,
        )?;
        chart_exposures.push(exposure);
        shading = Some(capture.shading);
        defects = capture.defects.clone();
        illuminants.push((name.clone(), cct, seen(&response, &[1.0; BANDS], &light)));
    }
    for name in &spec.flat_illuminants {
        let light = spectra::illuminant_bands(name)?;
        let cct = illuminant_cct(name)?.round();
        let rgb = seen(&response, &[1.0; BANDS], &light).map(|v| v * studio_white());
        let radiance: Vec<f32> = (0..w * h).flat_map(|_| rgb.map(|v| v as f32)).collect();
        let peak = rgb.iter().fold(0.0f64, |a, &b| a.max(b));
        let exposure = exposure_for(&spec.sensor, &spec.lens, peak, 0.7);
        for n in 0..spec.flats_per_illuminant {
            let sensor = SensorConfig {
                exposure_s: Some(exposure),
                ..spec.sensor.clone()
            };
            shoot(&radiance, sensor, format!("alsc_{cct}k_{n}.dng"), progress)?;
        }
    }
    // The darks at the charts' (mean) exposure and ISO: the dark charge they hold is the
    // charts', so their noise is the charts' noise at zero signal.
    let dark_exposure = chart_exposures.iter().sum::<f64>() / chart_exposures.len().max(1) as f64;
    for n in 0..spec.darks {
        let sensor = SensorConfig {
            exposure_s: Some(dark_exposure),
            ..spec.sensor.clone()
        };
        let capture = shoot(
            &vec![0.0f32; w * h * 3],
            sensor,
            format!("dark_{n}.dng"),
            progress,
        )?;
        defects = capture.defects.clone();
    }
    let mut noise = Vec::new();
    if !spec.ptc_isos.is_empty() {
        let light = spectra::illuminant_bands("D50")?;
        let rgb = seen(&response, &[1.0; BANDS], &light).map(|v| v * studio_white());
        let peak = rgb.iter().fold(0.0f64, |a, &b| a.max(b));
        for &iso in &spec.ptc_isos {
            let base = SensorConfig {
                iso,
                ..spec.sensor.clone()
            };
            // One exposure per ISO, the light varied: the dark charge (in the offset) stays put.
            let top = spec.ptc_levels.iter().fold(0.0f64, |a, &b| a.max(b));
            let exposure = exposure_for(&base, &spec.lens, peak, top.max(1e-3));
            let config = SensorConfig {
                exposure_s: Some(exposure),
                ..base
            };
            noise.push((iso, config.noise_profile(exposure)?));
            // The dark pair first: it fixes the offset, as EMVA 1288 takes it.
            let levels = std::iter::once(("dark".to_string(), 0.0)).chain(
                spec.ptc_levels
                    .iter()
                    .enumerate()
                    .map(|(k, &l)| (k.to_string(), l)),
            );
            for (label, level) in levels {
                let scale = level / top.max(1e-3);
                let radiance: Vec<f32> = (0..w * h)
                    .flat_map(|_| rgb.map(|v| (v * scale) as f32))
                    .collect();
                for side in ["a", "b"] {
                    shoot(
                        &radiance,
                        config.clone(),
                        format!("ptc_{}_{label}_{side}.dng", iso.round()),
                        progress,
                    )?;
                }
            }
        }
    }
    let Some(shading) = shading else {
        return Err(Error::Message(
            "a capture set needs at least one chart illuminant".into(),
        ));
    };
    let chart_noise = SensorConfig {
        exposure_s: Some(dark_exposure),
        ..spec.sensor.clone()
    }
    .noise_profile(dark_exposure)?;
    Ok(CaptureTruth {
        black: spec.sensor.black(),
        defects,
        noise,
        chart_noise,
        shading,
        chart_corners: spec.chart.map(w, h).corners(),
        illuminants,
        files,
    })
}

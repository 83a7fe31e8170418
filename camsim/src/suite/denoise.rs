//! The denoise suite: camsim's profile-driven noise reduction against OpenCV's
//! `fastNlMeansDenoisingColored` and two BM3D peers, on Kodak and McMaster images as noisy
//! 12-bit RGGB raws, every peer in the same run (`denoise.svg`).
//!
//! Each image's central 256 x 256 pixels (8-bit sRGB; 128 in quick runs) are decoded to linear light, mosaicked RGGB and scaled to 12-bit
//! codes (black 256, white 4095); noise `S Poisson(x / S) + sqrt(O) N(0, 1)` is added at
//! `S` = 0.0008, 0.0032 and 0.0128 with `O` from the unprocessing paper's fit (Brooks et al.
//! 2019, `log O = 2.18 log S + 1.2`). Every development is camsim's float path with the
//! default demosaicing method and no other stage; the reference is the noise-free raw's
//! development with noise reduction off, and PSNR is over 8-bit codes 8 pixels in from each
//! edge. camsim develops the noisy raw with its profile (noise reduction at its default
//! strength, both paths); OpenCV and CBM3D filter the noisy development; BM3D filters each CFA
//! plane of the noisy raw after a variance-stabilising transform, and camsim develops what it
//! returns.

use std::path::Path;

use host_tracer::random::Rng;
use host_tracer::sensor::pixel;
use isp_core::denoise::Search;
use isp_core::frame::RawFrame;
use isp_core::metrics::cpsnr;
use isp_core::noise::NoiseProfile;
use isp_core::pipeline::{Input, IspConfig};
use isp_core::CfaPattern;
use serde::{Deserialize, Serialize};

use super::{run_python, ProgressFn, SuiteSettings};
use crate::develop::{Runner, DEFAULT_METHOD};
use crate::error::Error;

/// The noise levels `S` (variance per unit of signal, a fraction of white).
pub const SCALES: [f64; 3] = [0.0008, 0.0032, 0.0128];
/// OpenCV's `h` grid (the same for its colour term).
pub const H_GRID: [f64; 11] = [1.0, 2.0, 3.0, 5.0, 7.0, 9.0, 11.0, 13.0, 15.0, 18.0, 21.0];
const BLACK: u16 = 256;
const WHITE: u16 = 4095;
/// Pixels left out at each edge of every PSNR.
const BORDER: usize = 8;
/// The images of a full run: four of each set, chosen for texture, edges and saturated colour.
const FULL: [(&str, &str); 8] = [
    ("kodak", "kodim01.png"),
    ("kodak", "kodim05.png"),
    ("kodak", "kodim13.png"),
    ("kodak", "kodim23.png"),
    ("mcmaster", "mcm01.png"),
    ("mcmaster", "mcm05.png"),
    ("mcmaster", "mcm10.png"),
    ("mcmaster", "mcm16.png"),
];
/// Side of the central crop of each image a full run measures (BM3D takes about a minute on a
/// whole Kodak image here).
const FULL_SIDE: usize = 256;
/// A quick run's images, cropped to [`QUICK_SIDE`].
const QUICK: [(&str, &str); 2] = [("kodak", "kodim05.png"), ("mcmaster", "mcm05.png")];
const QUICK_SIDE: usize = 128;

/// One method on one image at one noise level.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DenoisePoint {
    /// The image's file name.
    pub image: String,
    /// The noise level `S`.
    pub scale: f64,
    /// `noisy` (no noise reduction), `camsim float`, `camsim fixed` (the default search),
    /// `camsim float fast`, `camsim fixed fast` (the fast setting), `fnlm h=...`, `cbm3d`,
    /// `bm3d planes`.
    pub method: String,
    /// PSNR in dB against the noise-free development.
    pub psnr_db: f64,
    /// Seconds the method took on this image, one thread (camsim: the whole development with
    /// noise reduction; the peers: their filter alone); 0 for `noisy`.
    pub seconds: f64,
    /// The image's size in megapixels.
    pub megapixels: f64,
}

/// The suite's figures.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct DenoiseSuite {
    /// Every measurement.
    pub points: Vec<DenoisePoint>,
    /// The peers' library versions.
    pub peer_versions: Option<serde_json::Value>,
    /// Why BM3D did not run, when it did not (quick runs, or no bm3d package).
    pub bm3d_skipped: Option<String>,
}

/// One method's mean over the images at each level.
#[derive(Debug, Clone, PartialEq)]
pub struct MethodSummary {
    /// The method (`fnlm` rows name their best `h` per level).
    pub method: String,
    /// Mean PSNR at each of [`SCALES`] (NaN where it did not run).
    pub psnr_db: [f64; 3],
    /// Mean PSNR gain over `noisy` at each level.
    pub gain_db: [f64; 3],
    /// Megapixels per second (total pixels over total seconds).
    pub mpix_per_s: f64,
}

impl MethodSummary {
    /// The mean of the two noisier levels' PSNR, the criterion.
    pub fn noisier_mean(&self) -> f64 {
        (self.psnr_db[1] + self.psnr_db[2]) / 2.0
    }
}

impl DenoiseSuite {
    /// Each method's means; OpenCV's at its best `h` per level (best mean over the images).
    pub fn summary(&self) -> Vec<MethodSummary> {
        let mean = |method: &str, level: usize| -> Option<(f64, f64, f64)> {
            let rows: Vec<_> = self
                .points
                .iter()
                .filter(|p| p.method == method && p.scale == SCALES[level])
                .collect();
            (!rows.is_empty()).then(|| {
                let n = rows.len() as f64;
                (
                    rows.iter().map(|p| p.psnr_db).sum::<f64>() / n,
                    rows.iter().map(|p| p.seconds).sum::<f64>(),
                    rows.iter().map(|p| p.megapixels).sum::<f64>(),
                )
            })
        };
        let noisy: Vec<f64> = (0..3)
            .map(|l| mean("noisy", l).map_or(f64::NAN, |m| m.0))
            .collect();
        let mut methods: Vec<String> = Vec::new();
        for p in &self.points {
            let name = if p.method.starts_with("fnlm") {
                "fnlm".to_string()
            } else {
                p.method.clone()
            };
            if !methods.contains(&name) {
                methods.push(name);
            }
        }
        methods
            .into_iter()
            .map(|method| {
                let (mut psnr, mut seconds, mut mpix) = ([f64::NAN; 3], 0.0, 0.0);
                let mut best_h = Vec::new();
                for (l, slot) in psnr.iter_mut().enumerate() {
                    let found = if method == "fnlm" {
                        let best = H_GRID
                            .iter()
                            .filter_map(|h| Some((*h, mean(&format!("fnlm h={h}"), l)?)))
                            .max_by(|a, b| a.1 .0.total_cmp(&b.1 .0));
                        best.map(|(h, m)| {
                            best_h.push(format!("{h}"));
                            m
                        })
                    } else {
                        mean(&method, l)
                    };
                    if let Some((p, s, m)) = found {
                        *slot = p;
                        seconds += s;
                        mpix += m;
                    }
                }
                let label = if best_h.is_empty() {
                    method
                } else {
                    format!("{method} (best h: {})", best_h.join(", "))
                };
                MethodSummary {
                    method: label,
                    gain_db: std::array::from_fn(|l| psnr[l] - noisy[l]),
                    psnr_db: psnr,
                    mpix_per_s: if seconds > 0.0 {
                        mpix / seconds
                    } else {
                        f64::NAN
                    },
                }
            })
            .collect()
    }
}

/// A loaded image's linear RGB mosaic (RGGB), fractions of white, and its size.
struct Scene {
    name: String,
    width: usize,
    height: usize,
    linear: Vec<f64>,
}

/// The central `side` x `side` crop (or less, even sides) of an image, as a linear mosaic.
fn load(settings: &SuiteSettings, set: &str, file: &str, side: usize) -> Result<Scene, Error> {
    let path = settings.data.join(set).join(file);
    let rgb = raw_formats::image::read(&path)?;
    if rgb.channels != 3 {
        return Err(Error::Message(format!(
            "{}: not an RGB image",
            path.display()
        )));
    }
    let peak = f64::from((1u32 << rgb.bits) - 1);
    // Even sides and offsets (whole CFA blocks).
    let width = side.min(rgb.width) & !1;
    let height = side.min(rgb.height) & !1;
    let (left, top) = (
        ((rgb.width - width) / 2) & !1,
        ((rgb.height - height) / 2) & !1,
    );
    let linear = (0..width * height)
        .map(|i| {
            let (x, y) = (i % width, i / width);
            let c = CfaPattern::Rggb.colour_at(x, y).index();
            let at = 3 * ((top + y) * rgb.width + left + x) + c;
            let v = f64::from(rgb.data[at]) / peak;
            if v <= 0.04045 {
                v / 12.92
            } else {
                ((v + 0.055) / 1.055).powf(2.4)
            }
        })
        .collect();
    Ok(Scene {
        name: file.to_string(),
        width,
        height,
        linear,
    })
}

/// The unprocessing paper's read-against-shot fit.
pub fn offset_for(scale: f64) -> f64 {
    (2.18 * scale.ln() + 1.2).exp()
}

/// 12-bit codes of the scene, noise-free (`scale` None) or with Poisson-Gaussian noise.
fn codes(scene: &Scene, scale: Option<f64>, seed: u64) -> Vec<u16> {
    let mut rng = Rng::new(seed, 0xde_9015e);
    let range = f64::from(WHITE - BLACK);
    scene
        .linear
        .iter()
        .map(|&x| {
            let v = match scale {
                Some(s) => {
                    s * pixel::poisson(&mut rng, x / s)
                        + offset_for(s).sqrt() * pixel::normal(&mut rng)
                }
                None => x,
            };
            (f64::from(BLACK) + v * range)
                .round()
                .clamp(0.0, f64::from(WHITE)) as u16
        })
        .collect()
}

/// camsim's development of `data`: the default method, float or fixed, noise reduction at
/// `denoise` with `profile` (and chroma noise reduction at its default with it); the output
/// and the best of `repeats` runs in seconds.
fn develop(
    scene: &Scene,
    data: &[u16],
    profile: Option<NoiseProfile>,
    denoise: f32,
    search: Search,
    fixed: bool,
    repeats: u32,
) -> Result<(Vec<u8>, f64), Error> {
    let raw = RawFrame::new(
        data,
        scene.width,
        scene.height,
        scene.width,
        12,
        CfaPattern::Rggb,
        [BLACK; 4],
        WHITE,
    )?;
    let config = IspConfig {
        demosaic: DEFAULT_METHOD,
        denoise,
        denoise_search: search,
        noise: profile,
        chroma_denoise: crate::develop::default_chroma_denoise(denoise),
        ..IspConfig::default()
    };
    let mut out = vec![0u8; 3 * scene.width * scene.height];
    let ms = Runner::new(&Input::Mosaic(raw), &config, fixed, 8, 1)?.best_ms(&mut out, repeats)?;
    Ok((out, ms / 1e3))
}

fn psnr(out: &[u8], reference: &[u8], scene: &Scene) -> f64 {
    let widen = |v: &[u8]| v.iter().map(|b| u16::from(*b)).collect::<Vec<_>>();
    cpsnr(
        &widen(out),
        &widen(reference),
        scene.width,
        scene.height,
        BORDER,
        255.0,
    )
}

/// What the peer script prints.
#[derive(Deserialize)]
struct PeerReply {
    versions: serde_json::Value,
    rows: Vec<PeerRow>,
}

#[derive(Deserialize)]
struct PeerRow {
    name: String,
    s: f64,
    method: String,
    psnr_db: Option<f64>,
    seconds: f64,
}

/// Runs the suite: camsim on every image and level, then the peers in one Python process.
pub fn denoise_suite(
    settings: &SuiteSettings,
    peers_skipped: &mut Option<String>,
    progress: ProgressFn<'_>,
) -> Result<DenoiseSuite, Error> {
    let (list, side, repeats): (&[(&str, &str)], _, u32) = if settings.quick {
        (&QUICK, QUICK_SIDE, 1)
    } else {
        (&FULL, FULL_SIDE, 3)
    };
    let work = settings.out.join("denoise-work");
    std::fs::create_dir_all(&work).map_err(|e| raw_formats::FormatError::io(&work, e))?;
    let write = |path: &Path, bytes: &[u8]| {
        std::fs::write(path, bytes).map_err(|e| Error::from(raw_formats::FormatError::io(path, e)))
    };
    let mut points = Vec::new();
    let mut jobs = Vec::new();
    let mut scenes = Vec::new();
    for (i, (set, file)) in list.iter().enumerate() {
        let scene = load(settings, set, file, side)?;
        let megapixels = (scene.width * scene.height) as f64 / 1e6;
        let clean = codes(&scene, None, 0);
        let (reference, _) = develop(&scene, &clean, None, 0.0, Search::Wide, false, 1)?;
        for (l, &s) in SCALES.iter().enumerate() {
            progress(&format!("denoise: {file} at S = {s}"));
            let noisy = codes(&scene, Some(s), (i * SCALES.len() + l) as u64 + 1);
            let profile = NoiseProfile::uniform(s as f32, offset_for(s) as f32)?;
            let point = |method: &str, out: &[u8], seconds: f64| DenoisePoint {
                image: scene.name.clone(),
                scale: s,
                method: method.into(),
                psnr_db: psnr(out, &reference, &scene),
                seconds,
                megapixels,
            };
            let (plain, _) = develop(&scene, &noisy, None, 0.0, Search::Wide, false, 1)?;
            points.push(point("noisy", &plain, 0.0));
            for search in Search::ALL {
                for fixed in [false, true] {
                    let (out, seconds) =
                        develop(&scene, &noisy, Some(profile), 1.0, search, fixed, repeats)?;
                    let path = if fixed { "fixed" } else { "float" };
                    let name = match search {
                        Search::Wide => format!("camsim {path}"),
                        Search::Fast => format!("camsim {path} fast"),
                    };
                    points.push(point(&name, &out, seconds));
                }
            }
            let stem = work.join(format!("{}-{l}", scene.name.trim_end_matches(".png")));
            let file_of = |what: &str| stem.with_extension(what);
            let raw_bytes: Vec<u8> = noisy.iter().flat_map(|v| v.to_le_bytes()).collect();
            write(&file_of("noisy.u16"), &raw_bytes)?;
            write(&file_of("noisy.rgb"), &plain)?;
            write(&file_of("clean.rgb"), &reference)?;
            jobs.push(serde_json::json!({
                "name": scene.name, "width": scene.width, "height": scene.height,
                "s": s, "o": offset_for(s), "black": BLACK, "white": WHITE,
                "noisy_raw": file_of("noisy.u16"), "noisy_srgb": file_of("noisy.rgb"),
                "clean_srgb": file_of("clean.rgb"), "out_raw": file_of("bm3d.u16"),
            }));
        }
        scenes.push((scene, reference));
    }
    let bm3d = !settings.quick;
    let mut suite = DenoiseSuite {
        bm3d_skipped: (!bm3d).then(|| "quick runs leave BM3D out (minutes per image)".into()),
        ..DenoiseSuite::default()
    };
    progress(if bm3d {
        "denoise: peers (OpenCV's non-local means, CBM3D, BM3D per CFA plane: several minutes)"
    } else {
        "denoise: peers (OpenCV's non-local means)"
    });
    let request = serde_json::json!({
        "jobs": jobs, "h_grid": H_GRID, "bm3d": bm3d, "border": BORDER,
    });
    match run_python::<PeerReply>(&settings.python, include_str!("denoise_peers.py"), &request) {
        Ok(reply) => {
            suite.peer_versions = Some(reply.versions);
            for row in reply.rows {
                let Some((scene, reference)) = scenes.iter().find(|(s, _)| s.name == row.name)
                else {
                    continue;
                };
                let psnr_db = match row.psnr_db {
                    Some(p) => p,
                    None => {
                        // The raw peer: develop what it wrote, as camsim's own output is.
                        let l = SCALES.iter().position(|s| *s == row.s).unwrap_or(0);
                        let path = work
                            .join(format!("{}-{l}", scene.name.trim_end_matches(".png")))
                            .with_extension("bm3d.u16");
                        let bytes = std::fs::read(&path)
                            .map_err(|e| raw_formats::FormatError::io(&path, e))?;
                        let data: Vec<u16> = bytes
                            .chunks_exact(2)
                            .map(|b| u16::from_le_bytes([b[0], b[1]]))
                            .collect();
                        let (out, _) = develop(scene, &data, None, 0.0, Search::Wide, false, 1)?;
                        psnr(&out, reference, scene)
                    }
                };
                suite.points.push(DenoisePoint {
                    image: row.name,
                    scale: row.s,
                    method: row.method,
                    psnr_db,
                    seconds: row.seconds,
                    megapixels: (scene.width * scene.height) as f64 / 1e6,
                });
            }
        }
        Err(why) if !settings.require_peers => {
            *peers_skipped = Some(why.to_string());
        }
        Err(why) => {
            return Err(Error::Message(format!(
                "the denoise peers did not run: {why}"
            )))
        }
    }
    std::fs::remove_dir_all(&work).map_err(|e| raw_formats::FormatError::io(&work, e))?;
    suite.points.splice(0..0, points);
    Ok(suite)
}

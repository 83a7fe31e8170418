//! `camsim bench` without a subcommand: the benchmark suites, each figure written to one JSON
//! file, drawn as SVG charts and summed up in Markdown, with the peers measured in the same
//! run.
//!
//! | suite | chart | what |
//! |---|---|---|
//! | [`demosaic`](DemosaicSuite) | `demosaic_pareto.svg` | Mpix/s against CPSNR on Kodak and McMaster at 8 and 16 bits: every camsim method, OpenCV's and colour-demosaicing's |
//! | [`pipeline`](PipelineSuite) | `pipeline.svg` | the whole ISP's Mpix/s against its output's PSNR on the rendered demo scene, each path, method and denoise strength, with a copy and OpenCV's pipeline |
//! | [`fixed_vs_float`](FixedFloatSuite) | `fixed_vs_float.svg` | the whole pipeline's 8-bit output, fixed minus float, over the image sets as 12-bit raw; each path's throughput |
//! | [`render`](RenderSuite) | `render.svg` | RMSE against wall time for camsim and Mitsuba 3 on the Cornell box, pinhole and thin lens; each camera feature's cost alone |
//! | [`denoise`](DenoiseSuite) | `denoise.svg` | PSNR against noise level, and against Mpix/s, of camsim's profile-driven noise reduction (float and fixed) and OpenCV's and BM3D's on Kodak and McMaster as noisy 12-bit raws |
//! | [`failures`](FailureSuite) | `failures.svg` | each demosaicing method's CPSNR and false colour against the zone plate's frequency; output noise against ISO, with and without noise reduction |
//! | [`depth_of_field`](DofSuite) | `depth_of_field.svg` | the approximation 2u^2Nc/f^2 against the exact near/far limits over subject distance |
//! | [`calibration`](CalibrationSuite) | `calibration.svg` | CIE 2000 error per ColorChecker patch of the 3x3 and root-polynomial fits, in-sample and held out, for each camera and illuminant |
//! | [`tune`](tune::TuneSuite) | `tune.svg`, `tune_ccm.svg` | `camsim tune` on two simulated cameras against rpi-ctt (colour matrices per patch, lens shading) and emva1288 (noise profile), all against the simulator's truth |
//! | [`awb`](AwbSuite) | `awb.svg` | each AWB method's angular error on the demo scene relit by each of the six vendored illuminants, with and without its lamps |
//!
//! Everything timed runs on one thread (the AWB suite's renders use every core; nothing
//! there is timed). The peers run through the oracle environment's Python (the
//! one `scripts/test-all.sh` makes); without it the suites run alone and the results say the
//! peers were skipped and why. `quick` measures a few images on small tiles, for smoke runs.
//!
//! This is library code: progress goes through a callback, and nothing prints.

pub(crate) mod charts;
pub mod denoise;
mod markdown;
pub mod tune;

pub use charts::denoise as denoise_chart;
pub use denoise::{DenoisePoint, DenoiseSuite};
pub use markdown::{denoise_table, readme_blocks, summary, update_readme};

use std::path::{Path, PathBuf};
use std::time::Instant;

use isp_core::demosaic::Method;
use isp_core::frame::{RawFrame, RgbViewMut};
use isp_core::pipeline::{FixedPipeline, FloatPipeline, IspConfig};
use isp_core::CfaPattern;
use raw_formats::RawImage;
use serde::{Deserialize, Serialize};

use crate::demosaic::{self, BenchLimits, Demosaic};
use crate::develop::{with_prepared, RawInput, Runner};
use crate::error::Error;
use crate::isp_options::{IspOptions, WhiteBalance};

/// What `camsim bench` runs.
#[derive(Debug, Clone, PartialEq)]
pub struct SuiteSettings {
    /// Folder the results go into (created if missing).
    pub out: PathBuf,
    /// A few images, small tiles, short timings: a smoke run of about a minute.
    pub quick: bool,
    /// The folder holding `kodak/` and `mcmaster/` (8-bit RGB PNG images).
    pub data: PathBuf,
    /// The oracle environment's Python, which runs the peers.
    pub python: PathBuf,
    /// Fail, rather than skip the peers, when that Python cannot run them (CI).
    pub require_peers: bool,
    /// A Python with torch and demosaicnet, the learned peer of full runs
    /// (`scripts/setup-learned-peer.sh` makes `.venv-learned`); never required.
    pub learned_python: PathBuf,
    /// The command line, for the captions.
    pub command: String,
    /// The tuning peers' Python (rpi-ctt, emva1288), `.venv-tune`'s
    /// ([`tune::tune_python`]).
    pub tune_python: PathBuf,
}

/// Where the run is, for progress reports.
pub type ProgressFn<'a> = &'a mut dyn FnMut(&str);

/// The machine a run was measured on.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Machine {
    /// CPU model, from `/proc/cpuinfo` where there is one.
    pub cpu: String,
    /// Logical cores.
    pub cores: usize,
    /// Operating system and architecture.
    pub os: String,
}

impl Machine {
    /// This machine.
    pub fn this() -> Self {
        let info = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
        let field = |name: &str| {
            info.lines()
                .find(|l| l.split(':').next().map(str::trim) == Some(name))
                .and_then(|l| l.split(':').nth(1))
                .map(|m| m.split_whitespace().collect::<Vec<_>>().join(" "))
        };
        let mut cpu = field("model name").unwrap_or_else(|| "unknown CPU".into());
        // The model name alone ("AMD EPYC" under a hypervisor) does not say which generation
        // ran, nor whether the AVX-512 builds could: the kernels' speeds hinge on both.
        let mut detail = Vec::new();
        if let (Some(family), Some(model)) = (field("cpu family"), field("model")) {
            detail.push(format!("family {family} model {model}"));
        }
        #[cfg(target_arch = "x86_64")]
        detail.push(
            if std::arch::is_x86_feature_detected!("avx512f")
                && std::arch::is_x86_feature_detected!("avx512bw")
            {
                "AVX-512".to_string()
            } else if std::arch::is_x86_feature_detected!("avx2") {
                "AVX2, no AVX-512".to_string()
            } else {
                "no AVX2".to_string()
            },
        );
        if !detail.is_empty() {
            cpu = format!("{cpu} ({})", detail.join(", "));
        }
        Self {
            cpu,
            cores: std::thread::available_parallelism().map_or(1, |n| n.get()),
            os: format!("{} {}", std::env::consts::OS, std::env::consts::ARCH),
        }
    }

    /// One line for captions.
    pub fn describe(&self) -> String {
        format!("{}, {} cores, {}", self.cpu, self.cores, self.os)
    }
}

/// Every figure of a run (`bench.json`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SuiteResults {
    /// The date of the run, UTC, `YYYY-MM-DD`.
    pub date: String,
    /// The machine.
    pub machine: Machine,
    /// The command that made it.
    pub command: String,
    /// Whether this was a `--quick` smoke run (its speeds are from small tiles).
    pub quick: bool,
    /// Chart 1.
    pub demosaic: DemosaicSuite,
    /// Chart 2.
    pub pipeline: PipelineSuite,
    /// Chart 3.
    pub fixed_vs_float: FixedFloatSuite,
    /// Chart 4.
    pub render: RenderSuite,
    /// Chart 5.
    pub failures: FailureSuite,
    /// Chart 6.
    pub depth_of_field: DofSuite,
    /// Chart 7.
    pub awb: AwbSuite,
    /// Chart 8.
    pub calibration: CalibrationSuite,
    /// Chart 9 (absent from runs before it existed).
    #[serde(default)]
    pub denoise: DenoiseSuite,
    /// `camsim tune` against rpi-ctt and emva1288 on simulated cameras.
    #[serde(default)]
    pub tune: tune::TuneSuite,
    /// Why the peers did not run, if they did not.
    pub peers_skipped: Option<String>,
    /// Seconds the whole run took.
    pub seconds: f64,
}

/// One demosaicing method on one image set at one depth.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DemosaicPoint {
    /// `kodak` or `mcmaster`.
    pub dataset: String,
    /// `camsim`, `OpenCV` or `colour-demosaicing`.
    pub library: String,
    /// The method's name in its library.
    pub method: String,
    /// Sample depth, 8 or 16.
    pub bits: u8,
    /// Mean CPSNR over the images, dB.
    pub cpsnr_db: f64,
    /// Single-thread throughput on the tile, Mpix/s.
    pub mpix_per_s: f64,
    /// Images the CPSNR is averaged over.
    pub images: usize,
}

/// Chart 1's figures.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DemosaicSuite {
    /// Every method, set and depth.
    pub points: Vec<DemosaicPoint>,
    /// Side of the square mosaic whose demosaic is timed.
    pub tile: usize,
    /// The peers' library versions.
    pub peer_versions: Option<serde_json::Value>,
    /// The learned peer's (demosaicnet's) versions, when it ran (full runs only).
    #[serde(default)]
    pub learned_versions: Option<serde_json::Value>,
    /// Why the learned peer did not run, when it did not.
    #[serde(default)]
    pub learned_skipped: Option<String>,
}

/// One demosaicing method's fixed-against-float comparison.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PathAgreement {
    /// The pipeline's demosaicing method.
    pub method: String,
    /// `(fixed - float, samples)` for every difference that occurred, 8-bit output.
    pub histogram: Vec<(i32, u64)>,
    /// Output samples compared.
    pub samples: u64,
    /// The share of samples within 1 LSB.
    pub within_one_lsb: f64,
    /// The largest difference, LSB.
    pub worst_lsb: u32,
}

/// One path's whole-pipeline speed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PathSpeed {
    /// `float` or `fixed`.
    pub path: String,
    /// The demosaicing method.
    pub method: String,
    /// Threads (bands).
    #[serde(default = "one")]
    pub threads: usize,
    /// Sharpening amount (0: off).
    #[serde(default)]
    pub sharpen: f32,
    /// Best time per frame, ms.
    pub ms_per_frame: f64,
    /// Megapixels per second.
    pub mpix_per_s: f64,
    /// OpenCV's pipeline with the same threads and sharpening, timed in the same run, ms.
    #[serde(default)]
    pub opencv_ms: Option<f64>,
}

fn one() -> usize {
    1
}

/// Chart 3's figures.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FixedFloatSuite {
    /// The stages both paths ran.
    pub stages: String,
    /// Images compared (Kodak and McMaster as 12-bit RGGB raw).
    pub images: usize,
    /// Per method.
    pub agreement: Vec<PathAgreement>,
    /// The frame the speeds were measured on.
    pub speed_frame: String,
    /// Per path and method.
    pub speed: Vec<PathSpeed>,
    /// OpenCV's pipeline (`camsim bench isp`'s peer) on the same frame, if it ran.
    #[serde(default)]
    pub speed_opencv: Option<PathSpeed>,
}

/// One lens of chart 6.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DofLens {
    /// Focal length, mm.
    pub focal_length_mm: f64,
    /// f-number.
    pub f_number: f64,
    /// Hyperfocal distance, m.
    pub hyperfocal_m: f64,
    /// `(subject distance, exact depth of field, approximation)` in metres; the exact value
    /// is `None` (infinite) at and beyond the hyperfocal distance.
    pub curve: Vec<(f64, Option<f64>, f64)>,
    /// The subject distances (m) between which the approximation is within 10 % of the exact
    /// value: close up it ignores magnification, towards the hyperfocal distance the far
    /// limit's runaway.
    pub within_ten_percent_m: Option<(f64, f64)>,
}

/// Chart 6's figures.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DofSuite {
    /// Circle of confusion, mm (full frame).
    pub coc_mm: f64,
    /// The lenses.
    pub lenses: Vec<DofLens>,
}

/// One AWB estimate of chart 7.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AwbPoint {
    /// The scene's name in [`AwbSuite::scenes`].
    pub scene: String,
    /// The illuminant the scene was lit by.
    pub illuminant: String,
    /// The AWB method.
    pub method: String,
    /// Angle between the estimated and the true neutral in camera RGB, degrees.
    pub error_deg: f64,
    /// The estimate's correlated colour temperature, kelvin.
    pub cct_k: f64,
}

/// Chart 7's figures.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AwbSuite {
    /// `(name, description)` of each scene.
    pub scenes: Vec<(String, String)>,
    /// The camera whose response the sensor has.
    pub camera: String,
    /// Render size and samples per pixel.
    pub render: String,
    /// Every scene, illuminant and method.
    pub points: Vec<AwbPoint>,
}

/// One pipeline configuration of chart 2.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PipelinePoint {
    /// The scene.
    #[serde(default)]
    pub scene: String,
    /// `float` or `fixed`.
    pub path: String,
    /// The demosaicing method.
    pub method: String,
    /// Denoise strength (0: off).
    pub denoise: f32,
    /// PSNR of the 8-bit output against the truth, dB.
    pub psnr_db: f64,
    /// Best time per frame, ms.
    pub ms_per_frame: f64,
    /// Megapixels per second.
    pub mpix_per_s: f64,
}

/// A peer on chart 2's axes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PipelinePeer {
    /// The scene.
    #[serde(default)]
    pub scene: String,
    /// What it does.
    pub what: String,
    /// Best time per frame, ms.
    pub ms_per_frame: f64,
    /// Megapixels per second.
    pub mpix_per_s: f64,
    /// PSNR of its output against the truth, dB (none for a copy).
    pub psnr_db: Option<f64>,
}

/// Chart 2's figures.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PipelineSuite {
    /// The rendered scenes and the camera.
    pub scene: String,
    /// The stages every configuration runs.
    pub stages: String,
    /// Every scene, path, method and denoise strength.
    pub points: Vec<PipelinePoint>,
    /// A plain copy of the (first scene's) raw frame's bytes.
    pub copy: PipelinePeer,
    /// The OpenCV pipeline of `camsim bench isp` on each scene, if the oracle environment
    /// ran it.
    pub opencv: Vec<PipelinePeer>,
}

/// One camera under one illuminant, chart 8.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CalibrationFit {
    /// Camera response.
    pub camera: String,
    /// Illuminant.
    pub illuminant: String,
    /// Per-patch CIE 2000 error of the 3x3 matrix fitted to all 24 patches.
    pub matrix: Vec<f64>,
    /// Per patch, of the 3x3 matrix fitted to the other 23.
    pub matrix_held_out: Vec<f64>,
    /// Per patch, of the root-polynomial fit to all 24.
    pub root_polynomial: Vec<f64>,
    /// Per patch, of the root-polynomial fit to the other 23.
    pub root_polynomial_held_out: Vec<f64>,
}

/// Chart 8's figures.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CalibrationSuite {
    /// The ColorChecker patches' names, in order.
    pub patches: Vec<String>,
    /// Every camera and illuminant.
    pub fits: Vec<CalibrationFit>,
}

/// One frequency band of the zone plate, chart 5.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ZonePlateBand {
    /// The demosaicing method.
    pub method: String,
    /// The band's centre, cycles per pixel (0.5 is Nyquist).
    pub cycles_per_pixel: f64,
    /// CPSNR over the band's pixels, dB (16-bit).
    pub cpsnr_db: f64,
    /// False colour: the mean spread of the output's channels (largest minus smallest) on
    /// the grey pattern, in 8-bit steps.
    pub false_colour: f64,
}

/// Output noise at one ISO, chart 5.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NoisePoint {
    /// The demosaicing method.
    pub method: String,
    /// Denoise strength (0: off).
    pub denoise: f32,
    /// ISO.
    pub iso: f64,
    /// Standard deviation of the 8-bit output on a flat grey, mean over the channels.
    pub noise_lsb: f64,
}

/// Chart 5's figures.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FailureSuite {
    /// The zone plate.
    pub zone_plate: String,
    /// Each method and frequency band.
    pub zone_plate_bands: Vec<ZonePlateBand>,
    /// The noise measurement.
    pub noise_setup: String,
    /// Each method, denoise strength and ISO.
    pub noise: Vec<NoisePoint>,
}

/// One render of chart 4's convergence.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ConvergencePoint {
    /// `camsim` or `Mitsuba 3`.
    pub renderer: String,
    /// `pinhole` or `thin lens`.
    pub camera: String,
    /// Samples per pixel.
    pub spp: u32,
    /// Wall time of the render (one thread), s.
    pub seconds: f64,
    /// RMSE of its linear RGB against the same renderer's high-sample reference.
    pub rmse: f64,
}

/// One camera feature's cost, chart 4 (`camsim bench render`'s variants).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FeatureCost {
    /// The variant.
    pub variant: String,
    /// What it turns on.
    pub what: String,
    /// Camera samples per second, millions.
    pub msamples_per_s: f64,
    /// Time per sample over the pinhole's.
    pub relative_time: f64,
}

/// Chart 4's figures.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RenderSuite {
    /// The convergence renders.
    pub convergence_setup: String,
    /// Every renderer, camera and sample count.
    pub convergence: Vec<ConvergencePoint>,
    /// Mitsuba's version, if it ran.
    pub mitsuba: Option<String>,
    /// The feature renders.
    pub feature_setup: String,
    /// Every feature alone.
    pub features: Vec<FeatureCost>,
}

/// The files a run writes, in its folder.
pub const FILES: [&str; 13] = [
    "bench.json",
    "summary.md",
    "demosaic_pareto.svg",
    "pipeline.svg",
    "fixed_vs_float.svg",
    "render.svg",
    "failures.svg",
    "depth_of_field.svg",
    "awb.svg",
    "calibration.svg",
    "denoise.svg",
    "tune.svg",
    "tune_ccm.svg",
];

/// Runs every suite, writes [`FILES`] into `settings.out` and returns the results.
pub fn run(settings: &SuiteSettings, progress: ProgressFn<'_>) -> Result<SuiteResults, Error> {
    let started = Instant::now();
    std::fs::create_dir_all(&settings.out)
        .map_err(|e| raw_formats::FormatError::io(&settings.out, e))?;
    let mut peers_skipped = None;
    let demosaic = demosaic_suite(settings, &mut peers_skipped, progress)?;
    let pipeline = pipeline_suite(settings, &mut peers_skipped, progress)?;
    let denoise = denoise::denoise_suite(settings, &mut peers_skipped, progress)?;
    let tune = tune::tune_suite(
        settings,
        &settings.tune_python,
        &mut peers_skipped,
        progress,
    )?;
    let fixed_vs_float = fixed_float_suite(settings, progress)?;
    let render = render_suite(settings, &mut peers_skipped, progress)?;
    let failures = failure_suite(settings, progress)?;
    progress("depth of field");
    let depth_of_field = dof_suite()?;
    let awb = awb_suite(settings, progress)?;
    let calibration = calibration_suite(progress)?;
    let results = SuiteResults {
        date: today_utc(),
        machine: Machine::this(),
        command: settings.command.clone(),
        quick: settings.quick,
        demosaic,
        pipeline,
        fixed_vs_float,
        render,
        failures,
        depth_of_field,
        awb,
        calibration,
        denoise,
        tune,
        peers_skipped,
        seconds: started.elapsed().as_secs_f64(),
    };
    write_all(&results, &settings.out, progress)?;
    Ok(results)
}

/// Writes the JSON, the charts and the summary of `results` into `out` (also used to redraw
/// the charts from a saved `bench.json`).
pub fn write_all(
    results: &SuiteResults,
    out: &Path,
    progress: ProgressFn<'_>,
) -> Result<(), Error> {
    let write = |name: &str, text: &str| {
        let path = out.join(name);
        std::fs::write(&path, text)
            .map_err(|e| Error::Format(raw_formats::FormatError::io(path, e)))
    };
    let json = serde_json::to_string_pretty(results).map_err(|e| Error::Message(e.to_string()))?;
    write("bench.json", &(json + "\n"))?;
    progress("charts");
    charts::demosaic_pareto(results, &out.join("demosaic_pareto.svg"))?;
    charts::pipeline(results, &out.join("pipeline.svg"))?;
    charts::fixed_vs_float(results, &out.join("fixed_vs_float.svg"))?;
    charts::render(results, &out.join("render.svg"))?;
    charts::failures(results, &out.join("failures.svg"))?;
    charts::depth_of_field(results, &out.join("depth_of_field.svg"))?;
    charts::awb(results, &out.join("awb.svg"))?;
    charts::calibration(results, &out.join("calibration.svg"))?;
    if !results.denoise.points.is_empty() {
        charts::denoise(
            &results.denoise,
            &caption(results),
            &out.join("denoise.svg"),
        )?;
    }
    if !results.tune.cameras.is_empty() {
        tune::charts(&results.tune, &caption(results), out)?;
    }
    write("summary.md", &summary(results))
}

fn demosaic_suite(
    settings: &SuiteSettings,
    peers_skipped: &mut Option<String>,
    progress: ProgressFn<'_>,
) -> Result<DemosaicSuite, Error> {
    let limits = if settings.quick {
        BenchLimits {
            images: Some(2),
            tile: 512,
            min_seconds: 0.05,
        }
    } else {
        BenchLimits::default()
    };
    let mut points = Vec::new();
    for set in ["kodak", "mcmaster"] {
        for bits in [8, 16] {
            let rows = demosaic::bench_limited(
                &settings.data.join(set),
                bits,
                &Demosaic::ALL,
                limits,
                &mut |what| progress(&format!("demosaic: {set} {what}")),
            )?;
            let images = demosaic::dataset_images(&settings.data.join(set), limits.images)?.len();
            points.extend(rows.into_iter().map(|r| DemosaicPoint {
                dataset: set.into(),
                library: "camsim".into(),
                method: r.method.into(),
                bits,
                cpsnr_db: r.cpsnr_db,
                mpix_per_s: r.mpix_per_s,
                images,
            }));
        }
    }
    progress("demosaic: peers (OpenCV, colour-demosaicing)");
    let request = serde_json::json!({
        "datasets": [settings.data.join("kodak"), settings.data.join("mcmaster")],
        "images": limits.images,
        "tile": limits.tile,
        "min_seconds": limits.min_seconds,
        "depths": [8, 16],
    });
    let mut peer_versions = None;
    let script = include_str!("demosaic_peers.py");
    match run_python::<DemosaicReply>(&settings.python, script, &request) {
        Ok(reply) => {
            points.extend(reply.rows);
            peer_versions = Some(reply.versions);
        }
        Err(why) if !settings.require_peers => *peers_skipped = Some(why.to_string()),
        Err(why) => return Err(Error::Message(format!("the peers did not run: {why}"))),
    }
    let (mut learned_versions, mut learned_skipped) = (None, None);
    if settings.quick {
        learned_skipped = Some("quick runs leave the learned peer out".into());
    } else {
        progress("demosaic: learned peer (demosaicnet, about two minutes)");
        let request = serde_json::json!({
            "datasets": [settings.data.join("kodak"), settings.data.join("mcmaster")],
            "images": limits.images,
            "tile": LEARNED_TILE,
            "depths": [8, 16],
        });
        let script = include_str!("demosaic_learned.py");
        match run_python::<DemosaicReply>(&settings.learned_python, script, &request) {
            Ok(reply) => {
                points.extend(reply.rows);
                learned_versions = Some(reply.versions);
            }
            Err(why) => {
                learned_skipped = Some(format!(
                    "{why}; scripts/setup-learned-peer.sh makes .venv-learned \
                     (or set CAMSIM_LEARNED_PYTHON)"
                ))
            }
        }
    }
    Ok(DemosaicSuite {
        points,
        tile: limits.tile,
        peer_versions,
        learned_versions,
        learned_skipped,
    })
}

/// Side of the tile the learned peer is timed on (its forward pass also computes a mirrored
/// margin of about 50 pixels, which a caller would pay as well).
const LEARNED_TILE: usize = 512;

/// Runs `script` with the oracle Python and one JSON argument; its stdout parsed as JSON, or
/// why it could not run.
pub(crate) fn run_python<R: serde::de::DeserializeOwned>(
    python: &Path,
    script: &str,
    request: &serde_json::Value,
) -> Result<R, PeerError> {
    python_present(python)?;
    let output = std::process::Command::new(python)
        .arg("-c")
        .arg(script)
        .arg(request.to_string())
        .stderr(std::process::Stdio::inherit())
        .output()
        .map_err(|source| PeerError::Io {
            what: format!("running {}", python.display()),
            source,
        })?;
    if !output.status.success() {
        return Err(PeerError::Failed {
            script: "the peer script",
            detail: format!("{}; its error is above", output.status),
        });
    }
    serde_json::from_slice(&output.stdout).map_err(|e| PeerError::Reply {
        script: "the peer script",
        problem: e.to_string(),
    })
}

/// Why a peer (a Python script run with the oracle's interpreter) gave no figures.
#[derive(Debug)]
#[non_exhaustive]
pub enum PeerError {
    /// The interpreter is not there.
    NoPython {
        /// Where it was looked for.
        python: PathBuf,
    },
    /// A file or process operation failed.
    Io {
        /// What was being done, e.g. `running .venv/bin/python`.
        what: String,
        /// The system's reason.
        source: std::io::Error,
    },
    /// The script ran and failed.
    Failed {
        /// Which script.
        script: &'static str,
        /// Its exit status or last line of error.
        detail: String,
    },
    /// The script's reply could not be used.
    Reply {
        /// Which script.
        script: &'static str,
        /// What was wrong with it.
        problem: String,
    },
    /// The peer has no counterpart for this input.
    NotApplicable(&'static str),
}

impl std::fmt::Display for PeerError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::NoPython { python } => write!(
                f,
                "no Python at {} (scripts/test-all.sh creates the oracle's .venv; or set \
                 CAMSIM_ORACLE_PYTHON)",
                python.display()
            ),
            Self::Io { what, source } => write!(f, "{what}: {source}"),
            Self::Failed { script, detail } => write!(f, "{script} failed: {detail}"),
            Self::Reply { script, problem } => write!(f, "{script}'s reply: {problem}"),
            Self::NotApplicable(why) => f.write_str(why),
        }
    }
}

impl std::error::Error for PeerError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            Self::Io { source, .. } => Some(source),
            _ => None,
        }
    }
}

/// Whether `python` exists, or why the peers cannot run.
fn python_present(python: &Path) -> Result<(), PeerError> {
    if python.is_file() {
        Ok(())
    } else {
        Err(PeerError::NoPython {
            python: python.to_owned(),
        })
    }
}

/// What the demosaicing peer scripts print.
#[derive(Deserialize)]
struct DemosaicReply {
    rows: Vec<DemosaicPoint>,
    versions: serde_json::Value,
}

/// Chart 2's scenes: the demo scene (ColorChecker, bokeh, motion, fringes) under its own D65
/// and relit by illuminant A (tungsten: the white balance and the colour matrix work harder).
/// Each is a name, the scene and its illuminant. (The Cornell box is not one: its light is
/// warm RGB, and an RGB scene's truth assumes a white one.)
const PIPELINE_SCENES: [(&str, &str, &str); 2] =
    [("demo, D65", "demo", "D65"), ("demo under A", "demo", "A")];
/// Chart 2's noise-reduction strengths (multipliers on the profile's default).
const DENOISE: [f32; 3] = [0.0, 0.5, 1.0];

fn pipeline_suite(
    settings: &SuiteSettings,
    peers_skipped: &mut Option<String>,
    progress: ProgressFn<'_>,
) -> Result<PipelineSuite, Error> {
    use crate::demo::{capture, DemoSettings};
    use isp_core::metrics::psnr;
    use isp_core::pipeline::Input;

    let (spp, repeats) = if settings.quick { (16, 3) } else { (64, 20) };
    let mut points = Vec::new();
    let mut opencv = Vec::new();
    let mut copy = None;
    let mut described = Vec::new();
    let demo = DemoSettings::default();
    for (name, scene, illuminant) in PIPELINE_SCENES {
        let film = host_tracer::tracer::scene_file::load(scene)?.film;
        // The scene's own size (half of it in quick runs, kept even for the CFA).
        let (width, height) = if settings.quick {
            ((film.0 / 2) & !1, (film.1 / 2) & !1)
        } else {
            film
        };
        progress(&format!(
            "pipeline: rendering {name} at {width} x {height}, {spp} spp"
        ));
        let captured = capture(
            &DemoSettings {
                scene: scene.into(),
                illuminant: Some(illuminant.into()),
                width: Some(width),
                height: Some(height),
                spp: Some(spp),
                ..DemoSettings::default()
            },
            &|_| {},
        )?;
        let (w, h) = (captured.width(), captured.height());
        let raw = captured.capture.raw.frame()?;
        let input = Input::Mosaic(raw);
        // Speed is timed on the frame tiled 4 x 4 (the CFA phase kept: the sides are even),
        // so the frame is megapixels, as a camera's is, not a few hundred kilopixels that stay
        // in cache; quality is measured on the frame itself.
        let source = &captured.capture.raw;
        let (tw, th) = (4 * w, 4 * h);
        let tiled = RawImage::new(
            tw,
            th,
            source.pattern,
            source.bits,
            source.black_level,
            source.white_level,
            (0..tw * th)
                .map(|i| source.samples[(i / tw % h) * w + i % tw % w])
                .collect(),
        )?;
        let tiled_frame = tiled.frame()?;
        let tiled_input = Input::Mosaic(tiled_frame);
        let mpix = |ms: f64| (tw * th) as f64 / (ms * 1e3);
        let score = |out: &[u8]| {
            let out: Vec<u16> = out.iter().map(|v| u16::from(*v)).collect();
            psnr(&out, &captured.truth8, 255.0)
        };
        for fixed in [false, true] {
            let path = if fixed { "fixed" } else { "float" };
            for method in PIPELINE_METHODS {
                for denoise in DENOISE {
                    progress(&format!(
                        "pipeline: {name}, {path} {} denoise {denoise}",
                        method.name()
                    ));
                    let chroma = crate::develop::default_chroma_denoise(denoise);
                    let config = captured.isp_config(method, denoise, chroma)?;
                    let mut out = vec![0u8; w * h * 3];
                    Runner::new(&input, &config, fixed, 8, 1)?.best_ms(&mut out, 1)?;
                    let ms = Runner::new(&tiled_input, &config, fixed, 8, 1)?
                        .best_ms(&mut vec![0u8; tw * th * 3], repeats)?;
                    points.push(PipelinePoint {
                        scene: name.into(),
                        path: path.into(),
                        method: method.name().into(),
                        denoise,
                        psnr_db: score(&out),
                        ms_per_frame: ms,
                        mpix_per_s: mpix(ms),
                    });
                }
            }
        }
        if copy.is_none() {
            let ms = copy_ms(&tiled.samples, repeats.max(10));
            copy = Some(PipelinePeer {
                scene: name.into(),
                what: "copy of the raw frame".into(),
                ms_per_frame: ms,
                mpix_per_s: mpix(ms),
                psnr_db: None,
            });
        }
        progress(&format!("pipeline: {name}, OpenCV"));
        let config = captured.isp_config(Method::Bilinear, 0.0, 0.0)?;
        let mut image = Vec::new();
        match opencv_pipeline(&settings.python, &raw, &config, 1, 1, Some(&mut image)).and_then(
            |_| opencv_pipeline(&settings.python, &tiled_frame, &config, 1, repeats, None),
        ) {
            Ok(ms) => opencv.push(PipelinePeer {
                scene: name.into(),
                what: "OpenCV: subtract, cvtColor (Bayer bilinear), multiply, transform, LUT"
                    .into(),
                ms_per_frame: ms,
                mpix_per_s: mpix(ms),
                psnr_db: Some(score(&image)),
            }),
            Err(why) if !settings.require_peers => {
                peers_skipped.get_or_insert(why.to_string());
            }
            Err(why) => {
                return Err(Error::Message(format!(
                    "the OpenCV pipeline did not run: {why}"
                )))
            }
        }
        described.push(format!("{name} {w} x {h} (timed tiled 4 x 4, {tw} x {th})"));
    }
    let copy = copy.ok_or(Error::Message("no scene was rendered".into()))?;
    Ok(PipelineSuite {
        scene: format!(
            "{}; {spp} spp, through a simulated {} ({} sensor, ISO {}, {}-bit)",
            described.join(", "),
            demo.camera,
            demo.sensor.name(),
            demo.iso,
            demo.bits
        ),
        stages:
            "static defects, lens shading, white balance (AWB), demosaic, denoise, highlights, \
                 colour matrix, sRGB encoding, chroma denoise (on with denoise); one thread"
                .into(),
        points,
        copy,
        opencv,
    })
}

/// The fastest of `repeats` copies of `samples` into another buffer, in milliseconds.
pub fn copy_ms(samples: &[u16], repeats: u32) -> f64 {
    let mut target = vec![0u16; samples.len()];
    let mut best = f64::INFINITY;
    for _ in 0..repeats.max(1) {
        let start = Instant::now();
        target.copy_from_slice(std::hint::black_box(samples));
        std::hint::black_box(&mut target);
        best = best.min(start.elapsed().as_secs_f64() * 1e3);
    }
    best
}

/// The 12-bit raw the fixed-against-float comparison runs on: black 64, 255 maps to 3889.
const RAW_BLACK: u16 = 64;
const RAW_WHITE: u16 = 4095;
/// A camera-like colour matrix for the comparison (rows sum to one).
const CCM: [[f32; 3]; 3] = [[1.6, -0.4, -0.2], [-0.3, 1.5, -0.2], [0.0, -0.5, 1.5]];
/// The pipeline methods charted.
const PIPELINE_METHODS: [Method; 3] = [Method::Bilinear, Method::Mhc, Method::Directional];

fn fixed_float_suite(
    settings: &SuiteSettings,
    progress: ProgressFn<'_>,
) -> Result<FixedFloatSuite, Error> {
    let per_set = if settings.quick { Some(2) } else { None };
    let mut images = Vec::new();
    for set in ["kodak", "mcmaster"] {
        for path in demosaic::dataset_images(&settings.data.join(set), per_set)? {
            images.push(raw_formats::image::read(&path)?);
        }
    }
    let mut agreement = Vec::new();
    for method in PIPELINE_METHODS {
        let mut counts = std::collections::BTreeMap::<i32, u64>::new();
        for (i, rgb) in images.iter().enumerate() {
            progress(&format!(
                "fixed against float: {} {}/{}",
                method.name(),
                i + 1,
                images.len()
            ));
            let (w, h) = (rgb.width, rgb.height);
            let data: Vec<u16> = demosaic::mosaic_from_rgb(rgb, CfaPattern::Rggb, 15)
                .into_iter()
                .map(|v| v + RAW_BLACK)
                .collect();
            let raw = RawFrame::new(
                &data,
                w,
                h,
                w,
                12,
                CfaPattern::Rggb,
                [RAW_BLACK; 4],
                RAW_WHITE,
            )?;
            let config = comparison_config(method);
            let len = config.scratch_len(w, h).ok_or(Error::Message(
                "the frame's scratch does not fit memory".into(),
            ))?;
            let (mut float, mut fixed) = (vec![0u8; w * h * 3], vec![0u8; w * h * 3]);
            FloatPipeline::new(&config)?.run(
                &raw,
                0..h,
                &mut vec![0.0; len],
                &mut RgbViewMut::new(&mut float, w, h, 3 * w)?,
            )?;
            FixedPipeline::new(&config, 8)?.run(
                &raw,
                0..h,
                &mut vec![0; len],
                &mut RgbViewMut::new(&mut fixed, w, h, 3 * w)?,
            )?;
            for (a, b) in fixed.iter().zip(&float) {
                *counts.entry(i32::from(*a) - i32::from(*b)).or_default() += 1;
            }
        }
        let samples: u64 = counts.values().sum();
        let within: u64 = counts
            .iter()
            .filter(|(d, _)| d.abs() <= 1)
            .map(|(_, n)| n)
            .sum();
        agreement.push(PathAgreement {
            method: method.name().into(),
            worst_lsb: counts.keys().map(|d| d.unsigned_abs()).max().unwrap_or(0),
            histogram: counts.into_iter().collect(),
            samples,
            within_one_lsb: within as f64 / samples.max(1) as f64,
        });
    }
    let (frame, frame_name) = synthetic_raw()?;
    let repeats = if settings.quick { 2 } else { 10 };
    let (w, h) = (frame.raw.width, frame.raw.height);
    // Issue 19's configurations: one thread for each path and method, two threads, and
    // sharpening (the general engine); each beside OpenCV's pipeline with the same threads and
    // sharpening, timed in the same run.
    let mut configs: Vec<(bool, Method, usize, f32)> = Vec::new();
    for fixed in [false, true] {
        for method in PIPELINE_METHODS {
            configs.push((fixed, method, 1, 0.0));
        }
    }
    configs.extend([
        (true, Method::Mhc, 2, 0.0),
        (false, Method::Directional, 2, 0.0),
        (true, Method::Directional, 2, 0.0),
        (true, Method::Mhc, 1, 1.0),
    ]);
    let mut speed = Vec::new();
    for (fixed, method, threads, sharpen) in configs {
        let path = if fixed { "fixed" } else { "float" };
        progress(&format!(
            "pipeline speed: {path} {}, {threads} thread(s), sharpen {sharpen}",
            method.name()
        ));
        let options = IspOptions {
            fixed: Some(fixed),
            demosaic: Some(method),
            dpc_threshold: Some(64),
            white_balance: Some(WhiteBalance::Gains([1.9, 1.0, 1.6])),
            ccm: Some(CCM),
            highlight_knee: Some(1.0),
            sharpen: Some(sharpen),
            out_bits: Some(8),
            // Issue 19's stages, which have no noise reduction.
            denoise: Some(0.0),
            ..IspOptions::default()
        };
        let (ms, opencv) = with_prepared(&frame, &options, None, |p| {
            let mut runner = Runner::new(&p.input, &p.config, p.fixed, 8, threads)?;
            let ms = runner.best_ms(&mut vec![0u8; w * h * 3], repeats)?;
            let opencv = match &p.input {
                isp_core::pipeline::Input::Mosaic(raw) => {
                    opencv_pipeline(&settings.python, raw, &p.config, threads, repeats, None)
                }
                isp_core::pipeline::Input::Linear(_) => {
                    Err(PeerError::NotApplicable("a linear frame"))
                }
            };
            Ok((ms, opencv))
        })?;
        let opencv_ms = match opencv {
            Ok(ms) => Some(ms),
            Err(_) if !settings.require_peers => None,
            Err(why) => {
                return Err(Error::Message(format!(
                    "the OpenCV pipeline did not run: {why}"
                )))
            }
        };
        speed.push(PathSpeed {
            path: path.into(),
            method: method.name().into(),
            threads,
            sharpen,
            ms_per_frame: ms,
            mpix_per_s: (w * h) as f64 / (ms * 1e3),
            opencv_ms,
        });
    }
    let speed_opencv = speed
        .iter()
        .find(|q| q.threads == 1 && q.sharpen == 0.0)
        .and_then(|q| q.opencv_ms)
        .map(|ms| PathSpeed {
            path: "OpenCV".into(),
            method: "bilinear (cvtColor)".into(),
            threads: 1,
            sharpen: 0.0,
            ms_per_frame: ms,
            mpix_per_s: (w * h) as f64 / (ms * 1e3),
            opencv_ms: Some(ms),
        });
    Ok(FixedFloatSuite {
        stages: "defective pixels (dynamic), black level, white balance, demosaic, highlights \
                 (knee 0.9), colour matrix, sRGB encoding"
            .into(),
        images: images.len(),
        agreement,
        speed_frame: format!(
            "{frame_name}; dynamic defect correction (threshold 64), black level, white balance \
             1.9/1/1.6, demosaic, colour matrix, sRGB encoding (no highlight stage: knee 1); \
             best of {repeats}"
        ),
        speed,
        speed_opencv,
    })
}

/// The comparison's pipeline: the stages a camera runs, with `method`.
fn comparison_config(method: Method) -> IspConfig<'static> {
    IspConfig {
        demosaic: method,
        wb_gains: [1.4, 1.0, 1.2],
        highlight_knee: crate::develop::DEFAULT_HIGHLIGHT_KNEE,
        ccm: CCM,
        dpc: isp_core::dpc::DpcConfig {
            static_defects: &[],
            dynamic_threshold: Some(600),
        },
        ..IspConfig::default()
    }
}

/// The frame `camsim bench isp` and the pipeline speeds use: 2592 x 1968, 10 bits, RGGB,
/// black 64: gentle ramps per CFA colour with a little noise, as a scene has (not flat, not
/// pure noise); and its description.
pub fn synthetic_raw() -> Result<(RawInput, &'static str), Error> {
    let (w, h) = (2592usize, 1968usize);
    let mut state = 0x2545_f491u32;
    let samples = (0..w * h)
        .map(|i| {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            let (x, y) = (i % w, i / w);
            let colour = (y & 1) + (x & 1);
            let ramp = 64 + 150 * colour + x * 500 / w + y * 150 / h;
            (ramp + (state % 24) as usize).min(1023) as u16
        })
        .collect();
    let raw = RawImage::new(w, h, CfaPattern::Rggb, 10, [64; 4], 1023, samples)?;
    let mut input = RawInput::plain(raw);
    input.defaults.black_level = Some(vec![64]);
    input.defaults.white_level = Some(1023);
    Ok((input, "synthesised 2592x1968 10-bit RGGB"))
}

/// The thin lens of chart 4 (scene units, as `scripts/bench_tracer.py`): aperture radius and
/// focus distance.
const THIN_LENS: (f32, f32) = (0.1, 3.9);

fn render_suite(
    settings: &SuiteSettings,
    peers_skipped: &mut Option<String>,
    progress: ProgressFn<'_>,
) -> Result<RenderSuite, Error> {
    use host_tracer::render_bench::{bench, BenchSettings};
    use host_tracer::tracer::render::{render, RenderSettings};
    use host_tracer::tracer::scene_file;

    let cornell = scene_file::load("cornell-box")?;
    let (size, spps, reference_spp): (u32, &[u32], u32) = if settings.quick {
        (64, &[1, 4, 16], 256)
    } else {
        (128, &[1, 2, 4, 8, 16, 32, 64, 128, 256], 4096)
    };
    let cameras = [("pinhole", 0.0f32), ("thin lens", THIN_LENS.0)];
    let mut convergence = Vec::new();
    let mut references = Vec::new();
    for (camera, aperture) in cameras {
        let mut scene = cornell.clone();
        if aperture > 0.0 {
            scene.camera.aperture_radius_mm = aperture / scene.camera.units_per_mm;
            scene.camera.focus_distance = Some(THIN_LENS.1);
        }
        let mut render_settings = RenderSettings::for_scene(&scene);
        render_settings.width = size;
        render_settings.height = size;
        progress(&format!("render: {camera} reference, {reference_spp} spp"));
        render_settings.spp = reference_spp;
        render_settings.threads = 0;
        render_settings.seed = 7;
        let reference = render(&scene, &render_settings)?.rgb;
        render_settings.threads = 1;
        render_settings.seed = 1;
        for &spp in spps {
            progress(&format!("render: camsim {camera}, {spp} spp"));
            render_settings.spp = spp;
            let image = render(&scene, &render_settings)?;
            let squared: f64 = image
                .rgb
                .iter()
                .zip(&reference)
                .map(|(a, b)| f64::from(a - b).powi(2))
                .sum();
            convergence.push(ConvergencePoint {
                renderer: "camsim".into(),
                camera: camera.into(),
                spp,
                seconds: image.elapsed.as_secs_f64(),
                rmse: (squared / reference.len() as f64).sqrt(),
            });
        }
        references.push((camera, aperture));
    }
    progress("render: Mitsuba 3");
    let request = serde_json::json!({
        "size": size,
        "depth": cornell.max_depth,
        "spps": spps,
        "reference_spp": reference_spp,
        "cameras": references
            .iter()
            .map(|(camera, aperture)| {
                serde_json::json!({"name": camera, "aperture": aperture, "focus": THIN_LENS.1})
            })
            .collect::<Vec<_>>(),
    });
    #[derive(Deserialize)]
    struct MitsubaReply {
        rows: Vec<ConvergencePoint>,
        version: String,
    }
    let mut mitsuba = None;
    let script = include_str!("render_mitsuba.py");
    match run_python::<MitsubaReply>(&settings.python, script, &request) {
        Ok(reply) => {
            convergence.extend(reply.rows);
            mitsuba = Some(reply.version);
        }
        Err(why) if !settings.require_peers => {
            peers_skipped.get_or_insert(why.to_string());
        }
        Err(why) => {
            return Err(Error::Message(format!(
                "the Mitsuba peer did not run: {why}"
            )))
        }
    }

    let bench_settings = BenchSettings {
        width: if settings.quick { 64 } else { 256 },
        height: if settings.quick { 64 } else { 256 },
        spp: if settings.quick { 4 } else { 16 },
        seed: 0,
        threads: 1,
        repeats: if settings.quick { 1 } else { 3 },
        aperture_radius: THIN_LENS.0,
    };
    let rows = bench(&cornell, &bench_settings, &mut |variant| {
        progress(&format!("render: feature {variant}"))
    })?;
    Ok(RenderSuite {
        convergence_setup: format!(
            "cornell-box (Mitsuba 3's), {size} x {size}, max depth {}, one thread, seed 1; thin \
             lens: aperture radius {} and focus {} scene units; RMSE of linear RGB against the same \
             renderer at {reference_spp} spp (every core, seed 7)",
            cornell.max_depth, THIN_LENS.0, THIN_LENS.1
        ),
        convergence,
        mitsuba,
        feature_setup: format!(
            "cornell-box, {} x {}, {} spp, one thread, best of {}; time per sample over the pinhole's",
            bench_settings.width, bench_settings.height, bench_settings.spp, bench_settings.repeats
        ),
        features: rows
            .into_iter()
            .map(|r| FeatureCost {
                variant: r.variant.into(),
                what: r.what.into(),
                msamples_per_s: r.msamples_per_s,
                relative_time: r.relative_time,
            })
            .collect(),
    })
}

/// Side of the zone plate, pixels.
const ZONE_PLATE: usize = 512;
/// Width of its frequency bands, cycles per pixel.
const BAND: f64 = 0.025;
/// The ISOs of the noise measurement.
const ISOS: [f64; 7] = [100.0, 200.0, 400.0, 800.0, 1600.0, 3200.0, 6400.0];

fn failure_suite(
    settings: &SuiteSettings,
    progress: ProgressFn<'_>,
) -> Result<FailureSuite, Error> {
    use host_tracer::sensor::{capture, LensGeometry, SensorConfig};
    use isp_core::pipeline::Input;

    // A grey zone plate 0.5 + 0.45 cos(pi k r^2) about the centre: its local frequency is
    // k r cycles per pixel, 0.5 (Nyquist) at the edges' midpoints. Each band of frequency is
    // scored on the pixels whose radius gives it, away from the image border.
    let n = ZONE_PLATE;
    let k = 0.5 / (n as f64 / 2.0);
    let centre = n as f64 / 2.0 - 0.5;
    let radius = |x: usize, y: usize| (x as f64 - centre).hypot(y as f64 - centre);
    let grey: Vec<u16> = (0..n * n)
        .map(|i| {
            let r = radius(i % n, i / n);
            let v = 0.5 + 0.45 * (std::f64::consts::PI * k * r * r).cos();
            (v * 65535.0).round() as u16
        })
        .collect();
    let mosaic: Vec<u16> = grey.clone();
    let bands = (0.5 / BAND).round() as usize;
    let mut zone_plate_bands = Vec::new();
    // Every method but the bilinear variant with OpenCV's borders (the same inside).
    let methods = Demosaic::ALL
        .into_iter()
        .filter(|m| *m != Demosaic::BILINEAR_OPENCV);
    for method in methods {
        progress(&format!("zone plate: {}", method.name()));
        let mut out = vec![0u16; 3 * n * n];
        method.run(&mosaic, n, n, CfaPattern::Rggb, &mut out)?;
        let mut sums = vec![(0.0f64, 0.0f64, 0usize); bands];
        for y in 10..n - 10 {
            for x in 10..n - 10 {
                let band = (k * radius(x, y) / BAND) as usize;
                if band >= bands {
                    continue;
                }
                let truth = f64::from(grey[y * n + x]);
                let px = &out[3 * (y * n + x)..][..3];
                let error: f64 = px.iter().map(|v| (f64::from(*v) - truth).powi(2)).sum();
                let spread =
                    px.iter().max().copied().unwrap_or(0) - px.iter().min().copied().unwrap_or(0);
                let s = &mut sums[band];
                s.0 += error;
                s.1 += f64::from(spread) / 257.0;
                s.2 += 1;
            }
        }
        for (band, (error, spread, count)) in sums.into_iter().enumerate() {
            if count == 0 {
                continue;
            }
            let mse = error / (3 * count) as f64;
            zone_plate_bands.push(ZonePlateBand {
                method: method.name().into(),
                cycles_per_pixel: (band as f64 + 0.5) * BAND,
                cpsnr_db: 10.0 * (65535.0f64 * 65535.0 / mse.max(1e-12)).log10(),
                false_colour: spread / count as f64,
            });
        }
    }

    // Output noise: a flat grey (camera RGB 0.18, neutral) beside a white strip that the
    // automatic exposure meters at base ISO; each ISO then shortens the exposure by its
    // factor, so the raw level stays and the light falls, as a camera's ISO does.
    let (w, h) = if settings.quick {
        (128, 96)
    } else {
        (256, 192)
    };
    let strip = h / 12;
    let camera_rgb: Vec<f32> = (0..w * h)
        .flat_map(|i| {
            let v = if i / w < strip { 1.0 } else { 0.18 };
            [v; 3]
        })
        .collect();
    let lens = LensGeometry::thin_lens(50.0, 50.0 / 2.8 / 2.0, [36.0, 24.0]);
    let mut config = SensorConfig {
        noise: SensorConfig::realistic().noise,
        ..SensorConfig::ideal()
    };
    let base_exposure = capture(&camera_rgb, w, h, lens, &config)?.exposure_s;
    let methods = [Method::Bilinear, Method::Mhc, Method::Directional];
    let mut noise = Vec::new();
    for iso in ISOS {
        progress(&format!("noise at ISO {iso}"));
        config.iso = iso;
        config.exposure_s = Some(base_exposure * 100.0 / iso);
        let captured = capture(&camera_rgb, w, h, lens, &config)?;
        let input = Input::Mosaic(captured.raw.frame()?);
        for method in methods {
            for denoise in [0.0, 1.0] {
                let config = IspConfig {
                    demosaic: method,
                    denoise,
                    noise: Some(captured.noise_profile),
                    ..IspConfig::default()
                };
                let mut out = vec![0u8; 3 * w * h];
                Runner::new(&input, &config, true, 8, 1)?.best_ms(&mut out, 1)?;
                let mut deviation = 0.0;
                for c in 0..3 {
                    let values: Vec<f64> = (strip + 8..h - 8)
                        .flat_map(|y| (8..w - 8).map(move |x| (x, y)))
                        .map(|(x, y)| f64::from(out[3 * (y * w + x) + c]))
                        .collect();
                    let mean = values.iter().sum::<f64>() / values.len() as f64;
                    let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>()
                        / values.len() as f64;
                    deviation += var.sqrt() / 3.0;
                }
                noise.push(NoisePoint {
                    method: method.name().into(),
                    denoise,
                    iso,
                    noise_lsb: deviation,
                });
            }
        }
    }
    Ok(FailureSuite {
        zone_plate: format!(
            "grey zone plate 0.5 + 0.45 cos(pi k r^2), {n} x {n}, 16-bit RGGB mosaic; bands of \
             {BAND} cycles per pixel"
        ),
        zone_plate_bands,
        noise_setup: format!(
            "flat grey (18 % of a metered white) {w} x {h} through the realistic sensor's noise \
             (no shading, no defects), 12-bit; the fixed-point pipeline with no colour matrix, \
             8-bit sRGB out"
        ),
        noise,
    })
}

/// Full-frame circle of confusion, mm.
const COC_MM: f64 = 0.03;
/// Chart 6's lenses: focal length (mm) and f-number.
const LENSES: [(f64, f64); 4] = [(24.0, 8.0), (50.0, 2.0), (85.0, 1.8), (200.0, 4.0)];

fn dof_suite() -> Result<DofSuite, Error> {
    use optics_core::dof::{depth_of_field, depth_of_field_approx, hyperfocal_distance};
    let optics = |source| Error::Optics {
        option: "depth of field",
        source,
    };
    let mut lenses = Vec::new();
    for (f, n) in LENSES {
        let hyperfocal_mm = hyperfocal_distance(f, n, COC_MM)
            .map_err(optics)?
            .finite()
            .unwrap_or(f64::INFINITY);
        // Subject distances from 2 f (1:1 macro) to 1 km, evenly on a log axis.
        let (near, far) = ((2.0 * f).ln(), 1e6f64.ln());
        let steps = 240;
        let mut curve = Vec::new();
        let mut within_ten_percent_m: Option<(f64, f64)> = None;
        for k in 0..=steps {
            let s = (near + (far - near) * k as f64 / steps as f64).exp();
            let exact = depth_of_field(f, n, COC_MM, s)
                .map_err(optics)?
                .total
                .finite();
            let approx = depth_of_field_approx(f, n, COC_MM, s)
                .map_err(optics)?
                .finite()
                .unwrap_or(f64::INFINITY);
            if exact.is_some_and(|e| (approx - e).abs() <= 0.1 * e) {
                let first = within_ten_percent_m.map_or(s / 1e3, |w| w.0);
                within_ten_percent_m = Some((first, s / 1e3));
            }
            curve.push((s / 1e3, exact.map(|e| e / 1e3), approx / 1e3));
        }
        lenses.push(DofLens {
            focal_length_mm: f,
            f_number: n,
            hyperfocal_m: hyperfocal_mm / 1e3,
            curve,
            within_ten_percent_m,
        });
    }
    Ok(DofSuite {
        coc_mm: COC_MM,
        lenses,
    })
}

/// Runs the OpenCV pipeline (`isp_opencv.py`: black level, Bayer `cvtColor`, gains,
/// `cv2.transform`, `cv2.LUT`) on `raw` with `config`'s gains and matrix through `python`;
/// its best time over `repeats` in milliseconds, or why it could not run. With `output`, its
/// 8-bit RGB image (`3 * width * height` samples) is read back into it.
pub fn opencv_pipeline(
    python: &Path,
    raw: &RawFrame<'_>,
    config: &IspConfig<'_>,
    threads: usize,
    repeats: u32,
    output: Option<&mut Vec<u8>>,
) -> Result<f64, PeerError> {
    python_present(python)?;
    let mosaic = raw.mosaic();
    let (w, h) = (mosaic.width(), mosaic.height());
    let bytes: Vec<u8> = (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .flat_map(|(x, y)| mosaic.get(x, y).unwrap_or(0).to_le_bytes())
        .collect();
    let stem = std::env::temp_dir().join(format!("camsim-isp-opencv-{}", std::process::id()));
    let (frame, image) = (stem.with_extension("u16"), stem.with_extension("rgb"));
    std::fs::write(&frame, &bytes).map_err(|source| PeerError::Io {
        what: format!("writing {}", frame.display()),
        source,
    })?;
    let pattern = format!("{:?}", mosaic.pattern()).to_uppercase();
    let request = serde_json::json!({
        "frame": frame.display().to_string(),
        "width": w,
        "height": h,
        "pattern": pattern,
        "black": raw.black_level()[0],
        "white": raw.white_level(),
        "wb": config.wb_gains.map(|g| g * config.gain),
        "ccm": config.ccm,
        "sharpen": config.sharpen,
        // Raw noise reduction's counterpart: OpenCV's non-local means on the mosaic packed as
        // four channels, at the noise's deviation in codes at mid-grey (18 %).
        "denoise_sigma": config.noise.filter(|_| config.denoise > 0.0).map(|p| {
            let (s, o) = (p.scale()[1], p.offset()[1]);
            f64::from((s * 0.18 + o).max(0.0).sqrt())
                * f64::from(raw.white_level() - raw.black_level()[0])
                * f64::from(config.denoise)
        }),
        "threads": threads,
        "repeats": repeats.max(1),
        "output": output.is_some().then(|| image.display().to_string()),
    });
    let result = std::process::Command::new(python)
        .arg("-c")
        .arg(include_str!("isp_opencv.py"))
        .arg(request.to_string())
        .output();
    let _ = std::fs::remove_file(&frame);
    let result = result.map_err(|source| PeerError::Io {
        what: format!("running {}", python.display()),
        source,
    })?;
    const SCRIPT: &str = "the OpenCV script";
    if !result.status.success() {
        let _ = std::fs::remove_file(&image);
        let stderr = String::from_utf8_lossy(&result.stderr);
        let last = stderr.lines().last().unwrap_or("no message");
        return Err(PeerError::Failed {
            script: SCRIPT,
            detail: last.to_owned(),
        });
    }
    if let Some(out) = output {
        let read = std::fs::read(&image);
        let _ = std::fs::remove_file(&image);
        *out = read.map_err(|source| PeerError::Io {
            what: format!("reading {}", image.display()),
            source,
        })?;
        if out.len() != 3 * w * h {
            return Err(PeerError::Reply {
                script: SCRIPT,
                problem: format!("{} bytes written, not {}", out.len(), 3 * w * h),
            });
        }
    }
    let reply: serde_json::Value =
        serde_json::from_slice(&result.stdout).map_err(|e| PeerError::Reply {
            script: SCRIPT,
            problem: e.to_string(),
        })?;
    reply["ms_per_frame"].as_f64().ok_or(PeerError::Reply {
        script: SCRIPT,
        problem: "no time given".into(),
    })
}

/// The illuminants of the vendored spectra (`data/spectra/illuminants.csv`).
const ILLUMINANTS: [&str; 6] = ["A", "D50", "D65", "FL2", "FL11", "LED-B3"];
/// The AWB methods, by their command-line names.
const AWB_METHODS: [&str; 4] = ["grey-world", "white-patch", "shades-of-grey", "grey-edge"];
/// The camera chart 7 simulates.
const AWB_CAMERA: &str = "nikon-5100";

fn awb_suite(settings: &SuiteSettings, progress: ProgressFn<'_>) -> Result<AwbSuite, Error> {
    use host_tracer::calibrate::illuminant_colour;
    use host_tracer::sensor::{Response, SensorConfig};
    use host_tracer::tracer::render::{render, RenderSettings};
    use isp_core::metrics::angular_error_deg;
    use isp_core::wb::{self, AwbMethod};

    let demo = host_tracer::tracer::scene_file::load("demo")?;
    let mut key_only = demo.clone();
    key_only.shapes.retain(|s| s.name != "bokeh");
    let scenes = [
        (
            "demo",
            "camsim's demo scene: a ColorChecker on a dark board under one area light and a dim \
             environment of the illuminant, a white ball, black and white checks, and six small \
             bright illuminant-A lamps far behind (out of focus; they stay A)",
            demo,
        ),
        (
            "demo, key light only",
            "the same without the six lamps: every light is the illuminant",
            key_only,
        ),
    ];
    let (_, calibration) =
        crate::demo::calibration_for(&crate::demo::DemoSettings::default().camera, None)?;
    let to_xyz = calibration.camera_to_xyz(6504.0)?;
    let response = Response::named(AWB_CAMERA)?;
    let mut config = SensorConfig::realistic();
    config.camera = AWB_CAMERA.into();
    config.frame_seed = 1;
    let (width, height, spp) = if settings.quick {
        (150, 100, 16)
    } else {
        (600, 400, 64)
    };
    let mut points = Vec::new();
    for (name, _, scene) in &scenes {
        for illuminant in ILLUMINANTS {
            progress(&format!("AWB: {name} under {illuminant}"));
            let mut scene = scene.clone();
            scene.relight(illuminant)?;
            let mut render_settings = RenderSettings::for_scene(&scene);
            render_settings.width = width;
            render_settings.height = height;
            render_settings.spp = spp;
            render_settings.threads = 0;
            render_settings.seed = 1;
            let image = render(&scene, &render_settings)?;
            let capture = crate::demo::expose(&scene, &image, &response, &config)?;
            let raw = capture.raw.frame()?;
            let (_, truth) = illuminant_colour(illuminant, &response)?;
            for method in AWB_METHODS {
                let estimate = wb::estimate(&raw, AwbMethod::from_name(method)?, &to_xyz)?;
                points.push(AwbPoint {
                    scene: name.to_string(),
                    illuminant: illuminant.into(),
                    method: method.into(),
                    error_deg: angular_error_deg(estimate.neutral.map(f64::from), truth),
                    cct_k: calibration.cct_of_neutral(estimate.neutral)?,
                });
            }
        }
    }
    Ok(AwbSuite {
        scenes: scenes
            .iter()
            .map(|(n, d, _)| (n.to_string(), d.to_string()))
            .collect(),
        camera: AWB_CAMERA.into(),
        render: format!("{width} x {height}, {spp} spp, realistic sensor"),
        points,
    })
}

/// The measured camera responses of the vendored spectra.
const CAMERAS: [&str; 3] = ["nikon-5100", "canon-eos-5d-mark-ii", "sigma-sdmerill"];

fn calibration_suite(progress: ProgressFn<'_>) -> Result<CalibrationSuite, Error> {
    use host_tracer::spectra::{Table, COLORCHECKER};
    let patches = Table::parse(COLORCHECKER)?.names().to_vec();
    let mut fits = Vec::new();
    for camera in CAMERAS {
        for illuminant in ILLUMINANTS {
            progress(&format!("colour calibration: {camera} under {illuminant}"));
            let c = host_tracer::calibrate::calibrate(camera, illuminant)?;
            fits.push(CalibrationFit {
                camera: camera.into(),
                illuminant: illuminant.into(),
                matrix: c.delta_e_matrix,
                matrix_held_out: c.delta_e_matrix_held_out,
                root_polynomial: c.delta_e_root_polynomial,
                root_polynomial_held_out: c.delta_e_root_polynomial_held_out,
            });
        }
    }
    Ok(CalibrationSuite { patches, fits })
}

/// Today's date in UTC, `YYYY-MM-DD` (the civil date of the Unix day count; Howard Hinnant's
/// `civil_from_days`).
pub fn today_utc() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    civil_date(secs / 86_400)
}

fn civil_date(days_since_epoch: u64) -> String {
    let z = days_since_epoch as i64 + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!("{year:04}-{month:02}-{day:02}")
}

/// The caption every chart carries.
pub(crate) fn caption(r: &SuiteResults) -> String {
    format!(
        "{}{} on {}, {}",
        r.command,
        if r.quick {
            " (quick: few images, small tiles)"
        } else {
            ""
        },
        r.machine.describe(),
        r.date
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn civil_dates() {
        assert_eq!(civil_date(0), "1970-01-01");
        assert_eq!(civil_date(11_016), "2000-02-29");
        assert_eq!(civil_date(20_780), "2026-11-23");
    }

    #[test]
    fn the_depth_of_field_suite_finds_where_the_approximation_breaks() {
        let suite = dof_suite().unwrap();
        for lens in &suite.lenses {
            let (from, to) = lens.within_ten_percent_m.unwrap();
            let f_m = lens.focal_length_mm / 1e3;
            // Close up the approximation ignores magnification (at 2f it is twice the exact
            // value); it ignores the far limit's runaway, so it fails before the hyperfocal
            // distance, where the exact depth becomes infinite.
            assert!(
                from > 4.0 * f_m && to < lens.hyperfocal_m && from < to,
                "{lens:?}"
            );
            assert!(lens.curve.iter().any(|p| p.1.is_none()));
            let first = lens.curve[0];
            assert!(first.2 > 1.5 * first.1.unwrap(), "{first:?}");
        }
    }
}

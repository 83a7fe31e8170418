//! `camsim render`: renders a scene (built-in or TOML) to linear RGB radiance in OpenEXR and,
//! optionally, an sRGB preview PNG; prints what it did and how fast.

use std::path::PathBuf;

use camsim::Error;
use clap::Args;
use host_tracer::tracer::render::{render_with_progress, RenderSettings, Rendered};
use host_tracer::tracer::scene::SceneDesc;
use host_tracer::tracer::scene_file;
use raw_formats::Image;

use crate::args::RenderFlags;
use crate::progress::RenderBar;

/// A camera model.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum CameraArg {
    /// No lens sample.
    Pinhole,
    /// A thin lens (needs an aperture).
    Thinlens,
}

/// Arguments of `camsim render`.
#[derive(Args, Debug)]
pub struct RenderArgs {
    /// Built-in scene (cornell-box, demo) or a scene TOML file.
    #[arg(long, default_value = "cornell-box")]
    pub scene: String,
    /// Size, samples, seed and threads of the render.
    #[command(flatten)]
    pub render: RenderFlags,
    /// Longest path in segments (Mitsuba's max_depth; default: the scene's).
    #[arg(long)]
    pub max_depth: Option<u32>,
    /// Camera model: pinhole (no lens sample) or thinlens (needs an aperture).
    #[arg(long, value_enum)]
    pub camera: Option<CameraArg>,
    /// Aperture radius in scene units (as Mitsuba's thinlens); implies --camera thinlens.
    #[arg(long, value_name = "R", allow_hyphen_values = true)]
    pub aperture_radius: Option<f32>,
    /// Render through this lens file (TOML or pbrt .dat, see `camsim lens`) instead of the
    /// scene's thin lens: its focal length, the scene's f-number (no wider than the lens's
    /// widest), sensor and focus; each sample is traced at one wavelength.
    #[arg(long, value_name = "FILE", conflicts_with_all = ["camera", "aperture_radius"])]
    pub lens: Option<std::path::PathBuf>,
    /// Focus distance in scene units (default: the scene's, else the distance to the target).
    #[arg(long, value_name = "D", allow_hyphen_values = true)]
    pub focus_distance: Option<f32>,
    /// Linear RGB radiance out, OpenEXR 32-bit float.
    #[arg(long, value_name = "out.exr")]
    pub linear: Option<PathBuf>,
    /// sRGB preview out (8-bit PNG): radiance times 2^exposure, clipped, sRGB-encoded.
    #[arg(long, value_name = "out.png")]
    pub preview: Option<PathBuf>,
    /// Exposure of the preview in stops [default: automatic, the 99th percentile of the
    /// brightest channel at 1].
    #[arg(long, allow_hyphen_values = true)]
    pub exposure: Option<f32>,
    /// Print the report as one JSON object.
    #[arg(long)]
    pub json: bool,
}

fn positive(v: Option<f32>, what: &'static str) -> Result<Option<f32>, Error> {
    match v {
        Some(x) if !(x.is_finite() && x > 0.0) => Err(Error::Option {
            option: what,
            value: x.to_string(),
            allowed: "> 0".into(),
        }),
        v => Ok(v),
    }
}

/// Applies the command line's overrides to the scene's camera and film.
pub fn settings(args: &RenderArgs, scene: &mut SceneDesc) -> Result<RenderSettings, Error> {
    if let Some(path) = &args.lens {
        scene.camera.use_lens_file(path)?;
    }
    if scene.camera.lens.is_some() && (args.camera.is_some() || args.aperture_radius.is_some()) {
        return Err(Error::Message(
            "the camera has a lens file: its aperture is the lens's stop (set the scene's \
             f_number), not --camera or --aperture-radius"
                .into(),
        ));
    }
    let cam = &mut scene.camera;
    let radius = positive(args.aperture_radius, "--aperture-radius")?;
    let focus = positive(args.focus_distance, "--focus-distance")?;
    match args.camera {
        None => {}
        Some(CameraArg::Pinhole) => {
            if radius.is_some() {
                return Err(Error::Message(
                    "--camera pinhole has no aperture: drop --aperture-radius".into(),
                ));
            }
            cam.aperture_radius_mm = 0.0;
        }
        Some(CameraArg::Thinlens) if radius.is_none() && cam.aperture_radius_mm == 0.0 => {
            return Err(Error::Message(format!(
                "--camera thinlens needs --aperture-radius: scene {:?} is a pinhole",
                scene.name
            )));
        }
        Some(CameraArg::Thinlens) => {}
    }
    if let Some(r) = radius {
        cam.aperture_radius_mm = r / cam.units_per_mm;
    }
    if let Some(d) = focus {
        cam.focus_distance = Some(d);
    }
    let mut s = RenderSettings::for_scene(scene);
    let flags = &args.render;
    s.width = flags.width.unwrap_or(s.width);
    s.height = flags.height.unwrap_or(s.height);
    s.spp = flags.spp.unwrap_or(s.spp);
    s.path.max_depth = args.max_depth.unwrap_or(s.path.max_depth);
    s.seed = flags.seed;
    s.threads = flags.threads;
    let mut table = host_tracer::tracer::scene::MaskTable::default();
    scene.camera.rig(s.width, s.height, false, &mut table)?;
    Ok(s)
}

/// The exposure (stops) that puts the 99th percentile of the pixels' brightest channel at 1.
pub fn auto_exposure(image: &Rendered) -> f32 {
    let mut peaks: Vec<f32> = image
        .rgb
        .chunks_exact(3)
        .map(|p| p[0].max(p[1]).max(p[2]))
        .filter(|v| v.is_finite())
        .collect();
    if peaks.is_empty() {
        return 0.0;
    }
    let k = ((peaks.len() as f64 * 0.99) as usize).min(peaks.len() - 1);
    let (_, p99, _) = peaks.select_nth_unstable_by(k, |a, b| a.total_cmp(b));
    if *p99 > 0.0 {
        -p99.log2()
    } else {
        0.0
    }
}

/// The sRGB preview: radiance times `2^exposure`, clipped to [0, 1], sRGB-encoded to 8 bits.
pub fn preview(image: &Rendered, exposure: f32) -> Image {
    let k = exposure.exp2();
    Image {
        width: image.width as usize,
        height: image.height as usize,
        channels: 3,
        bits: 8,
        data: image
            .rgb
            .iter()
            .map(|&v| (isp_core::srgb::encode(v * k) * 255.0).round() as u16)
            .collect(),
    }
}

/// `camsim render --json`'s report.
#[derive(serde::Serialize)]
struct RenderReport<'a> {
    scene: &'a str,
    width: u32,
    height: u32,
    spp: u32,
    max_depth: u32,
    seed: u64,
    threads: usize,
    camera: &'a str,
    mode: &'a str,
    render_s: f64,
    prepare_s: f64,
    samples_per_s: f64,
    mean_rgb: [f64; 3],
}

/// Runs `camsim render`.
pub fn run(args: &RenderArgs) -> Result<String, Error> {
    if args.linear.is_none() && args.preview.is_none() {
        return Err(Error::Message(
            "nothing to write: give --linear out.exr and/or --preview out.png".into(),
        ));
    }
    if let Some(e) = args.exposure.filter(|e| !e.is_finite()) {
        return Err(Error::Option {
            option: "--exposure",
            value: e.to_string(),
            allowed: "finite".into(),
        });
    }
    let mut scene = scene_file::load(&args.scene)?;
    let settings = settings(args, &mut scene)?;
    let bar = RenderBar::new();
    let image = bar.during(|bar| render_with_progress(&scene, &settings, &|p| bar.update(p)))?;
    if let Some(path) = &args.linear {
        raw_formats::exr::write_rgb(
            path,
            image.width as usize,
            image.height as usize,
            &image.rgb,
        )?;
    }
    if let Some(path) = &args.preview {
        let exposure = args.exposure.unwrap_or_else(|| auto_exposure(&image));
        raw_formats::image::write(path, &preview(&image, exposure))?;
    }
    let mut mean = [0.0f64; 3];
    for px in image.rgb.chunks_exact(3) {
        for c in 0..3 {
            mean[c] += px[c] as f64;
        }
    }
    let pixels = (image.width * image.height) as f64;
    let mean = mean.map(|m| m / pixels);
    let mode = if scene.is_spectral() {
        "spectral"
    } else {
        "rgb"
    };
    let camera = if let Some(lens) = &scene.camera.lens {
        format!("lens {}", lens.file.name)
    } else if scene.camera.aperture_radius_mm > 0.0 {
        "thinlens".into()
    } else {
        "pinhole".into()
    };
    if args.json {
        let report = RenderReport {
            scene: &scene.name,
            width: image.width,
            height: image.height,
            spp: settings.spp,
            max_depth: settings.path.max_depth,
            seed: settings.seed,
            threads: rayon_threads(settings.threads),
            camera: &camera,
            mode,
            render_s: image.elapsed.as_secs_f64(),
            prepare_s: image.prepare.as_secs_f64(),
            samples_per_s: image.samples_per_second(),
            mean_rgb: mean,
        };
        return Ok(
            serde_json::to_string(&report).map_err(|e| Error::Message(e.to_string()))? + "\n",
        );
    }
    Ok(format!(
        "scene {} ({mode}, {camera}): {} x {} at {} spp, max depth {}, seed {}\n\
         rendered in {:.2} s on {} threads ({:.2} Msamples/s; BVH, tables and lens {:.1} ms; \
         {:.1} % of samples vignetted)\n\
         mean linear RGB {:.5} {:.5} {:.5}\n",
        scene.name,
        image.width,
        image.height,
        settings.spp,
        settings.path.max_depth,
        settings.seed,
        image.elapsed.as_secs_f64(),
        rayon_threads(settings.threads),
        image.samples_per_second() / 1e6,
        image.prepare.as_secs_f64() * 1e3,
        100.0 * image.lost_samples as f64 / image.samples.max(1) as f64,
        mean[0],
        mean[1],
        mean[2]
    ))
}

fn rayon_threads(requested: usize) -> usize {
    if requested == 0 {
        std::thread::available_parallelism().map_or(1, |n| n.get())
    } else {
        requested
    }
}

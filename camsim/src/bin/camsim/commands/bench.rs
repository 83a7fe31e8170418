//! `camsim bench demosaic` and `camsim bench render`: accuracy against speed, with progress on
//! stderr.

use std::path::PathBuf;

use camsim::demosaic::{self, Demosaic};
use camsim::Error;
use clap::{Args, Subcommand};
use host_tracer::render_bench::{bench, table, BenchSettings};

use crate::args::{DemosaicArg, RenderFlags};
use crate::progress::Progress;

#[derive(Subcommand)]
pub enum BenchCommand {
    /// CPSNR on an image set and single-thread Mpix/s for every demosaicing method.
    Demosaic(BenchDemosaicArgs),
    /// What each optical feature (thin lens, aperture shape, chromatic aberration, motion,
    /// spectral rendering, distortion) costs the path tracer, against the pinhole.
    Render(BenchRenderArgs),
    /// How long reading a DNG takes: parsing, decoding (unpacking or lossless JPEG),
    /// linearising and cropping, from bytes in memory; `scripts/bench-dng-decode.py` runs it
    /// beside LibRaw's unpack of the same file.
    Dng(BenchDngArgs),
}

#[derive(Args)]
pub struct BenchDngArgs {
    /// The DNG to decode.
    #[arg(long)]
    input: PathBuf,
    /// Decodes; the fastest is reported.
    #[arg(long, default_value_t = 10)]
    repeats: u32,
    /// Print one JSON object {file, width, height, ms, mpix_per_s, repeats}.
    #[arg(long)]
    json: bool,
}

/// What `camsim bench dng` measured.
#[derive(serde::Serialize)]
struct DngDecodeFigures {
    file: String,
    width: usize,
    height: usize,
    ms: f64,
    mpix_per_s: f64,
    repeats: u32,
}

#[derive(Args)]
pub struct BenchDemosaicArgs {
    /// Folder of 8-bit RGB PNG images (data/kodak, data/mcmaster).
    #[arg(long, default_value = "data/kodak")]
    dataset: PathBuf,
    /// Threads for the throughput measurement (only single-thread runs are measured so far).
    #[arg(long, default_value_t = 1)]
    threads: usize,
    /// Sample depth: 8 or 16; both when not given.
    #[arg(long)]
    bits: Option<u8>,
    /// Measure only this method (repeatable); every method when not given.
    #[arg(long = "method", value_name = "METHOD", value_enum)]
    methods: Vec<DemosaicArg>,
    /// Print a JSON list of {method, bits, cpsnr_db, mpix_per_s} instead of a table.
    #[arg(long)]
    json: bool,
}

#[derive(Args)]
// The same render flags as render and demo, with the benchmark's defaults: a 256 x 256 image at
// 16 spp on one thread, whatever the scene says, so figures compare across scenes.
#[command(
    mut_arg("width", |a| a.default_value("256").help("Image width in pixels")),
    mut_arg("height", |a| a.default_value("256").help("Image height in pixels")),
    mut_arg("spp", |a| a.default_value("16").help("Samples per pixel of each render")),
    mut_arg("threads", |a| a.default_value("1"))
)]
pub struct BenchRenderArgs {
    /// Built-in scene or scene TOML file (RGB colours; the spectral variant converts them).
    #[arg(long, default_value = "cornell-box")]
    scene: String,
    /// Size, samples, seed and threads of every render.
    #[command(flatten)]
    render: RenderFlags,
    /// Renders per variant; the fastest is reported.
    #[arg(long, default_value_t = 3)]
    repeats: u32,
    /// Aperture radius of the thin-lens variants, in scene units.
    #[arg(
        long,
        default_value_t = 0.1,
        value_name = "R",
        allow_hyphen_values = true
    )]
    aperture_radius: f32,
    /// Print a JSON list of {variant, what, msamples_per_s, relative_time, mean_rgb}.
    #[arg(long)]
    json: bool,
}

/// Runs a `camsim bench` subcommand.
pub fn run(command: &BenchCommand) -> Result<String, Error> {
    match command {
        BenchCommand::Demosaic(args) => bench_demosaic(args),
        BenchCommand::Render(args) => bench_render(args),
        BenchCommand::Dng(args) => bench_dng(args),
    }
}

fn bench_dng(args: &BenchDngArgs) -> Result<String, Error> {
    if args.repeats == 0 {
        return Err(Error::Option {
            option: "--repeats",
            value: "0".into(),
            allowed: "at least 1".into(),
        });
    }
    let bytes =
        std::fs::read(&args.input).map_err(|e| raw_formats::FormatError::io(&args.input, e))?;
    let mut best = f64::INFINITY;
    let mut size = (0, 0);
    for _ in 0..args.repeats {
        let start = std::time::Instant::now();
        let dng = raw_formats::dng::Dng::decode(&bytes).map_err(|e| e.in_file(&args.input))?;
        best = best.min(start.elapsed().as_secs_f64() * 1e3);
        size = (dng.image.width, dng.image.height);
    }
    let figures = DngDecodeFigures {
        file: args.input.display().to_string(),
        width: size.0,
        height: size.1,
        ms: best,
        mpix_per_s: (size.0 * size.1) as f64 / (best * 1e3),
        repeats: args.repeats,
    };
    if args.json {
        return json(&figures);
    }
    Ok(format!(
        "{}: {} x {} decoded in {:.2} ms ({:.1} Mpix/s), best of {}\n",
        figures.file,
        figures.width,
        figures.height,
        figures.ms,
        figures.mpix_per_s,
        figures.repeats
    ))
}

fn json<T: serde::Serialize>(value: &T) -> Result<String, Error> {
    Ok(serde_json::to_string_pretty(value).map_err(|e| Error::Message(e.to_string()))? + "\n")
}

fn bench_render(args: &BenchRenderArgs) -> Result<String, Error> {
    let scene = host_tracer::tracer::scene_file::load(&args.scene)?;
    let flags = &args.render;
    let settings = BenchSettings {
        // The defaults above always give a value.
        width: flags.width.unwrap_or(256),
        height: flags.height.unwrap_or(256),
        spp: flags.spp.unwrap_or(16),
        seed: flags.seed,
        threads: flags.threads,
        repeats: args.repeats,
        aperture_radius: args.aperture_radius,
    };
    let mut progress = Progress::new("bench render");
    let rows = bench(&scene, &settings, &mut |what| progress.step(what))?;
    progress.finish();
    if args.json {
        return json(&rows);
    }
    Ok(table(&rows, &scene.name, &settings))
}

fn bench_demosaic(args: &BenchDemosaicArgs) -> Result<String, Error> {
    if args.threads != 1 {
        return Err(Error::Option {
            option: "--threads",
            value: args.threads.to_string(),
            allowed: "1: only single-thread throughput is measured so far".into(),
        });
    }
    let depths = match args.bits {
        None => vec![8, 16],
        Some(b @ (8 | 16)) => vec![b],
        Some(b) => {
            return Err(Error::Option {
                option: "--bits",
                value: b.to_string(),
                allowed: "8 or 16".into(),
            })
        }
    };
    let methods = if args.methods.is_empty() {
        Demosaic::ALL.to_vec()
    } else {
        args.methods.iter().map(|m| Demosaic::from(*m)).collect()
    };
    let mut progress = Progress::new("bench");
    let mut rows = Vec::new();
    for bits in depths {
        rows.extend(demosaic::bench(
            &args.dataset,
            bits,
            &methods,
            &mut |what| progress.step(what),
        )?);
    }
    progress.finish();
    if args.json {
        return json(&rows);
    }
    let mut out = format!(
        "{}\n{:<18} {:>4} {:>10} {:>10}\n",
        args.dataset.display(),
        "method",
        "bits",
        "CPSNR dB",
        "Mpix/s"
    );
    for r in rows {
        out.push_str(&format!(
            "{:<18} {:>4} {:>10.2} {:>10.1}\n",
            r.method, r.bits, r.cpsnr_db, r.mpix_per_s
        ));
    }
    Ok(out)
}

impl BenchRenderArgs {
    /// The render flags as given (for tests).
    #[cfg(test)]
    pub fn flags(&self) -> &RenderFlags {
        &self.render
    }
}

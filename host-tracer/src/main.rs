//! `camsim`: the camera simulator's command line.

use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Args, Parser, Subcommand};
use host_tracer::demosaic_cmd::{self, Method};
use host_tracer::dof::{compute, DofInput};
use isp_core::CfaPattern;

#[derive(Parser)]
#[command(
    name = "camsim",
    version,
    about = "Camera simulator and image signal processor"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Depth of field, hyperfocal distance, focus position and magnification of a thin lens.
    Dof(DofArgs),
    /// Demosaic a single-channel 8- or 16-bit Bayer mosaic (PNG or PGM) into RGB of the same depth.
    Demosaic(DemosaicArgs),
    /// Run the ISP (defects, black level, lens shading, gain, white balance, demosaic, lens
    /// distortion, denoise, colour matrix, tone, sRGB) on a raw mosaic (PNG or PGM) and write
    /// an sRGB image; options from flags or a TOML file (--config).
    Isp(Box<host_tracer::isp_cmd::IspArgs>),
    /// Render a scene (built-in cornell-box or demo, or a TOML file) with the path tracer to
    /// linear RGB radiance (OpenEXR) and an sRGB preview.
    Render(Box<host_tracer::render_cmd::RenderArgs>),
    /// The whole camera on a built-in scene: render, sensor, raw DNG, ISP (float and fixed),
    /// ground truth, side-by-side comparison and a report (PSNR, ColorChecker error, AWB).
    Demo(Box<host_tracer::demo_cmd::DemoArgs>),
    /// Fit a camera's colour matrix on a rendered ColorChecker (under A and D65 by default)
    /// and write it for camsim isp and camsim demo.
    Calibrate(host_tracer::demo_cmd::CalibrateArgs),
    /// Measure accuracy against speed.
    Bench {
        #[command(subcommand)]
        what: BenchCommand,
    },
}

#[derive(Subcommand)]
enum BenchCommand {
    /// CPSNR on an image set and single-thread Mpix/s for every demosaicing method.
    Demosaic(BenchDemosaicArgs),
    /// What each optical feature (thin lens, aperture shape, chromatic aberration, motion,
    /// spectral rendering, distortion) costs the path tracer, against the pinhole.
    Render(BenchRenderArgs),
}

#[derive(Args)]
struct DofArgs {
    /// Focal length in millimetres (> 0).
    #[arg(long, value_name = "MM", allow_hyphen_values = true)]
    focal_length_mm: String,
    /// f-number N = f / D (>= 0.5).
    #[arg(long, value_name = "N", allow_hyphen_values = true)]
    f_number: String,
    /// Acceptable circle of confusion on the sensor, in millimetres (> 0; 0.03 for full frame).
    #[arg(long, value_name = "MM", allow_hyphen_values = true)]
    coc_mm: String,
    /// Focus (subject) distance in millimetres from the lens (> focal length), or `inf`.
    #[arg(long, value_name = "MM|inf", allow_hyphen_values = true)]
    focus_mm: String,
    /// Print one JSON object instead of a table.
    #[arg(long)]
    json: bool,
}

#[derive(Args)]
struct DemosaicArgs {
    /// nearest, bilinear, bilinear-opencv (bit-exact to OpenCV's cvtColor), mhc or directional
    /// (the high-quality method).
    #[arg(long, default_value = "mhc")]
    method: String,
    /// Border rule: reflect101 (mirror without repeating the edge; keeps CFA parity) or opencv
    /// (OpenCV's cvtColor rule; bilinear only, same as --method bilinear-opencv).
    #[arg(long, default_value = "reflect101")]
    border: String,
    /// CFA pattern by the top-left 2x2 block: RGGB, BGGR, GRBG or GBRG.
    #[arg(long, default_value = "RGGB")]
    pattern: String,
    /// Input mosaic: .png or .pgm, single channel, 8 or 16 bit.
    #[arg(long)]
    input: PathBuf,
    /// Output RGB image: .png or .ppm.
    #[arg(long)]
    output: PathBuf,
}

#[derive(Args)]
struct BenchDemosaicArgs {
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
    #[arg(long = "method", value_name = "METHOD")]
    methods: Vec<String>,
    /// Print a JSON list of {method, bits, cpsnr_db, mpix_per_s} instead of a table.
    #[arg(long)]
    json: bool,
}

#[derive(Args)]
struct BenchRenderArgs {
    /// Built-in scene or scene TOML file (RGB colours; the spectral variant converts them).
    #[arg(long, default_value = "cornell-box")]
    scene: String,
    /// Image width.
    #[arg(long, default_value_t = 256)]
    width: u32,
    /// Image height.
    #[arg(long, default_value_t = 256)]
    height: u32,
    /// Samples per pixel of each render.
    #[arg(long, default_value_t = 16)]
    spp: u32,
    /// Worker threads (0: one per core).
    #[arg(long, default_value_t = 1)]
    threads: usize,
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

/// Progress of a benchmark on stderr: one line rewritten in place on a terminal, a line per
/// step otherwise (logs).
struct Progress {
    label: &'static str,
    terminal: bool,
}

impl Progress {
    fn new(label: &'static str) -> Self {
        Self {
            label,
            terminal: std::io::stderr().is_terminal(),
        }
    }

    fn step(&mut self, what: &str) {
        if self.terminal {
            eprint!("\r\x1b[K{}: {what}", self.label);
        } else {
            eprintln!("{}: {what}", self.label);
        }
    }

    fn finish(self) {
        if self.terminal {
            eprintln!();
        }
    }
}

fn bench_render(args: &BenchRenderArgs) -> Result<String, String> {
    use host_tracer::render_bench::{bench, table, BenchSettings};
    let scene = host_tracer::tracer::scene_file::load(&args.scene)?;
    let settings = BenchSettings {
        width: args.width,
        height: args.height,
        spp: args.spp,
        threads: args.threads,
        repeats: args.repeats,
        aperture_radius: args.aperture_radius,
    };
    let mut progress = Progress::new("bench render");
    let rows = bench(&scene, &settings, &mut |what| progress.step(what))?;
    progress.finish();
    if args.json {
        let list: Vec<_> = rows.iter().map(|r| r.to_json()).collect();
        return Ok(serde_json::to_string_pretty(&list).map_err(|e| e.to_string())? + "\n");
    }
    Ok(table(&rows, &scene.name, &settings))
}

fn dof(args: &DofArgs) -> Result<String, String> {
    let input = DofInput::parse(
        &args.focal_length_mm,
        &args.f_number,
        &args.coc_mm,
        &args.focus_mm,
    )
    .map_err(|e| e.to_string())?;
    let report = compute(&input).map_err(|e| e.to_string())?;
    Ok(if args.json {
        report.to_json().to_string() + "\n"
    } else {
        report.to_table(&input)
    })
}

fn demosaic(args: &DemosaicArgs) -> Result<String, String> {
    let method = match (Method::parse(&args.method)?, args.border.as_str()) {
        (method, "reflect101") => method,
        (Method::Bilinear | Method::BilinearOpenCv, "opencv") => Method::BilinearOpenCv,
        (method, "opencv") => {
            return Err(format!(
                "--border opencv applies to bilinear only (got --method {})",
                method.name()
            ))
        }
        (_, other) => {
            return Err(format!(
                "--border must be reflect101 or opencv (got {other:?})"
            ))
        }
    };
    let pattern: CfaPattern = args.pattern.parse().map_err(|_| {
        format!(
            "--pattern must be one of RGGB, BGGR, GRBG, GBRG (got {:?})",
            args.pattern
        )
    })?;
    demosaic_cmd::demosaic_file(&args.input, &args.output, method, pattern)
}

fn bench_demosaic(args: &BenchDemosaicArgs) -> Result<String, String> {
    if args.threads != 1 {
        return Err(format!(
            "--threads must be 1: only single-thread throughput is measured so far (got {})",
            args.threads
        ));
    }
    let depths = match args.bits {
        None => vec![8, 16],
        Some(b @ (8 | 16)) => vec![b],
        Some(b) => return Err(format!("--bits must be 8 or 16 (got {b})")),
    };
    let methods = if args.methods.is_empty() {
        demosaic_cmd::Method::ALL.to_vec()
    } else {
        let parsed: Result<Vec<_>, _> = args
            .methods
            .iter()
            .map(|m| demosaic_cmd::Method::parse(m))
            .collect();
        parsed?
    };
    let mut progress = Progress::new("bench");
    let mut rows = Vec::new();
    for bits in depths {
        rows.extend(demosaic_cmd::bench(
            &args.dataset,
            bits,
            &methods,
            &mut |what| progress.step(what),
        )?);
    }
    progress.finish();
    if args.json {
        let list: Vec<_> = rows.iter().map(|r| r.to_json()).collect();
        return Ok(serde_json::to_string_pretty(&list).map_err(|e| e.to_string())? + "\n");
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

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match &cli.command {
        Command::Dof(args) => dof(args),
        Command::Demosaic(args) => demosaic(args),
        Command::Isp(args) => host_tracer::isp_cmd::run(args),
        Command::Render(args) => host_tracer::render_cmd::run(args),
        Command::Demo(args) => host_tracer::demo_cmd::run(args),
        Command::Calibrate(args) => host_tracer::demo_cmd::run_calibrate(args),
        Command::Bench {
            what: BenchCommand::Demosaic(args),
        } => bench_demosaic(args),
        Command::Bench {
            what: BenchCommand::Render(args),
        } => bench_render(args),
    };
    match result {
        Ok(out) => {
            print!("{out}");
            ExitCode::SUCCESS
        }
        Err(message) => {
            eprintln!("error: {message}");
            ExitCode::from(2)
        }
    }
}

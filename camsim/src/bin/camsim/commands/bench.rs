//! `camsim bench demosaic` and `camsim bench render`: accuracy against speed, with progress on
//! stderr.

use std::path::{Path, PathBuf};

use camsim::demosaic::{self, Demosaic};
use camsim::suite::{self, SuiteSettings};
use camsim::Error;
use clap::{Args, Subcommand};
use host_tracer::render_bench::{bench, table, BenchSettings};

use camsim::develop::{self, with_prepared, RawInput, Runner};
use isp_core::pipeline::Input;

use crate::args::{DemosaicArg, RenderFlags};
use crate::commands::isp::ProcessingArgs;
use crate::progress::Progress;

/// `camsim bench`: the suites, or one benchmark.
#[derive(Args)]
#[command(args_conflicts_with_subcommands = true)]
pub struct BenchArgs {
    /// One benchmark alone; without one, every suite runs and is charted.
    #[command(subcommand)]
    pub what: Option<BenchCommand>,
    /// Folder for bench.json, summary.md and the SVG charts (created if missing).
    #[arg(long, default_value = "camsim-bench")]
    pub out: PathBuf,
    /// A smoke run of about a minute: two images per set, small tiles, short timings (its
    /// speeds are not comparable with a full run's).
    #[arg(long)]
    pub quick: bool,
    /// Folder holding the kodak/ and mcmaster/ image sets.
    #[arg(long, default_value = "data")]
    pub data: PathBuf,
    /// Measure nothing: draw the charts and the summary again from a run's bench.json
    /// (into --out).
    #[arg(long, value_name = "BENCH_JSON", conflicts_with_all = ["quick", "data"])]
    pub from_json: Option<PathBuf>,
    /// Also rewrite this README's generated tables (between `<!-- camsim bench: NAME -->`
    /// and `<!-- end camsim bench -->`) from the results.
    #[arg(long, value_name = "README")]
    pub readme: Option<PathBuf>,
}

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
    /// Time the ISP pipeline alone (best of the repeats) on a raw file, or on a synthesised
    /// 2592 x 1968 10-bit RGGB frame, beside a plain copy of the same bytes and an OpenCV
    /// pipeline of the same stages run through the oracle environment's Python
    /// ($CAMSIM_ORACLE_PYTHON, else .venv/bin/python).
    Isp(Box<BenchIspArgs>),
    /// The noise-reduction suite alone: camsim's profile-driven noise reduction (float and
    /// fixed) against OpenCV's fastNlMeansDenoisingColored and BM3D (CBM3D on the
    /// development, BM3D per CFA plane of the raw) on Kodak and McMaster as noisy 12-bit raws,
    /// every peer in the same run (the full `camsim bench` runs it too).
    Denoise(BenchDenoiseArgs),
    /// The tuning suite alone: `camsim tune` on two simulated cameras' capture sets beside
    /// Raspberry Pi's Camera Tuning Tool (rpi-ctt: colour matrices, lens shading) and the
    /// EMVA 1288 reference implementation (emva1288: the noise profile), every tool against
    /// the simulator's truth in the same run. The peers run in .venv-tune
    /// ($CAMSIM_TUNE_PYTHON overrides; scripts/test-all.sh makes it). The full `camsim bench`
    /// runs it too.
    Tune(BenchTuneArgs),
}

#[derive(Args)]
pub struct BenchTuneArgs {
    /// Folder for tune.json, tune.md, tune.svg, tune_ccm.svg and each camera's captures and
    /// peer output (created if missing).
    #[arg(long, default_value = "camsim-bench-tune")]
    out: PathBuf,
    /// Smaller frames (240 x 180): a smoke run.
    #[arg(long)]
    quick: bool,
}

#[derive(Args)]
pub struct BenchDenoiseArgs {
    /// Folder for denoise.json, denoise.md and denoise.svg (created if missing).
    #[arg(long, default_value = "camsim-bench-denoise")]
    out: PathBuf,
    /// Two image crops, no BM3D (which takes minutes per image): a smoke run.
    #[arg(long)]
    quick: bool,
    /// Folder holding the kodak/ and mcmaster/ image sets.
    #[arg(long, default_value = "data")]
    data: PathBuf,
}

#[derive(Args)]
pub struct BenchIspArgs {
    /// Raw input, as for camsim isp [default: a synthesised 2592 x 1968 10-bit RGGB frame,
    /// black 64, white 1023].
    #[arg(long)]
    input: Option<PathBuf>,
    /// Runs of the pipeline (and of each peer); the fastest is reported.
    #[arg(long, default_value_t = 10)]
    repeats: u32,
    /// Print one JSON object instead of text.
    #[arg(long)]
    json: bool,
    /// How to process, as for camsim isp.
    #[command(flatten)]
    processing: ProcessingArgs,
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
    /// Also render through this lens file beside a thin lens of its focal length, f-number
    /// and framing (repeatable): samples per second, the share vignetted and the noise at
    /// equal time.
    #[arg(long, value_name = "FILE")]
    lens: Vec<PathBuf>,
    /// Print a JSON list of {variant, what, msamples_per_s, relative_time, mean_rgb} (with
    /// --lens: an object {features, lenses}).
    #[arg(long)]
    json: bool,
}

/// Runs `camsim bench`: a subcommand, or the suites.
pub fn run(args: &BenchArgs) -> Result<String, Error> {
    let Some(command) = &args.what else {
        return run_suites(args);
    };
    match command {
        BenchCommand::Demosaic(args) => bench_demosaic(args),
        BenchCommand::Render(args) => bench_render(args),
        BenchCommand::Dng(args) => bench_dng(args),
        BenchCommand::Isp(args) => bench_isp(args),
        BenchCommand::Denoise(args) => bench_denoise(args),
        BenchCommand::Tune(args) => bench_tune(args),
    }
}

fn bench_tune(args: &BenchTuneArgs) -> Result<String, Error> {
    let (results, caption, skipped) = one_suite(
        &args.out,
        args.quick,
        Path::new("data"),
        "bench tune",
        |settings, skipped, progress| {
            suite::tune::tune_suite(settings, &settings.tune_python, skipped, progress)
        },
    )?;
    let table = results.table();
    write_suite(&args.out, "tune", &results, &caption, &table)?;
    suite::tune::charts(&results, &caption, &args.out)?;
    let mut out = table;
    let behind = results.behind_the_peers();
    if skipped.is_none() {
        out += &if behind.is_empty() {
            "\ncamsim is at least as close to the truth as rpi-ctt (colour matrix, every light) \
             and emva1288 (S and O, averaged over every ISO and colour)\n"
                .to_string()
        } else {
            format!(
                "\nwhere camsim is farther from the truth than its peer:\n  {}\n",
                behind.join("\n  ")
            )
        };
    } else if let Some(why) = skipped {
        out += &format!("\nnote: the peers were skipped: {why}\n");
    }
    out += &format!("\nwritten: {}\n", args.out.display());
    Ok(out)
}

/// One suite alone into `out` (`camsim bench NAME`): its settings, its progress on stderr
/// under `label`;
/// returns its results, the caption its files carry and why its peers were skipped, if they
/// were.
fn one_suite<R>(
    out: &Path,
    quick: bool,
    data: &Path,
    label: &'static str,
    run: impl FnOnce(&SuiteSettings, &mut Option<String>, suite::ProgressFn<'_>) -> Result<R, Error>,
) -> Result<(R, String, Option<String>), Error> {
    let settings = suite_settings(out, quick, data);
    std::fs::create_dir_all(out).map_err(|e| raw_formats::FormatError::io(out, e))?;
    let mut progress = Progress::new(label);
    let started = std::time::Instant::now();
    let mut skipped = None;
    let results = run(&settings, &mut skipped, &mut |what| {
        progress.step(&format!(
            "[{:5.1} s] {what}",
            started.elapsed().as_secs_f64()
        ))
    })?;
    progress.finish();
    let caption = format!(
        "{} on {}, {}",
        settings.command,
        suite::Machine::this().describe(),
        suite::today_utc()
    );
    Ok((results, caption, skipped))
}

/// Writes a suite's `NAME.json` (its results) and `NAME.md` (title, caption, table) into `out`.
fn write_suite<R: serde::Serialize>(
    out: &Path,
    name: &str,
    results: &R,
    caption: &str,
    table: &str,
) -> Result<(), Error> {
    let write = |file: String, text: &str| {
        let path = out.join(file);
        std::fs::write(&path, text).map_err(|e| Error::from(raw_formats::FormatError::io(path, e)))
    };
    let json = serde_json::to_string_pretty(results).map_err(|e| Error::Message(e.to_string()))?;
    write(format!("{name}.json"), &(json + "\n"))?;
    write(
        format!("{name}.md"),
        &format!("# camsim bench {name}\n\n`{caption}`\n\n{table}"),
    )
}

/// The suites' settings for a run into `out` from the environment: the oracle's Python,
/// whether the peers are required (CI), the learned peer's Python and this command line.
fn suite_settings(out: &Path, quick: bool, data: &Path) -> SuiteSettings {
    SuiteSettings {
        out: out.to_owned(),
        quick,
        data: data.to_owned(),
        python: oracle_python(),
        require_peers: std::env::var_os("CAMSIM_REQUIRE_ORACLE").is_some_and(|v| v == "1"),
        learned_python: std::env::var_os("CAMSIM_LEARNED_PYTHON")
            .map(PathBuf::from)
            .unwrap_or_else(|| PathBuf::from(".venv-learned/bin/python")),
        tune_python: suite::tune::tune_python(),
        command: std::iter::once("camsim".to_string())
            .chain(std::env::args().skip(1))
            .collect::<Vec<_>>()
            .join(" "),
    }
}

fn bench_denoise(args: &BenchDenoiseArgs) -> Result<String, Error> {
    let (results, caption, skipped) = one_suite(
        &args.out,
        args.quick,
        &args.data,
        "bench denoise",
        |settings, skipped, progress| suite::denoise::denoise_suite(settings, skipped, progress),
    )?;
    let table = suite::denoise_table(&results);
    write_suite(&args.out, "denoise", &results, &caption, &table)?;
    suite::denoise_chart(&results, &caption, &args.out.join("denoise.svg"))?;
    let mut out = table;
    if let Some(why) = skipped {
        out += &format!("\nnote: the peers were skipped: {why}\n");
    }
    out += &format!("\nwritten: {}\n", args.out.display());
    Ok(out)
}

/// What `camsim bench isp` measured.
#[derive(serde::Serialize)]
struct IspFigures {
    input: String,
    width: usize,
    height: usize,
    path: &'static str,
    stages: Vec<&'static str>,
    threads: usize,
    repeats: u32,
    ms_per_frame: f64,
    mpix_per_s: f64,
    ns_per_pixel: f64,
    /// The whole library call `camsim isp` makes (`develop::develop`), best of the repeats:
    /// the preparation (the samples' range check, white balance, noise profile, the
    /// pipeline's tables and scratch), the run into new memory and the framing. What a
    /// caller of the library pays per frame, the peer of the Python package's `develop`.
    develop_ms: f64,
    /// Each stage's ns per pixel by ablation (the base: black level, demosaicing and encoding;
    /// then each stage that is on, its run less the run without it), in pipeline order.
    stage_ns_per_pixel: Vec<StageFigure>,
    /// A plain copy of the raw frame's bytes.
    copy: PeerFigures,
    /// The OpenCV pipeline, if the oracle environment ran it.
    opencv: Option<PeerFigures>,
    /// Why the OpenCV peer did not run, if it did not.
    peers_skipped: Option<String>,
}

#[derive(serde::Serialize)]
struct StageFigure {
    stage: &'static str,
    ns_per_pixel: f64,
}

#[derive(serde::Serialize)]
struct PeerFigures {
    what: String,
    ms_per_frame: f64,
    /// Our time over the peer's: below 1, camsim is faster.
    time_ratio: f64,
}

/// `--repeats` is at least 1 (the best of none is no figure).
fn at_least_one_repeat(repeats: u32) -> Result<(), Error> {
    if repeats == 0 {
        return Err(Error::Option {
            option: "--repeats",
            value: "0".into(),
            allowed: "at least 1".into(),
        });
    }
    Ok(())
}

fn bench_isp(args: &BenchIspArgs) -> Result<String, Error> {
    at_least_one_repeat(args.repeats)?;
    let (input, name) = match &args.input {
        Some(path) => (RawInput::read(path)?, path.display().to_string()),
        None => {
            let (frame, name) = suite::synthetic_raw()?;
            (frame, name.into())
        }
    };
    let processing = &args.processing;
    let options = processing.options()?;
    let calibration = processing.calibration()?;
    let threads = processing.threads();
    let mut progress = Progress::new("bench isp");
    progress.step("the whole develop call");
    let mut develop_ms = f64::INFINITY;
    for _ in 0..args.repeats {
        let start = std::time::Instant::now();
        let run = develop::RunOptions {
            threads,
            stage_times: false,
        };
        develop::develop(&input, &options, calibration, run)?;
        develop_ms = develop_ms.min(start.elapsed().as_secs_f64() * 1e3);
    }
    let figures = with_prepared(&input, &options, calibration, |p| {
        let (w, h) = (p.input.width(), p.input.height());
        progress.step("camsim pipeline");
        let mut runner = Runner::new(&p.input, &p.config, p.fixed, p.out_bits, threads)?;
        let ms = runner.time_ms(args.repeats)?;
        progress.step("each stage, by ablation");
        let pixels = (w * h) as f64;
        let stage_ns_per_pixel = develop::stage_times(
            &p.input,
            &p.config,
            p.fixed,
            p.out_bits,
            threads,
            args.repeats,
        )?
        .into_iter()
        .map(|(stage, ms)| StageFigure {
            stage,
            ns_per_pixel: ms * 1e6 / pixels,
        })
        .collect();
        progress.step("copy");
        let copy_ms = suite::copy_ms(&input.raw.samples, args.repeats);
        let copy = PeerFigures {
            what: format!(
                "copy of the raw frame's {} MB",
                input.raw.samples.len() * 2 / 1_000_000
            ),
            ms_per_frame: copy_ms,
            time_ratio: ms / copy_ms,
        };
        progress.step("OpenCV pipeline");
        let (opencv, peers_skipped) = match &p.input {
            Input::Mosaic(raw) => match suite::opencv_pipeline(
                &oracle_python(),
                raw,
                &p.config,
                threads,
                args.repeats,
                None,
            ) {
                Ok(peer_ms) => (
                    Some(PeerFigures {
                        what: if p.config.denoise > 0.0 && p.config.noise.is_some() {
                            "OpenCV: subtract, fastNlMeansDenoising (packed mosaic, template 3, \
                             search 5), cvtColor Bayer 16-bit, multiply, transform, \
                             convertScaleAbs, LUT"
                        } else {
                            "OpenCV: subtract, cvtColor Bayer 16-bit, multiply, transform, \
                             convertScaleAbs, LUT"
                        }
                        .into(),
                        ms_per_frame: peer_ms,
                        time_ratio: ms / peer_ms,
                    }),
                    None,
                ),
                Err(why) => (None, Some(why.to_string())),
            },
            Input::Linear(_) => (None, Some("the input is linear (no Bayer stage)".into())),
        };
        let stages = develop::stage_names(&p.config, matches!(p.input, Input::Linear(_)));
        Ok(IspFigures {
            input: name,
            width: w,
            height: h,
            path: if p.fixed { "fixed" } else { "float" },
            stages,
            threads: runner.threads(),
            repeats: args.repeats,
            ms_per_frame: ms,
            mpix_per_s: (w * h) as f64 / (ms * 1e3),
            ns_per_pixel: ms * 1e6 / (w * h) as f64,
            develop_ms,
            stage_ns_per_pixel,
            copy,
            opencv,
            peers_skipped,
        })
    })?;
    progress.finish();
    if let Some(why) = &figures.peers_skipped {
        eprintln!("note: the OpenCV peer was skipped: {why}");
    }
    if args.json {
        return json(&figures);
    }
    let f = &figures;
    let mut out = format!(
        "{}: {} x {}, {} path, {} ({} thread{})\n  camsim     {:9.2} ms per frame, {:7.1} Mpix/s, {:.2} ns per pixel (best of {})\n",
        f.input,
        f.width,
        f.height,
        f.path,
        f.stages.join(" -> "),
        f.threads,
        if f.threads == 1 { "" } else { "s" },
        f.ms_per_frame,
        f.mpix_per_s,
        f.ns_per_pixel,
        f.repeats
    );
    out += &format!(
        "  the whole develop call (preparation, run into new memory, framing): {:.2} ms\n",
        f.develop_ms
    );
    out += "  each stage, by ablation (ns per pixel):";
    for s in &f.stage_ns_per_pixel {
        out += &format!(" {} {:.2};", s.stage, s.ns_per_pixel);
    }
    out.pop();
    out += "\n";
    for peer in [Some(&f.copy), f.opencv.as_ref()].into_iter().flatten() {
        out += &format!(
            "  {:<60} {:9.2} ms: camsim takes {:.2}x its time\n",
            peer.what, peer.ms_per_frame, peer.time_ratio
        );
    }
    Ok(out)
}

/// The oracle environment's Python: $CAMSIM_ORACLE_PYTHON, else .venv/bin/python.
fn oracle_python() -> PathBuf {
    std::env::var_os("CAMSIM_ORACLE_PYTHON")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(".venv/bin/python"))
}

fn run_suites(args: &BenchArgs) -> Result<String, Error> {
    if let Some(json) = &args.from_json {
        let text =
            std::fs::read_to_string(json).map_err(|e| raw_formats::FormatError::io(json, e))?;
        let results: suite::SuiteResults = serde_json::from_str(&text)
            .map_err(|e| Error::Message(format!("{}: {e}", json.display())))?;
        std::fs::create_dir_all(&args.out)
            .map_err(|e| raw_formats::FormatError::io(&args.out, e))?;
        suite::write_all(&results, &args.out, &mut |_| {})?;
        update_readme(args, &results)?;
        return Ok(format!(
            "camsim bench: charts of the {} run of {} drawn into {}\n",
            results.date,
            json.display(),
            args.out.display()
        ));
    }
    // The README quotes ratios against the peers: refuse now, not after the run, when they
    // cannot be measured.
    let python = oracle_python();
    if args.readme.is_some() && !python.is_file() {
        return Err(Error::Message(format!(
            "--readme needs the oracle environment for the peers the README's ratios are \
             against, and there is no Python at {} (scripts/test-all.sh creates .venv; or set \
             CAMSIM_ORACLE_PYTHON); leave --readme out to chart without them",
            python.display()
        )));
    }
    let settings = suite_settings(&args.out, args.quick, &args.data);
    let mut progress = Progress::new("bench");
    let started = std::time::Instant::now();
    let results = suite::run(&settings, &mut |what| {
        progress.step(&format!(
            "[{:5.1} s] {what}",
            started.elapsed().as_secs_f64()
        ))
    })?;
    progress.finish();
    if let Some(why) = &results.peers_skipped {
        eprintln!("note: the peers were skipped: {why}");
    }
    update_readme(args, &results)?;
    let mut out = format!(
        "camsim bench: {:.0} s on {}; in {}:\n",
        results.seconds,
        results.machine.describe(),
        args.out.display()
    );
    for name in suite::FILES {
        out += &format!("  {}\n", args.out.join(name).display());
    }
    Ok(out)
}

/// `--readme`: the README's generated tables from `results`.
fn update_readme(args: &BenchArgs, results: &suite::SuiteResults) -> Result<(), Error> {
    let Some(path) = &args.readme else {
        return Ok(());
    };
    if let Some(why) = &results.peers_skipped {
        return Err(Error::Message(format!(
            "{}: not updated, as the peers its ratios are against did not run ({why}); the \
             charts are written",
            path.display()
        )));
    }
    let text = std::fs::read_to_string(path).map_err(|e| raw_formats::FormatError::io(path, e))?;
    let updated = suite::update_readme(&text, results).map_err(|e| e.in_file(path))?;
    std::fs::write(path, updated).map_err(|e| raw_formats::FormatError::io(path, e))?;
    Ok(())
}

fn bench_dng(args: &BenchDngArgs) -> Result<String, Error> {
    at_least_one_repeat(args.repeats)?;
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
    let lenses = args
        .lens
        .iter()
        .map(|p| {
            host_tracer::lens_file::LensFile::read(p, host_tracer::lens_file::DEFAULT_PBRT_ABBE)
        })
        .collect::<Result<Vec<_>, _>>()?;
    let mut progress = Progress::new("bench render");
    let rows = bench(&scene, &settings, &mut |what| progress.step(what))?;
    let lens_rows =
        host_tracer::render_bench::bench_lenses(&scene, &lenses, &settings, &mut |what| {
            progress.step(what)
        })?;
    progress.finish();
    if args.json {
        if lenses.is_empty() {
            return json(&rows);
        }
        return json(&serde_json::json!({ "features": rows, "lenses": lens_rows }));
    }
    let mut out = table(&rows, &scene.name, &settings);
    if !lens_rows.is_empty() {
        out.push('\n');
        out.push_str(&host_tracer::render_bench::lens_table(&lens_rows));
    }
    Ok(out)
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

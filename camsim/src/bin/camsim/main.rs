//! `camsim`: the camera simulator's command line. The argument types, terminal output and
//! progress bars live here; the work is in the libraries (`camsim`, `host-tracer`,
//! `raw-formats`, `isp-core`, `optics-core`), which never print.

use std::process::ExitCode;

use clap::{Parser, Subcommand};

mod args;
mod cli_args;
mod commands;
mod progress;

use commands::{bench, calibrate, dataset, demo, demosaic, dof, isp, lens, render, tune};

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
    Dof(dof::DofArgs),
    /// A real lens from its prescription (TOML or pbrt's .dat): paraxial data (focal lengths,
    /// principal planes, pupils, f-number) at a wavelength, or rays traced through it.
    Lens(lens::LensArgs),
    /// Demosaic a single-channel 8- or 16-bit Bayer mosaic (PNG or PGM) into RGB of the same depth.
    Demosaic(demosaic::DemosaicArgs),
    /// Run the ISP (defects, black level, lens shading, gain, white balance, demosaic, lens
    /// distortion, denoise, colour matrix, tone, sRGB) on a raw mosaic (PNG or PGM) and write
    /// an sRGB image; options from flags or a TOML file (--config).
    Isp(Box<isp::IspArgs>),
    /// Render a scene (built-in cornell-box or demo, or a TOML file) with the path tracer to
    /// linear RGB radiance (OpenEXR) and an sRGB preview.
    Render(Box<render::RenderArgs>),
    /// The whole camera on a built-in scene: render, sensor, raw DNG, ISP (float and fixed),
    /// ground truth, side-by-side comparison and a report (PSNR, ColorChecker error, AWB).
    Demo(Box<demo::DemoArgs>),
    /// Fit a camera's colour matrix on a rendered ColorChecker (under A and D65 by default)
    /// and write it for camsim isp and camsim demo.
    Calibrate(calibrate::CalibrateArgs),
    /// Tune a camera from its captures (charts, flat fields, darks, photon-transfer pairs named
    /// as Raspberry Pi's tuning tool names them): black level, noise profile, defects, lens
    /// shading, white-balance locus, colour matrices; writes a tuning file (TOML).
    Tune(Box<tune::TuneArgs>),
    /// Shoot a tuning capture set with a simulated camera whose every parameter is known.
    TuneCaptures(Box<tune::TuneCapturesArgs>),
    /// Render a synthetic raw dataset from a spec: each sample (raw DNG, truth EXRs, record)
    /// a pure function of (spec, seed, index), written atomically; --index, --range or --shard
    /// for one worker's share; --index-manifest gathers and checks a finished one.
    Dataset(Box<dataset::DatasetArgs>),
    /// Measure accuracy against speed. Without a subcommand: every suite, with its peers,
    /// written as JSON, SVG charts and a Markdown summary into --out.
    Bench(Box<bench::BenchArgs>),
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(error) => match args::invalid_value_message(&error) {
            Some(line) => {
                eprintln!("error: {line}");
                return ExitCode::from(2);
            }
            None => error.exit(),
        },
    };
    let result = match &cli.command {
        Command::Dof(args) => dof::run(args),
        Command::Lens(args) => lens::run(args),
        Command::Demosaic(args) => demosaic::run(args),
        Command::Isp(args) => isp::run(args),
        Command::Render(args) => render::run(args),
        Command::Demo(args) => demo::run(args),
        Command::Calibrate(args) => calibrate::run(args),
        Command::Tune(args) => tune::run(args),
        Command::TuneCaptures(args) => tune::run_captures(args),
        Command::Dataset(args) => dataset::run(args),
        Command::Bench(args) => bench::run(args),
    };
    match result {
        Ok(out) => {
            print!("{out}");
            ExitCode::SUCCESS
        }
        Err(error) => {
            eprintln!("error: {error}");
            ExitCode::from(2)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(args: &[&str]) -> Command {
        Cli::try_parse_from(args).unwrap().command
    }

    /// The shared render flags keep each command's defaults: demo's seed 1, render's 0 (the
    /// demo's files and the README's figures depend on them).
    #[test]
    fn shared_flags_keep_each_commands_defaults() {
        let Command::Demo(demo) = parse(&["camsim", "demo"]) else {
            panic!("not demo")
        };
        assert_eq!((demo.render.seed, demo.render.threads), (1, 0));
        let Command::Render(render) = parse(&["camsim", "render"]) else {
            panic!("not render")
        };
        assert_eq!((render.render.seed, render.render.threads), (0, 0));
        let Command::Demo(demo) = parse(&["camsim", "demo", "--seed", "7", "--spp", "3"]) else {
            panic!("not demo")
        };
        assert_eq!((demo.render.seed, demo.render.spp), (7, Some(3)));
        let Command::Bench(args) = parse(&["camsim", "bench", "render"]) else {
            panic!("not bench")
        };
        let Some(bench::BenchCommand::Render(b)) = &args.what else {
            panic!("not bench render")
        };
        let r = b.flags();
        assert_eq!(
            (r.width, r.height, r.spp, r.seed, r.threads),
            (Some(256), Some(256), Some(16), 0, 1)
        );
    }

    /// `camsim bench` alone runs the suites; its flags do not go with a subcommand.
    #[test]
    fn bench_without_a_subcommand_runs_the_suites() {
        let Command::Bench(args) = parse(&["camsim", "bench", "--quick", "--out", "x"]) else {
            panic!("not bench")
        };
        assert!(args.what.is_none() && args.quick && args.out == std::path::Path::new("x"));
        assert!(Cli::try_parse_from(["camsim", "bench", "--quick", "isp"]).is_err());
    }
}

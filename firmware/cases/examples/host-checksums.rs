//! The host's side of the firmware comparison: runs every case at the sizes given
//! (`WIDTHxHEIGHT`, default 64x48) and prints the lines the firmware prints, so that
//! `diff` of the two shows any case whose output differs on the target.
//!
//!     cargo run --release -p firmware-cases --example host-checksums -- 64x48 128x96
//!
//! With `--time`, it instead times each case's run on this CPU (one thread, the cores'
//! portable build: the code the firmware runs, compiled for the host) on a 648x492 frame, best
//! of five, and prints `ns_per_pixel <name> <ns>` and `construct_ns <name> <ns>` lines for
//! scripts/firmware-budget.py.
use std::process::ExitCode;
use std::time::Instant;

use firmware_cases::{report, run_case, scratch_needed, Buffers, CASES};

/// The frame `--time` runs on: large enough that per-frame costs vanish, small enough to be
/// quick.
const TIMED: (usize, usize) = (648, 492);

struct Owned {
    mosaic: Vec<u16>,
    out8: Vec<u8>,
    out16: Vec<u16>,
    scratch: Vec<u16>,
    scratch_f32: Vec<f32>,
}

impl Owned {
    fn new(w: usize, h: usize) -> Result<Self, String> {
        let (fixed, float) = scratch_needed(w, h).map_err(|e| format!("{w}x{h}: {e}"))?;
        Ok(Self {
            mosaic: vec![0; w * h],
            out8: vec![0; 3 * w * h],
            out16: vec![0; 3 * w * h],
            scratch: vec![0; fixed],
            scratch_f32: vec![0.0; float],
        })
    }

    fn buffers(&mut self) -> Buffers<'_> {
        Buffers {
            mosaic: &mut self.mosaic,
            out8: &mut self.out8,
            out16: &mut self.out16,
            scratch: &mut self.scratch,
            scratch_f32: &mut self.scratch_f32,
        }
    }
}

fn checksums(sizes: &[(usize, usize)]) -> Result<bool, String> {
    let mut all_ran = true;
    for &(w, h) in sizes {
        let mut owned = Owned::new(w, h)?;
        let mut text = String::new();
        all_ran &= report(&mut text, w, h, &mut owned.buffers(), &mut || 0, false)
            .map_err(|e| e.to_string())?;
        print!("{text}");
    }
    Ok(all_ran)
}

fn times() -> Result<bool, String> {
    let (w, h) = TIMED;
    let mut owned = Owned::new(w, h)?;
    let start = Instant::now();
    let mut clock = || start.elapsed().as_nanos() as u64;
    for case in &CASES {
        let mut best = (u64::MAX, u64::MAX);
        for _ in 0..5 {
            let outcome = run_case(case, w, h, &mut owned.buffers(), &mut clock)
                .map_err(|e| format!("{}: {e}", case.name()))?;
            best = (
                best.0.min(outcome.construct_ticks),
                best.1.min(outcome.run_ticks),
            );
        }
        let name = case.name();
        println!("construct_ns {name} {}", best.0);
        println!("ns_per_pixel {name} {:.3}", best.1 as f64 / (w * h) as f64);
    }
    Ok(true)
}

fn main() -> ExitCode {
    let mut sizes = Vec::new();
    let mut time = false;
    for arg in std::env::args().skip(1) {
        if arg == "--time" {
            time = true;
            continue;
        }
        let parsed = arg
            .split_once('x')
            .and_then(|(w, h)| Some((w.parse::<usize>().ok()?, h.parse::<usize>().ok()?)));
        match parsed {
            Some(size) => sizes.push(size),
            None => {
                eprintln!(
                    "error: `{arg}` is not a frame size WIDTHxHEIGHT (such as 64x48) or --time"
                );
                return ExitCode::from(2);
            }
        }
    }
    if sizes.is_empty() {
        sizes.push((64, 48));
    }
    let result = if time { times() } else { checksums(&sizes) };
    match result {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::FAILURE,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

//! The host's side of the firmware comparison: runs every case at the sizes given
//! (`WIDTHxHEIGHT`, default 64x48) and prints the lines the firmware prints, so that
//! `diff` of the two shows any case whose output differs on the target.
//!
//!     cargo run -p firmware-cases --example host-checksums -- 64x48 128x96
use std::process::ExitCode;

use firmware_cases::{report, scratch_needed, Buffers};

fn main() -> ExitCode {
    let mut sizes = Vec::new();
    for arg in std::env::args().skip(1) {
        let parsed = arg
            .split_once('x')
            .and_then(|(w, h)| Some((w.parse::<usize>().ok()?, h.parse::<usize>().ok()?)));
        match parsed {
            Some(size) => sizes.push(size),
            None => {
                eprintln!("error: `{arg}` is not a frame size WIDTHxHEIGHT, such as 64x48");
                return ExitCode::from(2);
            }
        }
    }
    if sizes.is_empty() {
        sizes.push((64, 48));
    }
    let mut ok = true;
    for (w, h) in sizes {
        let mut mosaic = vec![0u16; w * h];
        let mut out8 = vec![0u8; 3 * w * h];
        let mut out16 = vec![0u16; 3 * w * h];
        let (fixed, float) = match scratch_needed(w, h) {
            Ok(need) => need,
            Err(e) => {
                eprintln!("error: {w}x{h}: {e}");
                return ExitCode::FAILURE;
            }
        };
        eprintln!("{w}x{h}: scratch {fixed} u16, {float} f32");
        let mut scratch = vec![0u16; fixed];
        let mut scratch_f32 = vec![0f32; float];
        let mut buffers = Buffers {
            mosaic: &mut mosaic,
            out8: &mut out8,
            out16: &mut out16,
            scratch: &mut scratch,
            scratch_f32: &mut scratch_f32,
        };
        let mut text = String::new();
        match report(&mut text, w, h, &mut buffers, &mut || 0, false) {
            Ok(all_ran) => ok &= all_ran,
            Err(_) => ok = false,
        }
        print!("{text}");
    }
    if ok {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    }
}

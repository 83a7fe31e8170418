//! The firmware cases on the host: each pipeline case's checksum (`firmware_cases::run_case`,
//! the cores' portable build, as the Cortex-M firmware runs it) equals the checksum of the same
//! frame and configuration developed as `camsim isp` develops it (`camsim::develop::execute`:
//! the CPU's fastest build, in parallel bands). `scripts/firmware-check.sh` then compares the
//! firmware's checksums under QEMU with these, line by line.

use camsim::develop::{execute, RunOptions};
use firmware_cases::{
    config, fill_mosaic, image_checksum, run_case, scratch_needed, Buffers, Case, Path, BIT_DEPTH,
    BLACK_LEVEL, CASES, PATTERN, WHITE_LEVEL,
};
use isp_core::frame::RawFrame;
use isp_core::pipeline::Input;

fn firmware_checksum(case: &Case, w: usize, h: usize) -> u32 {
    let (fixed, float) = scratch_needed(w, h).unwrap();
    let mut mosaic = vec![0u16; w * h];
    let mut out8 = vec![0u8; 3 * w * h];
    let mut out16 = vec![0u16; 3 * w * h];
    let mut scratch = vec![0u16; fixed];
    let mut scratch_f32 = vec![0f32; float];
    let mut buffers = Buffers {
        mosaic: &mut mosaic,
        out8: &mut out8,
        out16: &mut out16,
        scratch: &mut scratch,
        scratch_f32: &mut scratch_f32,
    };
    run_case(case, w, h, &mut buffers, &mut || 0)
        .unwrap()
        .checksum
}

#[test]
fn firmware_cases_equal_the_command_lines_development() {
    for (w, h) in [(64, 48), (128, 96)] {
        let mut mosaic = vec![0u16; w * h];
        fill_mosaic(&mut mosaic, w, h).unwrap();
        let raw = RawFrame::new(
            &mosaic,
            w,
            h,
            w,
            BIT_DEPTH,
            PATTERN,
            [BLACK_LEVEL; 4],
            WHITE_LEVEL,
        )
        .unwrap();
        let mut distinct = std::collections::BTreeSet::new();
        for case in &CASES {
            let Case::Pipeline {
                name,
                path,
                method,
                stages,
                out_bits,
            } = *case
            else {
                continue;
            };
            let firmware = firmware_checksum(case, w, h);
            let config = config(method, stages, w, h).unwrap();
            for threads in [1, 3] {
                let run = RunOptions {
                    threads,
                    stage_times: false,
                };
                let (_, image) = execute(
                    Input::Mosaic(raw),
                    &config,
                    path == Path::Fixed,
                    out_bits,
                    run,
                )
                .unwrap();
                let host = image_checksum(image.data.iter().copied(), out_bits);
                assert_eq!(
                    firmware, host,
                    "{name} at {w}x{h} on {threads} threads: the firmware build's output differs \
                     from the command line's"
                );
            }
            // Every case must develop a different picture, or a stage would be untested.
            assert!(
                distinct.insert(firmware),
                "{name} at {w}x{h} repeats another case's output"
            );
        }
    }
}

#[test]
fn the_test_frame_exercises_the_stages() {
    let (w, h) = (64, 48);
    let mut mosaic = vec![0u16; w * h];
    fill_mosaic(&mut mosaic, w, h).unwrap();
    // Clipped highlights for highlight recovery, deep shadows, and the static defects.
    assert!(mosaic.iter().filter(|v| **v == WHITE_LEVEL).count() > 50);
    assert!(mosaic.iter().any(|v| *v < BLACK_LEVEL + 40));
    for d in firmware_cases::STATIC_DEFECTS {
        let v = mosaic[usize::from(d.y) * w + usize::from(d.x)];
        assert!(v == 0 || v == WHITE_LEVEL, "defect {d:?} reads {v}");
    }
    // Deterministic: a second fill is identical.
    let mut again = vec![0u16; w * h];
    fill_mosaic(&mut again, w, h).unwrap();
    assert_eq!(mosaic, again);
}

#[test]
fn firmware_buffers_hold_every_case_at_every_size() {
    for (w, h) in firmware_cases::FIRMWARE_SIZES {
        assert!(w * h <= firmware_cases::FIRMWARE_MAX_PIXELS);
        let (fixed, float) = scratch_needed(w, h).unwrap();
        assert!(
            fixed <= firmware_cases::FIRMWARE_SCRATCH_U16,
            "{w}x{h}: {fixed} u16"
        );
        assert!(
            float <= firmware_cases::FIRMWARE_SCRATCH_F32,
            "{w}x{h}: {float} f32"
        );
    }
}

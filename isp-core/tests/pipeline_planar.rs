//! The planar schedule (the common camera pipeline over parity-split planar rows) is the
//! general streaming engine, bit for bit, on both paths: for any frame size, stride, pattern, levels,
//! defects, gains, colour matrix, demosaic method, sharpening and band heights, in the baseline build and
//! in the AVX2 and AVX-512 builds. Configurations the schedule does not take run on the engine either way,
//! so they are checked too (the entry must not change them).

use isp_core::demosaic::Method;
use isp_core::dpc::{Defect, DpcConfig};
use isp_core::frame::RawFrame;
use isp_core::pipeline::{FixedPipeline, FloatPipeline, Input, IspConfig, IDENTITY};
use isp_core::CfaPattern;
use proptest::prelude::*;

mod common;
use common::in_bands;

#[derive(Debug, Clone)]
struct Case {
    w: usize,
    h: usize,
    stride: usize,
    pattern: CfaPattern,
    bits: u8,
    black: [u16; 4],
    data: Vec<u16>,
    defects: Vec<Defect>,
    threshold: Option<u16>,
    gain: f32,
    wb: [f32; 3],
    ccm: [[f32; 3]; 3],
    method: Method,
    knee: f32,
    sharpen: f32,
    bands: Vec<usize>,
}

fn case() -> impl Strategy<Value = Case> {
    (4usize..=40, 1usize..=24, 0usize..3, 0usize..4, 8u8..=16).prop_flat_map(
        |(w, h, pad, p, bits)| {
            let max = ((1u32 << bits) - 1) as u16;
            let stride = w + pad;
            (
                proptest::collection::vec(0..=max / 4, 4),
                proptest::collection::vec(
                    prop_oneof![Just(0u16), Just(max), 0..=max],
                    stride * (h - 1) + w,
                ),
                proptest::collection::btree_set((0..w as u16, 0..h as u16), 0..4),
                prop_oneof![Just(None), (1..=max).prop_map(Some)],
                prop_oneof![Just(1.0f32), 0.0f32..63.9],
                proptest::array::uniform3(prop_oneof![Just(1.0f32), 0.0f32..15.9]),
                prop_oneof![
                    Just(IDENTITY),
                    proptest::array::uniform3(proptest::array::uniform3(-8.0f32..7.99))
                ],
                prop_oneof![
                    Just(Method::Mhc),
                    Just(Method::Bilinear),
                    Just(Method::Directional),
                    Just(Method::Nearest)
                ],
                prop_oneof![3 => Just(1.0f32), 1 => 0.0f32..1.0],
                prop_oneof![Just(0.0f32), 0.0f32..=4.0],
                proptest::collection::vec(1usize..=h, 1..4),
            )
                .prop_map(
                    move |(
                        black,
                        data,
                        defects,
                        threshold,
                        gain,
                        wb,
                        ccm,
                        method,
                        knee,
                        sharpen,
                        bands,
                    )| {
                        Case {
                            w,
                            h,
                            stride,
                            pattern: CfaPattern::ALL[p],
                            bits,
                            black: [black[0], black[1], black[2], black[3]],
                            data,
                            defects: defects.into_iter().map(|(x, y)| Defect { x, y }).collect(),
                            threshold,
                            gain,
                            wb,
                            ccm,
                            method,
                            knee,
                            sharpen,
                            bands,
                        }
                    },
                )
        },
    )
}

/// The case's output through `run_input`, `run_input_avx2` and `run_input_avx512` (where the
/// CPU has the features) and the general engine, for the fixed path and for the float path: `[fixed runs, float runs]`,
/// each run named, the engine first.
fn outputs(c: &Case) -> [Vec<(&'static str, Vec<u8>)>; 2] {
    let white = ((1u32 << c.bits) - 1) as u16;
    let raw = RawFrame::new(
        &c.data, c.w, c.h, c.stride, c.bits, c.pattern, c.black, white,
    )
    .unwrap();
    let mut defects = c.defects.clone();
    defects.sort();
    let config = IspConfig {
        dpc: DpcConfig {
            static_defects: &defects,
            dynamic_threshold: c.threshold,
        },
        gain: c.gain,
        wb_gains: c.wb,
        demosaic: c.method,
        highlight_knee: c.knee,
        ccm: c.ccm,
        sharpen: c.sharpen,
        ..IspConfig::default()
    };
    let input = Input::from(&raw);
    let (w, h, bands) = (c.w, c.h, &c.bands);
    let avx2 = avx2();
    let fixed = FixedPipeline::new(&config, 8).unwrap();
    let mut scratch = vec![0u16; fixed.scratch_len(w, h).unwrap()];
    let mut fixed_runs = vec![
        (
            "fixed engine",
            in_bands(w, h, bands, |rows, view| {
                fixed
                    .run_input_general(input, rows, &mut scratch, view)
                    .unwrap()
            }),
        ),
        (
            "fixed run_input",
            in_bands(w, h, bands, |rows, view| {
                fixed.run_input(input, rows, &mut scratch, view).unwrap()
            }),
        ),
    ];
    let float = FloatPipeline::new(&config).unwrap();
    let mut scratch = vec![0f32; float.scratch_len(w, h).unwrap()];
    let mut float_runs = vec![
        (
            "float engine",
            in_bands(w, h, bands, |rows, view| {
                float
                    .run_input_general(input, rows, &mut scratch, view)
                    .unwrap()
            }),
        ),
        (
            "float run_input",
            in_bands(w, h, bands, |rows, view| {
                float.run_input(input, rows, &mut scratch, view).unwrap()
            }),
        ),
    ];
    #[cfg(target_arch = "x86_64")]
    if avx2 {
        let mut scratch = vec![0u16; fixed.scratch_len(w, h).unwrap()];
        fixed_runs.push((
            "fixed run_input_avx2",
            in_bands(w, h, bands, |rows, view| {
                // SAFETY: AVX2 and FMA were detected at run time.
                unsafe { fixed.run_input_avx2(input, rows, &mut scratch, view) }.unwrap()
            }),
        ));
        let mut scratch = vec![0f32; float.scratch_len(w, h).unwrap()];
        float_runs.push((
            "float run_input_avx2",
            in_bands(w, h, bands, |rows, view| {
                // SAFETY: AVX2 and FMA were detected at run time.
                unsafe { float.run_input_avx2(input, rows, &mut scratch, view) }.unwrap()
            }),
        ));
    }
    #[cfg(target_arch = "x86_64")]
    if avx512() {
        let mut scratch = vec![0u16; fixed.scratch_len(w, h).unwrap()];
        fixed_runs.push((
            "fixed run_input_avx512",
            in_bands(w, h, bands, |rows, view| {
                // SAFETY: the AVX-512 features were detected at run time.
                unsafe { fixed.run_input_avx512(input, rows, &mut scratch, view) }.unwrap()
            }),
        ));
        let mut scratch = vec![0f32; float.scratch_len(w, h).unwrap()];
        float_runs.push((
            "float run_input_avx512",
            in_bands(w, h, bands, |rows, view| {
                // SAFETY: the AVX-512 features were detected at run time.
                unsafe { float.run_input_avx512(input, rows, &mut scratch, view) }.unwrap()
            }),
        ));
    }
    [fixed_runs, float_runs]
}

/// Whether the CPU has the features of the `run_input_avx512` entries.
fn avx512() -> bool {
    #[cfg(target_arch = "x86_64")]
    return std::arch::is_x86_feature_detected!("avx512f")
        && std::arch::is_x86_feature_detected!("avx512bw")
        && std::arch::is_x86_feature_detected!("avx512vl")
        && std::arch::is_x86_feature_detected!("avx512dq");
    #[cfg(not(target_arch = "x86_64"))]
    false
}

fn avx2() -> bool {
    #[cfg(target_arch = "x86_64")]
    return std::arch::is_x86_feature_detected!("avx2")
        && std::arch::is_x86_feature_detected!("fma");
    #[cfg(not(target_arch = "x86_64"))]
    false
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn planar_schedule_is_the_engine_bit_for_bit(c in case()) {
        for runs in outputs(&c) {
            let (_, engine) = &runs[0];
            for (name, out) in &runs[1..] {
                let first = out.iter().zip(engine).position(|(a, b)| a != b);
                prop_assert!(first.is_none(), "{name} differs from the engine at sample {first:?}");
            }
        }
    }
}

/// A frame the schedule takes, at a size where every loop runs its vector body: equal to the
/// engine, and the engine's output is not trivially flat (so the comparison could fail).
#[test]
fn planar_schedule_matches_the_engine_on_a_wide_frame() {
    let (w, h) = (517, 37);
    let mut state = 7u32;
    let data: Vec<u16> = (0..w * h)
        .map(|i| {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            let (x, y) = (i % w, i / w);
            (64 + x * 3 + y * 5 + (state >> 26) as usize).min(4095) as u16
        })
        .collect();
    let configurations = [Method::Mhc, Method::Bilinear, Method::Directional]
        .into_iter()
        .flat_map(|method| [(method, 0.0), (method, 1.5)]);
    for (method, sharpen) in configurations {
        let c = Case {
            w,
            h,
            stride: w,
            pattern: CfaPattern::Gbrg,
            bits: 12,
            black: [64, 60, 66, 64],
            data: data.clone(),
            defects: vec![Defect { x: 9, y: 4 }, Defect { x: 516, y: 36 }],
            threshold: Some(64),
            gain: 1.3,
            wb: [1.9, 1.0, 1.6],
            ccm: [[1.6, -0.4, -0.2], [-0.3, 1.5, -0.2], [0.0, -0.5, 1.5]],
            method,
            knee: 1.0,
            sharpen,
            bands: vec![5, 17],
        };
        for runs in outputs(&c) {
            let (engine_name, engine) = &runs[0];
            let distinct: std::collections::BTreeSet<u8> = engine.iter().copied().collect();
            assert!(
                distinct.len() > 100,
                "{method:?}, sharpen {sharpen}: {engine_name} gives {} distinct codes",
                distinct.len()
            );
            for (name, out) in &runs[1..] {
                assert!(
                    out == engine,
                    "{method:?}, sharpen {sharpen}: {name} differs from the engine"
                );
            }
        }
    }
}

//! The pipeline's one schedule is the general streaming engine (`run_input_general`, kept as
//! the reference), bit for bit, on both paths: for any frame size, stride, pattern, levels,
//! defects, shading grid, gains, noise reduction (either window), demosaic method,
//! highlights, lens distortion, colour matrix, tone, chroma noise reduction, sharpening,
//! output depth (8-bit, 16-bit, `f32`), mosaic or linear input and band heights, in the
//! baseline build and in the AVX2 and AVX-512 builds.

use isp_core::demosaic::Method;
use isp_core::denoise::Search;
use isp_core::distortion::{BrownConrady, LensDistortion};
use isp_core::dpc::{Defect, DpcConfig};
use isp_core::frame::{LinearFrame, RawFrame};
use isp_core::lateral_colour::LateralColour;
use isp_core::lsc::LensShading;
use isp_core::noise::NoiseProfile;
use isp_core::pipeline::{FixedPipeline, FloatPipeline, Input, IspConfig, OutputSample, IDENTITY};
use isp_core::tone::Look;
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
    /// A linear frame's samples (three a pixel), run instead of the mosaic when present.
    linear: Option<Vec<u16>>,
    defects: Vec<Defect>,
    threshold: Option<u16>,
    /// A shading grid's sides and gains.
    lsc: Option<(usize, usize, Vec<u16>)>,
    gain: f32,
    wb: [f32; 3],
    denoise: f32,
    search: Search,
    ccm: [[f32; 3]; 3],
    method: Method,
    knee: f32,
    /// Barrel or pincushion strength, when distortion correction is on.
    distortion: Option<f64>,
    /// Red's and blue's scale at the corner (lateral colour), when its correction is on.
    lateral_colour: Option<(f64, f64)>,
    look: Look,
    chroma: f32,
    sharpen: f32,
    /// 8, 16, or 0 for `f32` output (float path alone).
    depth: u8,
    bands: Vec<usize>,
}

fn case() -> impl Strategy<Value = Case> {
    (1usize..=40, 1usize..=24, 0usize..3, 0usize..4, 8u8..=16).prop_flat_map(
        |(w, h, pad, p, bits)| {
            let max = ((1u32 << bits) - 1) as u16;
            let stride = w + pad;
            (
                (
                    proptest::collection::vec(0..=max / 4, 4),
                    proptest::collection::vec(
                        prop_oneof![Just(0u16), Just(max), 0..=max],
                        stride * (h - 1) + w,
                    ),
                    prop_oneof![
                        3 => Just(None),
                        1 => proptest::collection::vec(0..=max, 3 * w * h).prop_map(Some)
                    ],
                    proptest::collection::btree_set((0..w as u16, 0..h as u16), 0..4),
                    prop_oneof![Just(None), (1..=max).prop_map(Some)],
                    prop_oneof![
                        Just(None),
                        (2usize..5, 2usize..5).prop_flat_map(|(gw, gh)| {
                            proptest::collection::vec(2048u16..12000, gw * gh * 4)
                                .prop_map(move |g| Some((gw, gh, g)))
                        })
                    ],
                    prop_oneof![Just(1.0f32), 0.0f32..63.9],
                    proptest::array::uniform3(prop_oneof![Just(1.0f32), 0.0f32..15.9]),
                ),
                (
                    prop_oneof![2 => Just(0.0f32), 1 => 0.1f32..=4.0],
                    prop_oneof![Just(Search::Wide), Just(Search::Fast)],
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
                    prop_oneof![3 => Just(None), 1 => (-0.4f64..0.3).prop_map(Some)],
                    proptest::sample::select(Look::ALL.to_vec()),
                    prop_oneof![Just(0.0f32), 0.0f32..=4.0],
                    prop_oneof![Just(0.0f32), 0.0f32..=4.0],
                    prop_oneof![Just(8u8), Just(16u8), Just(0u8)],
                    proptest::collection::vec(1usize..=h, 1..4),
                    prop_oneof![
                        3 => Just(None),
                        1 => (0.92f64..1.08, 0.92f64..1.08).prop_map(Some)
                    ],
                ),
            )
                .prop_map(
                    move |(
                        (black, data, linear, defects, threshold, lsc, gain, wb),
                        (
                            denoise,
                            search,
                            ccm,
                            method,
                            knee,
                            distortion,
                            look,
                            chroma,
                            sharpen,
                            depth,
                            bands,
                            lateral_colour,
                        ),
                    )| {
                        // Noise reduction takes mosaics of whole 2x2 blocks.
                        let blocks = w % 2 == 0 && h % 2 == 0 && linear.is_none();
                        Case {
                            w,
                            h,
                            stride,
                            pattern: CfaPattern::ALL[p],
                            bits,
                            black: [black[0], black[1], black[2], black[3]],
                            data,
                            defects: match linear {
                                Some(_) => Vec::new(),
                                None => defects.into_iter().map(|(x, y)| Defect { x, y }).collect(),
                            },
                            threshold: threshold.filter(|_| linear.is_none()),
                            linear,
                            lsc,
                            gain,
                            wb,
                            denoise: if blocks { denoise } else { 0.0 },
                            search,
                            ccm,
                            method,
                            knee,
                            distortion,
                            lateral_colour,
                            look,
                            chroma,
                            sharpen,
                            depth,
                            bands,
                        }
                    },
                )
        },
    )
}

/// One run's output as bits (`u8` and `u16` widened, `f32` as its bits).
trait Bits: OutputSample + Default {
    fn bits(self) -> u32;
}

impl Bits for u8 {
    fn bits(self) -> u32 {
        u32::from(self)
    }
}

impl Bits for u16 {
    fn bits(self) -> u32 {
        u32::from(self)
    }
}

impl Bits for f32 {
    fn bits(self) -> u32 {
        self.to_bits()
    }
}

/// Runs `f` over the case's bands with output samples `O`, as bits.
fn banded<O: Bits>(
    c: &Case,
    mut f: impl FnMut(std::ops::Range<usize>, &mut isp_core::frame::RgbViewMut<'_, O>),
) -> Vec<u32> {
    in_bands::<O>(c.w, c.h, &c.bands, |rows, view| f(rows, view))
        .into_iter()
        .map(Bits::bits)
        .collect()
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

/// The fixed path's runs of `input` with `config`: the engine first.
fn fixed_runs<O: Bits>(
    c: &Case,
    config: &IspConfig<'_>,
    input: Input<'_>,
) -> Vec<(&'static str, Vec<u32>)> {
    let (w, h) = (c.w, c.h);
    let fixed = FixedPipeline::new(config, O::BITS).unwrap();
    let need = fixed
        .scratch_len(w, h)
        .unwrap()
        .max(fixed.general_scratch_len(w, h).unwrap());
    let mut scratch = vec![0xA5A5u16; need];
    let mut runs = vec![
        (
            "fixed engine",
            banded::<O>(c, |rows, view| {
                fixed
                    .run_input_general(input, rows, &mut scratch, view)
                    .unwrap()
            }),
        ),
        (
            "fixed run_input",
            banded::<O>(c, |rows, view| {
                let n = fixed.scratch_len(w, h).unwrap();
                fixed
                    .run_input(input, rows, &mut scratch[..n], view)
                    .unwrap()
            }),
        ),
    ];
    #[cfg(target_arch = "x86_64")]
    if avx2() {
        runs.push((
            "fixed run_input_avx2",
            banded::<O>(c, |rows, view| {
                // SAFETY: AVX2 and FMA were detected at run time.
                unsafe { fixed.run_input_avx2(input, rows, &mut scratch, view) }.unwrap()
            }),
        ));
    }
    #[cfg(target_arch = "x86_64")]
    if avx512() {
        runs.push((
            "fixed run_input_avx512",
            banded::<O>(c, |rows, view| {
                // SAFETY: the AVX-512 features were detected at run time.
                unsafe { fixed.run_input_avx512(input, rows, &mut scratch, view) }.unwrap()
            }),
        ));
    }
    runs
}

/// The float path's runs of `input` with `config`: the engine first.
fn float_runs<O: Bits>(
    c: &Case,
    config: &IspConfig<'_>,
    input: Input<'_>,
) -> Vec<(&'static str, Vec<u32>)> {
    let (w, h) = (c.w, c.h);
    let float = FloatPipeline::new(config).unwrap();
    let need = float
        .scratch_len(w, h)
        .unwrap()
        .max(float.general_scratch_len(w, h).unwrap());
    let mut scratch = vec![f32::NAN; need];
    let mut runs = vec![
        (
            "float engine",
            banded::<O>(c, |rows, view| {
                float
                    .run_input_general(input, rows, &mut scratch, view)
                    .unwrap()
            }),
        ),
        (
            "float run_input",
            banded::<O>(c, |rows, view| {
                let n = float.scratch_len(w, h).unwrap();
                float
                    .run_input(input, rows, &mut scratch[..n], view)
                    .unwrap()
            }),
        ),
    ];
    #[cfg(target_arch = "x86_64")]
    if avx2() {
        runs.push((
            "float run_input_avx2",
            banded::<O>(c, |rows, view| {
                // SAFETY: AVX2 and FMA were detected at run time.
                unsafe { float.run_input_avx2(input, rows, &mut scratch, view) }.unwrap()
            }),
        ));
    }
    #[cfg(target_arch = "x86_64")]
    if avx512() {
        runs.push((
            "float run_input_avx512",
            banded::<O>(c, |rows, view| {
                // SAFETY: the AVX-512 features were detected at run time.
                unsafe { float.run_input_avx512(input, rows, &mut scratch, view) }.unwrap()
            }),
        ));
    }
    runs
}

/// Every run of the case, each named, the engine first in each list.
fn outputs(c: &Case) -> Vec<Vec<(&'static str, Vec<u32>)>> {
    let white = ((1u32 << c.bits) - 1) as u16;
    let raw = RawFrame::new(
        &c.data, c.w, c.h, c.stride, c.bits, c.pattern, c.black, white,
    )
    .unwrap();
    let linear = c.linear.as_ref().map(|data| {
        LinearFrame::new(
            data,
            c.w,
            c.h,
            3 * c.w,
            c.bits,
            [c.black[0], c.black[1], c.black[2]],
            [white; 3],
        )
        .unwrap()
    });
    let mut defects = c.defects.clone();
    defects.sort();
    let lsc = c
        .lsc
        .as_ref()
        .map(|(gw, gh, gains)| LensShading::new(*gw, *gh, gains).unwrap());
    let distortion = c.distortion.map(|k1| {
        let f = c.w.max(c.h) as f64;
        let model = BrownConrady::from_opencv([k1, 0.05, 0.001, -0.002, 0.0]).unwrap();
        LensDistortion::new(
            f,
            f,
            (c.w as f64 - 1.0) / 2.0,
            (c.h as f64 - 1.0) / 2.0,
            model,
        )
        .unwrap()
        .fitted(c.w, c.h)
    });
    // Lateral colour: scales from 1 at the centre to the case's at the corner, linear in r^2.
    let lca = c.lateral_colour.map(|(red, blue)| {
        let curve = |corner: f64| core::array::from_fn(|k| 1.0 + (corner - 1.0) * k as f64 / 16.0);
        let centre = [(c.w as f64 - 1.0) / 2.0, (c.h as f64 - 1.0) / 2.0];
        LateralColour::new(c.w, c.h, centre, None, &curve(red), &curve(blue)).unwrap()
    });
    let distortion = match (distortion, lca) {
        (Some(lens), Some(lca)) => Some(lens.with_lateral_colour(lca)),
        (None, Some(lca)) => Some(LensDistortion::lateral_colour_only(lca)),
        (lens, None) => lens,
    };
    let config = IspConfig {
        dpc: DpcConfig {
            static_defects: &defects,
            dynamic_threshold: c.threshold,
        },
        lsc,
        gain: c.gain,
        wb_gains: c.wb,
        demosaic: c.method,
        distortion,
        denoise: c.denoise,
        denoise_search: c.search,
        noise: Some(NoiseProfile::new([0.003, 0.002, 0.004], [1e-5, 2e-6, 0.0]).unwrap()),
        highlight_knee: c.knee,
        ccm: c.ccm,
        tone: c.look.tone(),
        sharpen: c.sharpen,
        chroma_denoise: c.chroma,
    };
    let input = match &linear {
        Some(frame) => Input::from(frame),
        None => Input::from(&raw),
    };
    match c.depth {
        8 => vec![
            fixed_runs::<u8>(c, &config, input),
            float_runs::<u8>(c, &config, input),
        ],
        16 => vec![
            fixed_runs::<u16>(c, &config, input),
            float_runs::<u16>(c, &config, input),
        ],
        _ => vec![float_runs::<f32>(c, &config, input)],
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(384))]

    #[test]
    fn planar_schedule_is_the_engine_bit_for_bit(c in case()) {
        for runs in outputs(&c) {
            let (_, engine) = &runs[0];
            for (name, out) in &runs[1..] {
                let first = out.iter().zip(engine).position(|(a, b)| a != b);
                prop_assert!(
                    first.is_none(),
                    "{name} differs from the engine at sample {first:?}: {:?} against {:?}",
                    first.map(|i| out[i]),
                    first.map(|i| engine[i])
                );
            }
        }
    }
}

/// Frames the schedule runs at a size where every loop runs its vector body, with every
/// stage on in turn: equal to the engine, and the engine's output is not trivially flat (so
/// the comparison could fail).
#[test]
fn planar_schedule_matches_the_engine_on_a_wide_frame() {
    let (w, h) = (518, 38);
    let mut state = 7u32;
    let data: Vec<u16> = (0..w * h)
        .map(|i| {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            let (x, y) = (i % w, i / w);
            (64 + x * 3 + y * 5 + (state >> 26) as usize).min(4095) as u16
        })
        .collect();
    let grid: Vec<u16> = (0..5 * 4 * 4).map(|i| 4096 + 97 * i as u16).collect();
    let base = Case {
        w,
        h,
        stride: w,
        pattern: CfaPattern::Gbrg,
        bits: 12,
        black: [64, 60, 66, 64],
        data: data.clone(),
        linear: None,
        defects: vec![Defect { x: 9, y: 4 }, Defect { x: 517, y: 37 }],
        threshold: Some(64),
        lsc: None,
        gain: 1.3,
        wb: [1.9, 1.0, 1.6],
        denoise: 0.0,
        search: Search::Wide,
        ccm: [[1.6, -0.4, -0.2], [-0.3, 1.5, -0.2], [0.0, -0.5, 1.5]],
        method: Method::Mhc,
        knee: 1.0,
        distortion: None,
        lateral_colour: None,
        look: Look::Neutral,
        chroma: 0.0,
        sharpen: 0.0,
        depth: 8,
        bands: vec![5, 17],
    };
    let variants: Vec<(&str, Case)> = vec![
        ("plain", base.clone()),
        (
            "sharpen",
            Case {
                sharpen: 1.5,
                ..base.clone()
            },
        ),
        (
            "shading",
            Case {
                lsc: Some((5, 4, grid.clone())),
                ..base.clone()
            },
        ),
        (
            "denoise",
            Case {
                denoise: 1.0,
                ..base.clone()
            },
        ),
        (
            "fast denoise",
            Case {
                denoise: 1.0,
                search: Search::Fast,
                ..base.clone()
            },
        ),
        (
            "vivid",
            Case {
                look: Look::Vivid,
                ..base.clone()
            },
        ),
        (
            "chroma",
            Case {
                chroma: 1.0,
                sharpen: 0.7,
                ..base.clone()
            },
        ),
        (
            "distortion",
            Case {
                distortion: Some(-0.2),
                ..base.clone()
            },
        ),
        (
            "lateral colour",
            Case {
                lateral_colour: Some((1.06, 0.95)),
                ..base.clone()
            },
        ),
        (
            "lateral colour and distortion",
            Case {
                distortion: Some(-0.2),
                lateral_colour: Some((0.94, 1.05)),
                ..base.clone()
            },
        ),
        (
            "16-bit",
            Case {
                depth: 16,
                look: Look::Muted,
                ..base.clone()
            },
        ),
        (
            "f32",
            Case {
                depth: 0,
                chroma: 1.0,
                ..base.clone()
            },
        ),
        (
            "highlights",
            Case {
                knee: 0.6,
                ..base.clone()
            },
        ),
    ];
    for (stage, variant) in variants {
        for method in [
            Method::Mhc,
            Method::Bilinear,
            Method::Directional,
            Method::Nearest,
        ] {
            let c = Case {
                method,
                ..variant.clone()
            };
            for runs in outputs(&c) {
                let (engine_name, engine) = &runs[0];
                let distinct: std::collections::BTreeSet<u32> = engine.iter().copied().collect();
                assert!(
                    distinct.len() > 100,
                    "{stage}, {method:?}: {engine_name} gives {} distinct values",
                    distinct.len()
                );
                for (name, out) in &runs[1..] {
                    let first = out.iter().zip(engine).position(|(a, b)| a != b);
                    assert!(
                        first.is_none(),
                        "{stage}, {method:?}: {name} differs from the engine at {first:?}"
                    );
                }
            }
        }
    }
}

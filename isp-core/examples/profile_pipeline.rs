//! Runs the pipeline on a synthetic 2592x1968 10-bit RGGB frame in a loop, for `perf record`:
//! `cargo run --release -p isp-core --example profile_pipeline -- fixed mhc 20`.
//! Arguments: path (float or fixed), demosaic method, frames, highlight knee, chroma noise
//! reduction's strength. Prints ms per
//! frame. Runs the AVX2 entry where the CPU has AVX2, unless `CAMSIM_BASELINE` is set.

use isp_core::dpc::DpcConfig;
use isp_core::frame::{RawFrame, RgbViewMut};
use isp_core::pipeline::{FixedPipeline, FloatPipeline, IspConfig};
use isp_core::CfaPattern;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let path = args.get(1).map_or("fixed", String::as_str);
    let method = args.get(2).map_or("mhc", String::as_str).parse().unwrap();
    let frames: usize = args.get(3).map_or(10, |s| s.parse().unwrap());
    let knee: f32 = args.get(4).map_or(1.0, |s| s.parse().unwrap());
    let chroma: f32 = args.get(5).map_or(0.0, |s| s.parse().unwrap());
    // CAMSIM_BASELINE=1 runs the baseline build even where AVX2 is there.
    let avx2 = std::env::var_os("CAMSIM_BASELINE").is_none() && avx2_detected();
    let (w, h) = (2592usize, 1968usize);
    // A smooth gradient with texture, as a scene is: not constant, not noise.
    let mut state = 1u32;
    let data: Vec<u16> = (0..w * h)
        .map(|i| {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            let (x, y) = (i % w, i / w);
            let base = 64 + (x * 700 / w + y * 200 / h) as u32;
            (base + (state >> 28)).min(1023) as u16
        })
        .collect();
    let raw = RawFrame::new(&data, w, h, w, 10, CfaPattern::Rggb, [64; 4], 1023).unwrap();
    // CAMSIM_STAGES names the camera's other stages to add: any of lsc, denoise, fast (the
    // fast search), tone (vivid), as a comma-separated list.
    let stages = std::env::var("CAMSIM_STAGES").unwrap_or_default();
    let on = |s: &str| stages.split(',').any(|t| t == s);
    let grid: Vec<u16> = (0..17 * 13 * 4)
        .map(|i| 4096 + (i % 97) as u16 * 20)
        .collect();
    let config = IspConfig {
        dpc: DpcConfig {
            static_defects: &[],
            dynamic_threshold: Some(64),
        },
        lsc: on("lsc").then(|| isp_core::lsc::LensShading::new(17, 13, &grid).unwrap()),
        wb_gains: [1.9, 1.0, 1.6],
        demosaic: method,
        denoise: if on("denoise") || on("fast") {
            1.0
        } else {
            0.0
        },
        denoise_search: if on("fast") {
            isp_core::denoise::Search::Fast
        } else {
            isp_core::denoise::Search::Wide
        },
        noise: Some(isp_core::noise::NoiseProfile::uniform(0.0008, 4.3295e-6).unwrap()),
        highlight_knee: knee,
        ccm: [[1.6, -0.4, -0.2], [-0.3, 1.5, -0.2], [0.0, -0.5, 1.5]],
        tone: if on("tone") {
            isp_core::tone::Look::Vivid.tone()
        } else {
            isp_core::tone::Tone::default()
        },
        chroma_denoise: chroma,
        ..IspConfig::default()
    };
    let mut out = vec![0u8; w * h * 3];
    let len = config.scratch_len(w, h).unwrap();
    let mut best = f64::INFINITY;
    for _ in 0..frames {
        let mut view = RgbViewMut::new(&mut out, w, h, 3 * w).unwrap();
        let start = std::time::Instant::now();
        if path == "fixed" {
            let p = FixedPipeline::new(&config, 8).unwrap();
            let mut scratch = vec![0u16; len];
            if avx2 {
                // SAFETY: AVX2 and FMA were detected at run time.
                unsafe { p.run_input_avx2((&raw).into(), 0..h, &mut scratch, &mut view) }.unwrap();
            } else {
                p.run(&raw, 0..h, &mut scratch, &mut view).unwrap();
            }
        } else {
            let p = FloatPipeline::new(&config).unwrap();
            let mut scratch = vec![0f32; len];
            if avx2 {
                // SAFETY: AVX2 and FMA were detected at run time.
                unsafe { p.run_input_avx2((&raw).into(), 0..h, &mut scratch, &mut view) }.unwrap();
            } else {
                p.run(&raw, 0..h, &mut scratch, &mut view).unwrap();
            }
        }
        best = best.min(start.elapsed().as_secs_f64() * 1e3);
    }
    let checksum: u64 = out.iter().map(|v| u64::from(*v)).sum();
    println!(
        "{path} {method:?}: {best:.2} ms per frame, {:.1} Mpix/s, checksum {checksum}",
        (w * h) as f64 / best / 1e3
    );
}

fn avx2_detected() -> bool {
    #[cfg(target_arch = "x86_64")]
    return std::arch::is_x86_feature_detected!("avx2")
        && std::arch::is_x86_feature_detected!("fma");
    #[cfg(not(target_arch = "x86_64"))]
    false
}

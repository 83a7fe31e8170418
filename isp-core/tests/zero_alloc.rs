//! A full pipeline run, both paths, every stage on (distortion correction included), makes no heap allocation: a counting global
//! allocator sees zero between the start and the end of the run.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

use isp_core::demosaic::Method;
use isp_core::distortion::{BrownConrady, LensDistortion};
use isp_core::dpc::{Defect, DefectMap, DpcConfig};
use isp_core::frame::{RawFrame, RgbViewMut};
use isp_core::lsc::LensShading;
use isp_core::noise::NoiseProfile;
use isp_core::pipeline::{scratch_len, FixedPipeline, FloatPipeline, IspConfig};
use isp_core::tone::{Tone, ToneCurve};
use isp_core::wb::{self, AwbMethod};
use isp_core::CfaPattern;

struct Counting;

thread_local! {
    /// Allocations made by this thread. Per thread, because the test harness's own threads
    /// allocate at any time (reporting a finished test, starting the next one), and a global
    /// count made these tests fail now and then.
    static ALLOCATIONS: Cell<usize> = const { Cell::new(0) };
}

/// Allocations made so far by the calling thread.
fn allocations() -> usize {
    ALLOCATIONS.with(Cell::get)
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        // `try_with`: the slot is gone while a thread is being torn down.
        let _ = ALLOCATIONS.try_with(|n| n.set(n.get() + 1));
        unsafe { System.alloc(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn full_pipeline_run_allocates_nothing() {
    let (w, h) = (64, 48);
    let data: Vec<u16> = (0..w * h).map(|i| ((i * 7919) % 4096) as u16).collect();
    let gains = vec![5000u16; 5 * 4 * 4];
    let lens = LensDistortion::new(
        60.0,
        60.0,
        31.5,
        23.5,
        BrownConrady::from_opencv([-0.2, 0.03, 0.001, 0.0, 0.0]).unwrap(),
    )
    .unwrap()
    .fitted(w, h);
    // The scratch is sized before counting starts, for the configuration run below.
    let with_lens = IspConfig {
        distortion: Some(lens),
        lsc: Some(LensShading::new(5, 4, &gains).unwrap()),
        sharpen: 0.5,
        chroma_denoise: 1.0,
        denoise: 1.0,
        noise: Some(NoiseProfile::uniform(0.0032, 1.5e-5).unwrap()),
        ..IspConfig::default()
    };
    let len = with_lens.scratch_len(w, h).unwrap();
    assert!(len > scratch_len(w).unwrap());
    let mut scratch_f = vec![0.0f32; len];
    let mut scratch_u = vec![0u16; len];
    let mut out8 = vec![0u8; w * h * 3];
    let mut out16 = vec![0u16; w * h * 3];
    let mut map: DefectMap<4> = DefectMap::new();
    map.insert(Defect { x: 3, y: 4 }).unwrap();
    let curve = ToneCurve::new(&[[0.0, 0.0], [0.5, 0.6], [1.0, 1.0]]).unwrap();

    let before = allocations();
    let raw = RawFrame::new(&data, w, h, w, 12, CfaPattern::Grbg, [64; 4], 4095).unwrap();
    let awb = wb::estimate(
        &raw,
        AwbMethod::WhitePatch { percentile: 99.0 },
        &isp_core::colour::LINEAR_SRGB_TO_XYZ,
    )
    .unwrap();
    let config = IspConfig {
        dpc: DpcConfig {
            static_defects: map.as_slice(),
            dynamic_threshold: Some(300),
        },
        lsc: Some(LensShading::new(5, 4, &gains).unwrap()),
        gain: 1.3,
        wb_gains: awb.gains,
        demosaic: Method::Mhc,
        distortion: Some(lens),
        denoise: 1.0,
        denoise_search: Default::default(),
        noise: Some(NoiseProfile::uniform(0.0032, 1.5e-5).unwrap()),
        highlight_knee: 0.9,
        ccm: [[1.5, -0.3, -0.2], [-0.2, 1.4, -0.2], [0.0, -0.4, 1.4]],
        tone: Tone {
            saturation: 1.2,
            contrast: 1.1,
            curve,
        },
        sharpen: 0.5,
        chroma_denoise: 1.0,
    };
    let float = FloatPipeline::new(&config).unwrap();
    float
        .run(
            &raw,
            0..h,
            &mut scratch_f,
            &mut RgbViewMut::new(&mut out8, w, h, 3 * w).unwrap(),
        )
        .unwrap();
    let fixed8 = FixedPipeline::new(&config, 8).unwrap();
    fixed8
        .run(
            &raw,
            0..h,
            &mut scratch_u,
            &mut RgbViewMut::new(&mut out8, w, h, 3 * w).unwrap(),
        )
        .unwrap();
    let fixed16 = FixedPipeline::new(&config, 16).unwrap();
    for band in 0..h / 8 {
        let rows = band * 8..band * 8 + 8;
        let chunk = &mut out16[rows.start * 3 * w..rows.end * 3 * w];
        fixed16
            .run(
                &raw,
                rows,
                &mut scratch_u,
                &mut RgbViewMut::new(chunk, w, 8, 3 * w).unwrap(),
            )
            .unwrap();
    }
    let after = allocations();
    assert_eq!(after - before, 0, "the pipeline allocated");
    // The run did something.
    assert!(out8.iter().any(|v| *v > 0) && out16.iter().any(|v| *v > 0));
}

/// The directional demosaic, float and integer, works in the caller's scratch alone.
#[test]
fn directional_demosaic_allocates_nothing() {
    use isp_core::demosaic::directional::{directional, directional_fixed, scratch_len};
    use isp_core::frame::MosaicView;
    let (w, h) = (40, 30);
    let data: Vec<u16> = (0..w * h).map(|i| ((i * 7919) % 65536) as u16).collect();
    let mut rgb = vec![0u16; 3 * w * h];
    let mut scratch = vec![0f32; scratch_len(w).unwrap()];
    let mosaic = MosaicView::new(&data, w, h, w, CfaPattern::Gbrg).unwrap();
    let mut out = RgbViewMut::new(&mut rgb, w, h, 3 * w).unwrap();
    let before = allocations();
    directional(&mosaic, &mut out, &mut scratch).unwrap();
    assert_eq!(allocations(), before);
    assert!(rgb.iter().any(|v| *v != 0));
    // The integer variant too.
    let mut scratch = vec![0i32; scratch_len(w).unwrap()];
    let mut rgb = vec![0u16; 3 * w * h];
    let mut out = RgbViewMut::new(&mut rgb, w, h, 3 * w).unwrap();
    let before = allocations();
    directional_fixed(&mosaic, &mut out, &mut scratch).unwrap();
    assert_eq!(allocations(), before);
    assert!(rgb.iter().any(|v| *v != 0));
}

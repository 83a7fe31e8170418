//! The directional method inside the streaming pipeline is the whole-frame method: with every
//! other stage neutral, the float path's output is the estimated sRGB curve of
//! [`directional`]'s and the fixed path's the encoding table of [`directional_fixed`]'s, for
//! any frame size, pattern and band heights.

use isp_core::demosaic::directional::{directional, directional_fixed, scratch_len};
use isp_core::demosaic::Method;
use isp_core::frame::{MosaicView, RawFrame, RgbViewMut};
use isp_core::pipeline::{FixedPipeline, FloatPipeline, IspConfig};
use isp_core::srgb::{self, EncodeLut};
use isp_core::CfaPattern;
use proptest::prelude::*;

mod common;
use common::in_bands;

fn config() -> IspConfig<'static> {
    IspConfig {
        demosaic: Method::Directional,
        ..IspConfig::default()
    }
}

fn frame() -> impl Strategy<Value = (usize, usize, CfaPattern, Vec<u16>, Vec<usize>)> {
    (1usize..=40, 1usize..=40, 0usize..4).prop_flat_map(|(w, h, p)| {
        (
            Just(w),
            Just(h),
            Just(CfaPattern::ALL[p]),
            proptest::collection::vec(prop_oneof![Just(0u16), Just(65535), any::<u16>()], w * h),
            proptest::collection::vec(1usize..=h, 1..4),
        )
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn float_pipeline_runs_the_whole_frame_method((w, h, pattern, data, bands) in frame()) {
        let raw = RawFrame::new(&data, w, h, w, 16, pattern, [0; 4], 65535).unwrap();
        let pipeline = FloatPipeline::new(&config()).unwrap();
        let mut scratch = vec![0f32; pipeline.scratch_len(w, h).unwrap()];
        let ours = in_bands::<f32>(w, h, &bands, |rows, view| {
            pipeline.run(&raw, rows, &mut scratch, view).unwrap();
        });

        let unit: Vec<f32> = data.iter().map(|&v| v as f32 / 65535.0).collect();
        let mosaic = MosaicView::new(&unit, w, h, w, pattern).unwrap();
        let mut rgb = vec![0f32; w * h * 3];
        let mut view = RgbViewMut::new(&mut rgb, w, h, 3 * w).unwrap();
        directional(&mosaic, &mut view, &mut vec![0.0; scratch_len(w).unwrap()]).unwrap();
        for (i, (o, t)) in ours.iter().zip(&rgb).enumerate() {
            prop_assert_eq!(o.to_bits(), srgb::encode_estimated(*t).to_bits(), "sample {}", i);
        }
    }

    #[test]
    fn fixed_pipeline_runs_the_whole_frame_method((w, h, pattern, data, bands) in frame()) {
        let raw = RawFrame::new(&data, w, h, w, 16, pattern, [0; 4], 65535).unwrap();
        let pipeline = FixedPipeline::new(&config(), 16).unwrap();
        let need = pipeline.scratch_len(w, h).unwrap();
        let mut scratch = vec![0u16; need + 1];
        let ours = in_bands::<u16>(w, h, &bands, |rows, view| {
            pipeline.run(&raw, rows, &mut scratch[..need], view).unwrap();
        });
        // The i32 rings inside the u16 scratch start one element later this time: the
        // alignment is handled both ways.
        let shifted = in_bands::<u16>(w, h, &[h], |rows, view| {
            pipeline.run(&raw, rows, &mut scratch[1..], view).unwrap();
        });
        prop_assert_eq!(&ours, &shifted);

        let mosaic = MosaicView::new(&data, w, h, w, pattern).unwrap();
        let mut rgb = vec![0u16; w * h * 3];
        let mut view = RgbViewMut::new(&mut rgb, w, h, 3 * w).unwrap();
        directional_fixed(&mosaic, &mut view, &mut vec![0; scratch_len(w).unwrap()]).unwrap();
        let encode = EncodeLut::new(16).unwrap();
        for (i, (o, t)) in ours.iter().zip(&rgb).enumerate() {
            prop_assert_eq!(u32::from(*o), encode.lookup(*t), "sample {}", i);
        }
    }
}

/// The scratch the pipeline asks for covers the directional method's rings and is checked;
/// the figures the docs state hold (at 4096 pixels wide: at most 2 MiB for the fixed path).
#[test]
fn directional_scratch_is_sized_and_checked() {
    let (w, h) = (4096, 8);
    let fixed = FixedPipeline::new(&config(), 8).unwrap();
    let float = FloatPipeline::new(&config()).unwrap();
    let fixed_bytes = 2 * fixed.scratch_len(w, h).unwrap();
    let float_bytes = 4 * float.scratch_len(w, h).unwrap();
    assert!(fixed_bytes <= 2 << 20, "{fixed_bytes}");
    assert!(float_bytes <= 2 << 20, "{float_bytes}");
    assert!(config().scratch_len(w, h).unwrap() >= fixed.scratch_len(w, h).unwrap());
    assert!(config().scratch_len(w, h).unwrap() >= float.scratch_len(w, h).unwrap());

    let (w, h) = (24, 20);
    let data = vec![1000u16; w * h];
    let raw = RawFrame::new(&data, w, h, w, 12, CfaPattern::Grbg, [64; 4], 4095).unwrap();
    let mut rgb = vec![0u8; w * h * 3];
    let mut out = RgbViewMut::new(&mut rgb, w, h, 3 * w).unwrap();
    let need = fixed.scratch_len(w, h).unwrap();
    assert!(fixed
        .run(&raw, 0..h, &mut vec![0; need - 2], &mut out)
        .is_err());
    fixed.run(&raw, 0..h, &mut vec![0; need], &mut out).unwrap();
    let need = float.scratch_len(w, h).unwrap();
    assert!(float
        .run(&raw, 0..h, &mut vec![0.0; need - 1], &mut out)
        .is_err());
    float
        .run(&raw, 0..h, &mut vec![0.0; need], &mut out)
        .unwrap();
    assert!(
        rgb.chunks(3).all(|p| p == &rgb[..3]),
        "a flat field stays flat"
    );
}

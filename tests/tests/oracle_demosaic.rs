//! Property 1: bilinear demosaicing with the `opencv` border mode equals OpenCV's
//! `cvtColor(..., COLOR_Bayer*2RGB)` bit for bit, every pixel, for random sizes (1, 2, 3 and odd
//! included), all four patterns, 8- and 16-bit samples, and the edge values 0 and max. On a
//! mismatch proptest shrinks to a minimal mosaic.

use camsim_tests::oracle::{oracle_arrays, Array};
use isp_core::demosaic::{bilinear, Border};
use isp_core::frame::{IntSample, MosaicView, RgbViewMut};
use isp_core::CfaPattern;
use proptest::prelude::*;

fn ours<T: IntSample>(data: &[T], w: usize, h: usize, p: CfaPattern) -> Vec<u32> {
    let mosaic = MosaicView::new(data, w, h, w, p).unwrap();
    let mut rgb = vec![T::default(); 3 * w * h];
    bilinear(
        &mosaic,
        Border::OpenCv,
        &mut RgbViewMut::new(&mut rgb, w, h, 3 * w).unwrap(),
    )
    .unwrap();
    rgb.iter().map(|v| v.to_u32()).collect()
}

fn opencv(input: Array, p: CfaPattern) -> Option<Vec<u32>> {
    let out = oracle_arrays(
        "bayer_bilinear",
        serde_json::json!({ "pattern": p.name() }),
        &[input],
    )?;
    Some(out[0].to_f64().iter().map(|v| *v as u32).collect())
}

fn mosaic(max: u32) -> impl Strategy<Value = (usize, usize, Vec<u32>)> {
    let side = prop_oneof![1usize..=4, 5usize..40];
    (side.clone(), side).prop_flat_map(move |(w, h)| {
        let value = prop_oneof![1 => Just(0u32), 1 => Just(max), 4 => 0..=max];
        (Just(w), Just(h), proptest::collection::vec(value, w * h))
    })
}

fn pattern() -> impl Strategy<Value = CfaPattern> {
    prop::sample::select(CfaPattern::ALL.to_vec())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    #[test]
    fn bilinear_8bit_equals_opencv((w, h, m) in mosaic(255), p in pattern()) {
        let data: Vec<u8> = m.iter().map(|v| *v as u8).collect();
        let Some(theirs) = opencv(Array::U8(data.clone(), vec![h, w]), p) else { return Ok(()) };
        prop_assert_eq!(ours(&data, w, h, p), theirs);
    }

    #[test]
    fn bilinear_16bit_equals_opencv((w, h, m) in mosaic(65535), p in pattern()) {
        let data: Vec<u16> = m.iter().map(|v| *v as u16).collect();
        let Some(theirs) = opencv(Array::U16(data.clone(), vec![h, w]), p) else { return Ok(()) };
        prop_assert_eq!(ours(&data, w, h, p), theirs);
    }
}

/// Property 3: Malvar-He-Cutler within 1 LSB of colour-demosaicing's
/// `demosaicing_CFA_Bayer_Malvar2004` (rounded and clipped) on the interior: a 2-pixel crop,
/// since that library's scipy 'reflect' border breaks the CFA parity.
fn mhc_matches_colour_demosaicing<T: IntSample>(
    data: &[T],
    w: usize,
    h: usize,
    p: CfaPattern,
) -> Result<(), TestCaseError> {
    let mosaic = MosaicView::new(data, w, h, w, p).unwrap();
    let mut rgb = vec![T::default(); 3 * w * h];
    isp_core::demosaic::mhc(
        &mosaic,
        &mut RgbViewMut::new(&mut rgb, w, h, 3 * w).unwrap(),
    )
    .unwrap();
    let input = Array::f64_shaped(data.iter().map(|v| v.to_u32() as f64).collect(), &[h, w]);
    let Some(theirs) = oracle_arrays(
        "malvar2004",
        serde_json::json!({ "pattern": p.name() }),
        &[input],
    ) else {
        return Ok(());
    };
    let theirs = theirs[0].to_f64();
    for y in 2..h - 2 {
        for x in 2..w - 2 {
            for c in 0..3 {
                let i = 3 * (y * w + x) + c;
                let expected = theirs[i].round().clamp(0.0, T::MAX as f64);
                let got = rgb[i].to_u32() as f64;
                prop_assert!(
                    (got - expected).abs() <= 1.0,
                    "({}, {}) channel {}: ours {} theirs {}",
                    x,
                    y,
                    c,
                    got,
                    theirs[i]
                );
            }
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(150))]

    #[test]
    fn mhc_8bit_within_1_lsb((w, h, m) in (5usize..40, 5usize..40).prop_flat_map(|(w, h)| (Just(w), Just(h), proptest::collection::vec(prop_oneof![Just(0u32), Just(255), 0..=255u32], w * h))), p in pattern()) {
        let data: Vec<u8> = m.iter().map(|v| *v as u8).collect();
        mhc_matches_colour_demosaicing(&data, w, h, p)?;
    }

    #[test]
    fn mhc_16bit_within_1_lsb((w, h, m) in (5usize..40, 5usize..40).prop_flat_map(|(w, h)| (Just(w), Just(h), proptest::collection::vec(prop_oneof![Just(0u32), Just(65535), 0..=65535u32], w * h))), p in pattern()) {
        let data: Vec<u16> = m.iter().map(|v| *v as u16).collect();
        mhc_matches_colour_demosaicing(&data, w, h, p)?;
    }
}

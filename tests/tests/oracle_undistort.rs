//! Property 6 (images): isp-core's lens distortion correction against OpenCV's `cv2.undistort`
//! with the same camera matrix and coefficients, within 1 LSB on every pixel, for random
//! sizes, lenses (barrel and pincushion, with tangential terms) and content, 8- and 16-bit; and
//! on a Kodak image under a strong lens.

use camsim_tests::oracle::{oracle_arrays, Array};
use camsim_tests::strategies::lens;
use isp_core::distortion::LensDistortion;
use isp_core::frame::{IntSample, RgbView, RgbViewMut};
use optics_core::distortion::BrownConrady;
use proptest::prelude::*;
use raw_formats::image as imageio;

fn ours<T: IntSample>(data: &[T], w: usize, h: usize, lens: &LensDistortion) -> Vec<u32> {
    let mut out = vec![T::default(); 3 * w * h];
    lens.correct(
        &RgbView::new(data, w, h, 3 * w).unwrap(),
        &mut RgbViewMut::new(&mut out, w, h, 3 * w).unwrap(),
    )
    .unwrap();
    out.iter().map(|v| v.to_u32()).collect()
}

fn opencv(image: Array, lens: &LensDistortion) -> Option<Vec<u32>> {
    let [fx, fy, cx, cy] = lens.camera();
    let out = oracle_arrays(
        "undistort",
        serde_json::json!({ "fx": fx, "fy": fy, "cx": cx, "cy": cy }),
        &[image, Array::f64(lens.model().to_opencv().to_vec())],
    )?;
    Some(out[0].to_f64().iter().map(|v| *v as u32).collect())
}

/// The worst difference and where it is, as `(difference, sample index)`.
fn worst(a: &[u32], b: &[u32]) -> (u32, usize) {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .enumerate()
        .map(|(i, (x, y))| (x.abs_diff(*y), i))
        .max()
        .unwrap_or((0, 0))
}

fn case(max: u32) -> impl Strategy<Value = (usize, usize, Vec<u32>, LensDistortion)> {
    let side = prop_oneof![1usize..=4, 5usize..48];
    (side.clone(), side).prop_flat_map(move |(w, h)| {
        let value = prop_oneof![1 => Just(0u32), 1 => Just(max), 4 => 0..=max];
        (
            Just(w),
            Just(h),
            proptest::collection::vec(value, 3 * w * h),
            lens(w, h),
        )
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    #[test]
    fn matches_opencv_undistort_8bit((w, h, data, lens) in case(255)) {
        let data: Vec<u8> = data.iter().map(|v| *v as u8).collect();
        let Some(theirs) = opencv(Array::U8(data.clone(), vec![h, w, 3]), &lens) else { return Ok(()) };
        let (diff, at) = worst(&ours(&data, w, h, &lens), &theirs);
        prop_assert!(diff <= 1, "{} LSB at sample {}", diff, at);
    }

    #[test]
    fn matches_opencv_undistort_16bit((w, h, data, lens) in case(65535)) {
        let data: Vec<u16> = data.iter().map(|v| *v as u16).collect();
        let Some(theirs) = opencv(Array::U16(data.clone(), vec![h, w, 3]), &lens) else { return Ok(()) };
        let (diff, at) = worst(&ours(&data, w, h, &lens), &theirs);
        prop_assert!(diff <= 1, "{} LSB at sample {}", diff, at);
    }
}

/// A whole Kodak image under strong barrel correction with tangential terms, 8- and 16-bit.
#[test]
fn matches_opencv_undistort_on_kodak() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/kodak/kodim19.png");
    let image = imageio::read(&path).unwrap();
    let (w, h) = (image.width, image.height);
    let model = BrownConrady::from_opencv([-0.28, 0.09, 0.002, -0.001, -0.01]).unwrap();
    let lens = LensDistortion::new(
        0.9 * w as f64,
        0.9 * w as f64,
        (w as f64 - 1.0) / 2.0 + 3.3,
        (h as f64 - 1.0) / 2.0 - 2.1,
        model,
    )
    .unwrap();
    let data8: Vec<u8> = image.data.iter().map(|v| *v as u8).collect();
    let Some(theirs) = opencv(Array::U8(data8.clone(), vec![h, w, 3]), &lens) else {
        return;
    };
    let ours8 = ours(&data8, w, h, &lens);
    let (diff, at) = worst(&ours8, &theirs);
    let differing = ours8.iter().zip(&theirs).filter(|(a, b)| a != b).count();
    println!(
        "kodim19 8-bit: worst {diff} LSB (sample {at}), {differing} of {} samples differ",
        ours8.len()
    );
    assert!(diff <= 1);
    let data16: Vec<u16> = image.data.iter().map(|v| *v * 257).collect();
    let Some(theirs) = opencv(Array::U16(data16.clone(), vec![h, w, 3]), &lens) else {
        return;
    };
    let (diff, at) = worst(&ours(&data16, w, h, &lens), &theirs);
    println!("kodim19 16-bit: worst {diff} LSB (sample {at})");
    assert!(diff <= 1);
    // The lens really moved the picture: most of it is not where it was.
    let moved = ours8
        .iter()
        .zip(&data8)
        .filter(|(a, b)| **a != u32::from(**b))
        .count();
    assert!(moved > ours8.len() / 2, "only {moved} samples changed");
}

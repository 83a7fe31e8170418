//! Property 6 (images): isp-core's lens distortion correction against OpenCV's `cv2.undistort`
//! with the same camera matrix and coefficients, for random sizes, lenses (barrel and
//! pincushion, with tangential terms) and content, 8- and 16-bit; and on a Kodak image under a
//! strong lens.
//!
//! The stated bound: isp-core samples where its mesh puts a pixel (within 1/32 pixel of the
//! exact model per axis, `isp-core/tests/distortion_mesh.rs`, then rounded to 1/32), OpenCV
//! where its float map puts it rounded to 1/32 (`INTER_TAB_SIZE`). The two positions differ by
//! at most 1/32 + 1/64 + 1/64 = 1/16 pixel per axis, and a bilinear interpolation moves by at
//! most its neighbourhood's range `R` per pixel of shift on each axis, so every sample is
//! within `1 + R / 8` (one for the two roundings to an integer), `R` the range of the source
//! samples (0 outside the frame, OpenCV's border) around the exact position. Where the picture
//! is smooth that is 1 LSB: on the Kodak image at least 99 % of samples are within 1.

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

/// The largest excess of `|ours - theirs|` over the stated bound `1 + R / 8` (see the module
/// docs), as `(excess, sample index)`; at most 0 where the bound holds everywhere.
fn excess(
    source: &[u32],
    w: usize,
    h: usize,
    lens: &LensDistortion,
    ours: &[u32],
    theirs: &[u32],
) -> (f64, usize) {
    assert_eq!(ours.len(), theirs.len());
    let mut worst = (f64::MIN, 0);
    for v in 0..h {
        for u in 0..w {
            // The exact model's position, in 1/32 pixel; none: both read the border.
            let corner = lens
                .source_position(u, v)
                .map(|[qx, qy]| (i64::from(qx >> 5), i64::from(qy >> 5)));
            let range = |c: usize| {
                let Some((x0, y0)) = corner else {
                    return 0.0;
                };
                let (mut lo, mut hi) = (u32::MAX, 0u32);
                for y in y0 - 1..=y0 + 2 {
                    for x in x0 - 1..=x0 + 2 {
                        let s = if x < 0 || y < 0 || x >= w as i64 || y >= h as i64 {
                            0
                        } else {
                            source[3 * (y as usize * w + x as usize) + c]
                        };
                        lo = lo.min(s);
                        hi = hi.max(s);
                    }
                }
                f64::from(hi - lo)
            };
            for c in 0..3 {
                let i = 3 * (v * w + u) + c;
                let diff = f64::from(ours[i].abs_diff(theirs[i]));
                let over = diff - (1.0 + range(c) / 8.0);
                if over > worst.0 {
                    worst = (over, i);
                }
            }
        }
    }
    worst
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
        let bytes: Vec<u8> = data.iter().map(|v| *v as u8).collect();
        let Some(theirs) = opencv(Array::U8(bytes.clone(), vec![h, w, 3]), &lens) else { return Ok(()) };
        let (over, at) = excess(&data, w, h, &lens, &ours(&bytes, w, h, &lens), &theirs);
        prop_assert!(over <= 0.0, "{} LSB over the bound at sample {}", over, at);
    }

    #[test]
    fn matches_opencv_undistort_16bit((w, h, data, lens) in case(65535)) {
        let words: Vec<u16> = data.iter().map(|v| *v as u16).collect();
        let Some(theirs) = opencv(Array::U16(words.clone(), vec![h, w, 3]), &lens) else { return Ok(()) };
        let (over, at) = excess(&data, w, h, &lens, &ours(&words, w, h, &lens), &theirs);
        prop_assert!(over <= 0.0, "{} LSB over the bound at sample {}", over, at);
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
    .unwrap()
    .fitted(w, h);
    let data8: Vec<u8> = image.data.iter().map(|v| *v as u8).collect();
    let Some(theirs) = opencv(Array::U8(data8.clone(), vec![h, w, 3]), &lens) else {
        return;
    };
    let ours8 = ours(&data8, w, h, &lens);
    let wide = |d: &[u8]| d.iter().map(|v| u32::from(*v)).collect::<Vec<_>>();
    let within_one = |a: &[u32], b: &[u32]| {
        a.iter()
            .zip(b)
            .filter(|(x, y)| x.abs_diff(**y) <= 1)
            .count() as f64
            / a.len() as f64
    };
    let (over, at) = excess(&wide(&data8), w, h, &lens, &ours8, &theirs);
    let share = within_one(&ours8, &theirs);
    println!(
        "kodim19 8-bit: {:.2} % of samples within 1 LSB, worst excess over the bound {over} (sample {at})",
        100.0 * share
    );
    assert!(over <= 0.0 && share >= 0.99);
    let data16: Vec<u16> = image.data.iter().map(|v| *v * 257).collect();
    let Some(theirs) = opencv(Array::U16(data16.clone(), vec![h, w, 3]), &lens) else {
        return;
    };
    let ours16 = ours(&data16, w, h, &lens);
    let source16: Vec<u32> = data16.iter().map(|v| u32::from(*v)).collect();
    let (over, at) = excess(&source16, w, h, &lens, &ours16, &theirs);
    println!("kodim19 16-bit: worst excess over the bound {over} (sample {at})");
    assert!(over <= 0.0);
    // The lens really moved the picture: most of it is not where it was.
    let moved = ours8
        .iter()
        .zip(&data8)
        .filter(|(a, b)| **a != u32::from(**b))
        .count();
    assert!(moved > ours8.len() / 2, "only {moved} samples changed");
}

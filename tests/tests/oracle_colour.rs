//! isp-core's colorimetry and sRGB curves against colour-science 0.4.7 (the oracle).

use camsim_tests::first_mismatch;
use camsim_tests::oracle::{oracle_arrays, Array};
use isp_core::colour::*;
use isp_core::srgb;
use proptest::prelude::*;

fn flat(rows: &[[f64; 3]]) -> Vec<f64> {
    rows.iter().flatten().copied().collect()
}

#[test]
fn srgb_xyz_matrices_equal_colour_science() {
    let Some(m) = oracle_arrays("srgb_matrices", serde_json::json!({}), &[]) else {
        return;
    };
    assert_eq!(
        first_mismatch(&flat(&XYZ_TO_LINEAR_SRGB), &m[0].to_f64(), 1e-12, 0.0),
        None
    );
    assert_eq!(
        first_mismatch(&flat(&LINEAR_SRGB_TO_XYZ), &m[1].to_f64(), 1e-12, 0.0),
        None
    );
}

/// Property 4 (fixed point): the sRGB encoding table, over every linear `u16` input, is within
/// 0.5 LSB of colour-science's `eotf_inverse_sRGB` at 8 and 16 bits before its final rounding,
/// so the rounded output is the exact curve's rounding except where the curve sits within the
/// table's error of a half.
#[test]
fn srgb_encode_lut_within_half_lsb_of_colour_science() {
    let input = Array::f64((0..=65535u32).map(|v| v as f64 / 65535.0).collect());
    let Some(exact) = oracle_arrays("srgb_encode", serde_json::json!({}), &[input]) else {
        return;
    };
    let exact = exact[0].to_f64();
    for bits in [8u8, 16] {
        let lut = srgb::EncodeLut::new(bits).unwrap();
        let max = lut.max() as f64;
        let (mut worst, mut at, mut rounded_off) = (0.0f64, 0usize, 0usize);
        for (v, e) in exact.iter().enumerate() {
            let target = e * max;
            let ours = lut.lookup_q8(v as u16) as f64 / 256.0;
            if (ours - target).abs() > worst {
                (worst, at) = ((ours - target).abs(), v);
            }
            let rounded = lut.lookup(v as u16) as f64;
            if rounded != target.round() {
                rounded_off += 1;
                // Only where the exact value is within the table's error of a rounding edge.
                assert!(
                    (target.fract() - 0.5).abs() <= worst + 1e-9,
                    "{bits}-bit input {v}: {rounded} vs {target}"
                );
            }
        }
        println!("{bits}-bit sRGB table: worst {worst:.4} LSB (input {at}); {rounded_off} of 65536 outputs round the other way");
        assert!(worst <= 0.5, "{bits}-bit: {worst} LSB at input {at}");
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Property 4 (float): encode and decode within 1e-6 of colour-science over [0, 1],
    /// including both ends and the segment joins.
    #[test]
    fn srgb_curves_match(mut xs in proptest::collection::vec(0.0f32..=1.0, 256)) {
        xs.extend([0.0, 1.0, srgb::LINEAR_THRESHOLD, srgb::ENCODED_THRESHOLD, 1e-7]);
        let input = Array::f64(xs.iter().map(|x| *x as f64).collect());
        let Some(enc) = oracle_arrays("srgb_encode", serde_json::json!({}), std::slice::from_ref(&input)) else { return Ok(()) };
        let Some(dec) = oracle_arrays("srgb_decode", serde_json::json!({}), &[input]) else { return Ok(()) };
        let ours_enc: Vec<f64> = xs.iter().map(|x| srgb::encode(*x) as f64).collect();
        let ours_dec: Vec<f64> = xs.iter().map(|x| srgb::decode(*x) as f64).collect();
        prop_assert_eq!(first_mismatch(&ours_enc, &enc[0].to_f64(), 0.0, 1e-6), None);
        prop_assert_eq!(first_mismatch(&ours_dec, &dec[0].to_f64(), 0.0, 1e-6), None);
    }

    /// Property 5: Bradford chromatic adaptation (von Kries) to 1e-6 relative.
    #[test]
    fn bradford_matches(
        xyz in proptest::collection::vec([0.0f64..1.0, 0.0f64..1.0, 0.0f64..1.0], 32),
        src_cct in 4000.0f64..25000.0, dst_cct in 4000.0f64..25000.0, scale in 0.5f64..2.0,
    ) {
        let src = xy_to_xyz(cct_to_xy_daylight(src_cct).unwrap()).unwrap().map(|c| c * scale);
        let dst = xy_to_xyz(cct_to_xy_daylight(dst_cct).unwrap()).unwrap();
        let m = bradford_adaptation(src, dst).unwrap();
        let ours: Vec<f64> = xyz.iter().flat_map(|v| mat3_mul_vec(&m, *v)).collect();
        let Some(theirs) = oracle_arrays("bradford", serde_json::json!({}), &[
            Array::f64_shaped(flat(&xyz), &[xyz.len(), 3]), Array::f64(src.to_vec()), Array::f64(dst.to_vec()),
        ]) else { return Ok(()) };
        prop_assert_eq!(first_mismatch(&ours, &theirs[0].to_f64(), 1e-6, 1e-12), None);
    }

    /// Property 5: xy -> CCT (McCamy 1992) and CCT -> xy (CIE daylight locus).
    #[test]
    fn cct_matches(xy in proptest::collection::vec((0.25f64..0.5, 0.25f64..0.45), 64), ccts in proptest::collection::vec(4000.0f64..25000.0, 64)) {
        let pts: Vec<f64> = xy.iter().flat_map(|(x, y)| [*x, *y]).collect();
        let ours: Vec<f64> = xy.iter().map(|(x, y)| xy_to_cct_mccamy([*x, *y]).unwrap()).collect();
        let Some(theirs) = oracle_arrays("xy_to_cct_mccamy", serde_json::json!({}), &[Array::f64_shaped(pts, &[xy.len(), 2])]) else { return Ok(()) };
        prop_assert_eq!(first_mismatch(&ours, &theirs[0].to_f64(), 1e-6, 1e-9), None);
        let ours: Vec<f64> = ccts.iter().flat_map(|t| cct_to_xy_daylight(*t).unwrap()).collect();
        let Some(theirs) = oracle_arrays("cct_to_xy_daylight", serde_json::json!({}), &[Array::f64(ccts.clone())]) else { return Ok(()) };
        prop_assert_eq!(first_mismatch(&ours, &theirs[0].to_f64(), 1e-6, 1e-12), None);
    }

    /// Property 5: CIE L*a*b* and CIEDE2000, including neutral colours (hue undefined) and
    /// pairs on opposite sides of the hue circle.
    #[test]
    fn lab_and_delta_e_2000_match(
        xyz in proptest::collection::vec([0.0f64..1.0, 0.0f64..1.0, 0.0f64..1.1], 32),
        white_cct in 4000.0f64..10000.0,
        pairs in proptest::collection::vec(([0.0f64..100.0, -128.0f64..128.0, -128.0f64..128.0], [0.0f64..100.0, -128.0f64..128.0, -128.0f64..128.0]), 64),
    ) {
        let white_xy = cct_to_xy_daylight(white_cct).unwrap();
        let white = xy_to_xyz(white_xy).unwrap();
        let ours: Vec<f64> = xyz.iter().flat_map(|v| xyz_to_lab(*v, white).unwrap()).collect();
        let Some(theirs) = oracle_arrays("xyz_to_lab", serde_json::json!({}), &[
            Array::f64_shaped(flat(&xyz), &[xyz.len(), 3]), Array::f64(white_xy.to_vec()),
        ]) else { return Ok(()) };
        prop_assert_eq!(first_mismatch(&ours, &theirs[0].to_f64(), 1e-6, 1e-9), None);

        let mut pairs = pairs;
        pairs.push(([50.0, 0.0, 0.0], [60.0, 0.0, 0.0]));
        pairs.push(([50.0, 0.0, 0.0], [50.0, -3.0, 0.0]));
        pairs.push(([50.0, -10.0, 0.001], [50.0, -10.0, -0.001]));
        let (a, b): (Vec<[f64; 3]>, Vec<[f64; 3]>) = pairs.iter().copied().unzip();
        let ours: Vec<f64> = pairs.iter().map(|(p, q)| delta_e_2000(*p, *q)).collect();
        let Some(theirs) = oracle_arrays("delta_e_2000", serde_json::json!({}), &[
            Array::f64_shaped(flat(&a), &[a.len(), 3]), Array::f64_shaped(flat(&b), &[b.len(), 3]),
        ]) else { return Ok(()) };
        prop_assert_eq!(first_mismatch(&ours, &theirs[0].to_f64(), 1e-6, 1e-9), None);
    }
}

use isp_core::{srgb, CfaColour, CfaPattern};
use proptest::prelude::*;

/// The IEC 61966-2-1 curve computed independently in f64.
fn encode_f64(x: f64) -> f64 {
    if x <= 0.0031308 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    }
}

proptest! {
    #[test]
    fn encode_matches_the_standard(x in 0.0f32..=1.0) {
        prop_assert!((srgb::encode(x) as f64 - encode_f64(x as f64)).abs() < 2e-6);
    }

    #[test]
    fn decode_inverts_encode(x in 0.0f32..=1.0) {
        prop_assert!((srgb::decode(srgb::encode(x)) - x).abs() < 2e-6);
    }

    #[test]
    fn output_always_in_range(x in proptest::num::f32::ANY) {
        let (e, d) = (srgb::encode(x), srgb::decode(x));
        prop_assert!((0.0..=1.0).contains(&e) && (0.0..=1.0).contains(&d));
    }

    #[test]
    fn encode_is_monotonic(a in 0.0f32..=1.0, b in 0.0f32..=1.0) {
        let (lo, hi) = if a <= b { (a, b) } else { (b, a) };
        prop_assert!(srgb::encode(lo) <= srgb::encode(hi));
    }
}

#[test]
fn curve_endpoints_and_segments_meet() {
    assert_eq!(srgb::encode(0.0), 0.0);
    assert!((srgb::encode(1.0) - 1.0).abs() < 1e-6);
    let t = srgb::LINEAR_THRESHOLD;
    assert!((srgb::encode(t) - (1.055 * t.powf(1.0 / 2.4) - 0.055)).abs() < 1e-6);
}

#[test]
fn cfa_patterns() {
    for p in CfaPattern::ALL {
        assert_eq!(p.name().parse::<CfaPattern>().unwrap(), p);
        assert_eq!(p.name().to_lowercase().parse::<CfaPattern>().unwrap(), p);
        // Each 2x2 block has two greens on a diagonal, and the pattern repeats with period 2.
        let greens = (0..2)
            .flat_map(|y| (0..2).map(move |x| (x, y)))
            .filter(|&(x, y)| p.colour_at(x, y) == CfaColour::Green)
            .count();
        assert_eq!(greens, 2);
        assert_eq!(
            p.colour_at(0, 0) == CfaColour::Green,
            p.colour_at(1, 1) == CfaColour::Green
        );
        assert_eq!(p.colour_at(4, 6), p.colour_at(0, 0));
        assert_eq!(p.colour_at(5, 7), p.colour_at(1, 1));
    }
    assert_eq!(CfaPattern::Rggb.opencv_name(), "COLOR_BayerBG2RGB");
    assert!("RGBG".parse::<CfaPattern>().is_err());
}

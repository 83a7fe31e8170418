//! Stages on their own: defect correction on injected defects, shading against a cos^4
//! falloff, AWB on scenes with a known illuminant, calibration and presets, the fixed-point
//! tables against the exact curves, distortion correction against a scene seen through a known
//! lens.

use isp_core::ccm::Calibration;
use isp_core::colour::{self, LINEAR_SRGB_TO_XYZ};
use isp_core::distortion::{BrownConrady, LensDistortion};
use isp_core::dpc::{correct_row, Defect, DefectMap, DpcConfig};
use isp_core::frame::{RawFrame, RgbView, RgbViewMut, Sample};
use isp_core::lateral_colour::{LateralColour, NODES};
use isp_core::lsc::LensShading;
use isp_core::pipeline::{scratch_len, FixedPipeline, IspConfig};
use isp_core::srgb::{self, exact_code8, EncodeLut, EncodeThresholds8};
use isp_core::tone::{Look, Tone, ToneCurve, ToneLut};
use isp_core::wb::{self, AwbMethod, WbPreset};
use isp_core::CfaPattern;
use isp_core::IspError;
use proptest::prelude::*;

/// A smooth 12-bit scene in the mosaic: each CFA colour a gentle ramp.
fn smooth_scene(w: usize, h: usize, pattern: CfaPattern) -> Vec<u16> {
    let mut data = vec![0u16; w * h];
    for y in 0..h {
        for x in 0..w {
            let c = pattern.colour_at(x, y).index() as f32;
            data[y * w + x] = (800.0 + 20.0 * x as f32 + 15.0 * y as f32 + 300.0 * c) as u16;
        }
    }
    data
}

fn correct(data: &[u16], w: usize, h: usize, p: CfaPattern, config: &DpcConfig) -> Vec<u16> {
    let raw = RawFrame::new(data, w, h, w, 12, p, [0; 4], 4095).unwrap();
    let mut out = vec![0u16; w * h];
    for y in 0..h {
        correct_row(&raw, config, y, &mut out[y * w..(y + 1) * w]).unwrap();
    }
    out
}

/// The dynamic rule written out pixel by pixel, as the dpc module states it: the usable
/// same-colour neighbours (mirrored about the pixel off the frame; not the pixel, not listed),
/// an outlier among three or more by more than the threshold replaced by their median; listed
/// pixels replaced by the median of whatever neighbours are usable.
fn dpc_rule(data: &[u16], w: usize, h: usize, config: &DpcConfig) -> Vec<u16> {
    let listed = |x: usize, y: usize| {
        config.static_defects.contains(&Defect {
            x: x as u16,
            y: y as u16,
        })
    };
    let mirror = |i: usize, d: isize, n: usize| {
        [i as isize + d, i as isize - d]
            .into_iter()
            .find(|v| (0..n as isize).contains(v))
            .map(|v| v as usize)
    };
    let mut out = data.to_vec();
    for y in 0..h {
        for x in 0..w {
            let mut n = Vec::new();
            for (dx, dy) in [
                (-2, -2),
                (0, -2),
                (2, -2),
                (-2, 0),
                (2, 0),
                (-2, 2),
                (0, 2),
                (2, 2),
            ] {
                if let (Some(nx), Some(ny)) = (mirror(x, dx, w), mirror(y, dy, h)) {
                    if (nx, ny) != (x, y) && !listed(nx, ny) {
                        n.push(data[ny * w + nx] as u32);
                    }
                }
            }
            n.sort();
            let median = |n: &[u32]| {
                let k = n.len();
                if k % 2 == 1 {
                    n[k / 2]
                } else {
                    (n[k / 2 - 1] + n[k / 2]).div_ceil(2)
                }
            };
            let v = data[y * w + x] as u32;
            if listed(x, y) {
                if !n.is_empty() {
                    out[y * w + x] = median(&n) as u16;
                }
            } else if let (Some(t), true) = (config.dynamic_threshold, n.len() >= 3) {
                let k = n.len();
                if v > n[k - 2] + t as u32 || v + (t as u32) < n[1] {
                    out[y * w + x] = median(&n) as u16;
                }
            }
        }
    }
    out
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]
    /// Defect correction, whose interior runs a vectorised detection, equals the rule written
    /// out pixel by pixel, on noisy frames with spikes and listed pixels, at any width
    /// (spanning several detection blocks) and any threshold.
    #[test]
    fn dpc_equals_the_rule_pixel_by_pixel(
        w in 1usize..300,
        h in 1usize..9,
        seed in any::<u64>(),
        // Samples and thresholds on a grid of 50 as well, so the comparisons meet ties.
        threshold in prop_oneof![
            Just(None),
            (0u16..2000).prop_map(Some),
            (0u16..12).prop_map(|k| Some(50 * k)),
            Just(Some(u16::MAX)),
        ],
        grid in any::<bool>(),
        listed in prop::collection::vec((0usize..300, 0usize..9), 0..4),
    ) {
        let mut state = seed | 1;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        let data: Vec<u16> = (0..w * h)
            .map(|_| match next() % 16 {
                0 => 4095,
                1 => 0,
                _ if grid => 1500 + 50 * (next() % 8) as u16,
                _ => 1500 + (next() % 400) as u16,
            })
            .collect();
        let mut map: DefectMap<8> = DefectMap::new();
        for (x, y) in listed.iter().filter(|(x, y)| *x < w && *y < h) {
            map.insert(Defect { x: *x as u16, y: *y as u16 }).unwrap();
        }
        let config = DpcConfig { static_defects: map.as_slice(), dynamic_threshold: threshold };
        for pattern in [CfaPattern::Rggb, CfaPattern::Gbrg] {
            prop_assert_eq!(correct(&data, w, h, pattern, &config), dpc_rule(&data, w, h, &config));
        }
    }
}

/// Hot, dead and stuck pixels, alone, in clusters (a 2x2 block and a same-colour pair) and on
/// the border and corners, are found dynamically and replaced by a value within the range of
/// their same-colour neighbours; the clean pixels are untouched.
#[test]
fn dynamic_detection_replaces_injected_defects() {
    let (w, h) = (20, 16);
    for pattern in CfaPattern::ALL {
        let clean = smooth_scene(w, h, pattern);
        let mut data = clean.clone();
        let defects: [(usize, usize, u16); 11] = [
            (5, 5, 4095),   // hot
            (9, 4, 0),      // dead
            (13, 9, 2900),  // stuck at a mid value
            (0, 0, 4095),   // corner
            (19, 7, 0),     // right border
            (6, 15, 4095),  // bottom border
            (10, 12, 4095), // 2x2 cluster
            (11, 12, 4095),
            (10, 13, 4095),
            (11, 13, 4095),
            (15, 2, 4095), // with (17, 2): a same-colour pair
        ];
        for &(x, y, v) in &defects {
            data[y * w + x] = v;
        }
        data[2 * w + 17] = 4095;
        let config = DpcConfig {
            static_defects: &[],
            dynamic_threshold: Some(400),
        };
        let out = correct(&data, w, h, pattern, &config);
        let mut bad: Vec<(usize, usize)> = defects.iter().map(|d| (d.0, d.1)).collect();
        bad.push((17, 2));
        for y in 0..h {
            for x in 0..w {
                let (o, c) = (out[y * w + x] as i32, clean[y * w + x] as i32);
                if bad.contains(&(x, y)) {
                    // The smooth scene changes by at most 2 * (20 + 15) between same-colour
                    // neighbours, so a good replacement is that close to the clean value.
                    assert!(
                        (o - c).abs() <= 80,
                        "{pattern:?} ({x}, {y}): {o} vs clean {c}"
                    );
                } else {
                    assert_eq!(o, c, "{pattern:?} ({x}, {y}) changed");
                }
            }
        }
    }
}

/// A one-pixel bright line is detail, not a defect: it stays.
#[test]
fn dynamic_detection_keeps_a_thin_line() {
    let (w, h) = (16, 12);
    let mut data = smooth_scene(w, h, CfaPattern::Rggb);
    for x in 0..w {
        data[5 * w + x] = 3500;
    }
    let config = DpcConfig {
        static_defects: &[],
        dynamic_threshold: Some(400),
    };
    assert_eq!(correct(&data, w, h, CfaPattern::Rggb, &config), data);
}

/// Listed pixels are replaced whatever their value, and a listed neighbour never feeds a
/// replacement, so a listed cluster is repaired from good pixels only.
#[test]
fn static_map_replaces_listed_pixels_from_good_neighbours() {
    let (w, h) = (12, 10);
    let clean = smooth_scene(w, h, CfaPattern::Grbg);
    let mut data = clean.clone();
    let mut map: DefectMap<8> = DefectMap::new();
    for (x, y) in [(4usize, 4usize), (6, 4), (4, 6), (0, 9), (11, 0)] {
        data[y * w + x] = 4095;
        map.insert(Defect {
            x: x as u16,
            y: y as u16,
        })
        .unwrap();
    }
    map.insert(Defect { x: 4, y: 4 }).unwrap(); // a duplicate changes nothing
    assert_eq!(map.as_slice().len(), 5);
    let config = DpcConfig {
        static_defects: map.as_slice(),
        dynamic_threshold: None,
    };
    let out = correct(&data, w, h, CfaPattern::Grbg, &config);
    for d in map.as_slice() {
        let i = d.y as usize * w + d.x as usize;
        assert!(
            (out[i] as i32 - clean[i] as i32).abs() <= 80,
            "{d:?}: {}",
            out[i]
        );
    }
    let unlisted = (0..w * h).filter(|i| {
        !map.as_slice()
            .iter()
            .any(|d| d.y as usize * w + d.x as usize == *i)
    });
    for i in unlisted {
        assert_eq!(out[i], data[i]);
    }
    // A full map says so.
    let mut small: DefectMap<1> = DefectMap::new();
    small.insert(Defect { x: 0, y: 0 }).unwrap();
    assert!(small.insert(Defect { x: 1, y: 0 }).is_err());
    // An unsorted list is refused.
    let unsorted = [Defect { x: 2, y: 1 }, Defect { x: 1, y: 1 }];
    let config = DpcConfig {
        static_defects: &unsorted,
        dynamic_threshold: None,
    };
    let raw = RawFrame::new(&data, w, h, w, 12, CfaPattern::Grbg, [0; 4], 4095).unwrap();
    assert!(correct_row(&raw, &config, 0, &mut vec![0; w]).is_err());
}

/// Shading correction undoes a synthetic cos^4 falloff with colour shading: a flat grey scene
/// seen through it comes back flat to the grid's interpolation error.
#[test]
fn lens_shading_undoes_cos4_falloff() {
    let (w, h) = (160, 120);
    let (gw, gh) = (17, 13);
    // Half field of view 35 degrees on the diagonal; red falls off 10% more at the corner.
    let half_diag = ((w - 1) as f64).hypot((h - 1) as f64) / 2.0;
    let focal = half_diag / 35f64.to_radians().tan();
    let falloff = |x: f64, y: f64, position: usize| {
        let r = (x - (w - 1) as f64 / 2.0).hypot(y - (h - 1) as f64 / 2.0);
        let cos = (r / focal).atan().cos();
        let colour_shading = if position == 0 {
            1.0 - 0.1 * (r / half_diag).powi(2)
        } else {
            1.0
        };
        cos.powi(4) * colour_shading
    };
    let mut gains = vec![0u16; gw * gh * 4];
    for gy in 0..gh {
        for gx in 0..gw {
            let (x, y) = (
                gx as f64 * (w - 1) as f64 / (gw - 1) as f64,
                gy as f64 * (h - 1) as f64 / (gh - 1) as f64,
            );
            for p in 0..4 {
                gains[(gy * gw + gx) * 4 + p] = (4096.0 / falloff(x, y, p)).round() as u16;
            }
        }
    }
    let lsc = LensShading::new(gw, gh, &gains).unwrap();
    let mut worst: f64 = 0.0;
    for y in 0..h {
        for x in 0..w {
            let p = (y % 2) * 2 + x % 2;
            let seen = 0.5 * falloff(x as f64, y as f64, p);
            let corrected = seen * lsc.gain_f32(x, y, w, h) as f64;
            worst = worst.max((corrected / 0.5 - 1.0).abs());
        }
    }
    // Bilinear interpolation of the smooth 1/cos^4 on a 17x13 grid, Q4.12 nodes: under 1%,
    // against a falloff of more than a third at the corner.
    assert!(worst < 0.01, "worst relative error {worst}");
    // The corner is darkened by more than a third, so the test has something to correct.
    assert!(falloff(0.0, 0.0, 1) < 0.65);
}

/// A scene of random reflectances under a coloured illuminant, as a 12-bit mosaic.
fn tinted_scene(illuminant: [f32; 3], pattern: CfaPattern, seed: u64, colourful: bool) -> Vec<u16> {
    let (w, h) = (64, 48);
    let mut state = seed;
    let mut next = || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((state >> 33) as f32) / (1u64 << 31) as f32
    };
    // 8x8 patches of grey-world-balanced colours: each patch's colour and its complement.
    let mut patches = vec![[0.0f32; 3]; 8 * 6];
    for i in 0..patches.len() / 2 {
        let c = if colourful {
            [next(), next(), next()].map(|v| 0.1 + 0.6 * v)
        } else {
            [next(); 3].map(|v| 0.1 + 0.6 * v)
        };
        patches[2 * i] = c;
        patches[2 * i + 1] = c.map(|v| 0.8 - v);
    }
    let mut data = vec![0u16; w * h];
    for y in 0..h {
        for x in 0..w {
            let c = pattern.colour_at(x, y).index();
            let reflectance = patches[(y / 8) * 8 + x / 8][c];
            // Edges between patches in every channel, so grey edge has something to see.
            data[y * w + x] = (64.0 + 3000.0 * reflectance * illuminant[c]) as u16;
        }
    }
    data
}

fn angular_error_deg(a: [f32; 3], b: [f32; 3]) -> f64 {
    let dot: f64 = (0..3).map(|i| a[i] as f64 * b[i] as f64).sum();
    let na: f64 = a.iter().map(|v| (*v as f64).powi(2)).sum::<f64>().sqrt();
    let nb: f64 = b.iter().map(|v| (*v as f64).powi(2)).sum::<f64>().sqrt();
    (dot / (na * nb)).clamp(-1.0, 1.0).acos().to_degrees()
}

/// Every AWB method recovers a warm illuminant from a scene of grey patches (all four
/// assumptions hold), and grey world also from a colourful scene that averages to grey.
#[test]
fn awb_methods_recover_the_illuminant() {
    let illuminant = [1.0f32, 0.8, 0.45]; // warm, tungsten-like in linear sRGB
    let grey_patches = [
        AwbMethod::GreyWorld,
        AwbMethod::ShadesOfGrey { p: 6.0 },
        AwbMethod::GreyEdge { p: 1.0 },
        AwbMethod::GreyEdge { p: 6.0 },
        AwbMethod::WhitePatch { percentile: 99.0 },
    ];
    for pattern in CfaPattern::ALL {
        for (colourful, methods) in [(false, &grey_patches[..]), (true, &grey_patches[..1])] {
            let data = tinted_scene(illuminant, pattern, 7, colourful);
            let raw = RawFrame::new(&data, 64, 48, 64, 12, pattern, [64; 4], 4095).unwrap();
            // Quantisation to 12 bits and white patch's histogram bins leave a little error.
            let bound = 0.5;
            for &method in methods {
                let est = wb::estimate(&raw, method, &LINEAR_SRGB_TO_XYZ).unwrap();
                let err = angular_error_deg(est.neutral, illuminant);
                assert!(
                    err < bound,
                    "{pattern:?} {method:?}: {err} degrees, {est:?}"
                );
                assert_eq!(est.gains[1], 1.0);
                // The temperature of the estimate is that of the light (exactly for grey world).
                let truth = wb::cct_of_neutral(illuminant, &LINEAR_SRGB_TO_XYZ).unwrap();
                let k_bound = if method == AwbMethod::GreyWorld {
                    20.0
                } else {
                    600.0
                };
                assert!(
                    (est.cct_k - truth).abs() < k_bound,
                    "{method:?}: {} K vs {truth} K",
                    est.cct_k
                );
                assert!(truth < 5000.0);
            }
        }
    }
    // No content: an error, not a guess.
    let black = vec![64u16; 16 * 16];
    let raw = RawFrame::new(&black, 16, 16, 16, 12, CfaPattern::Rggb, [64; 4], 4095).unwrap();
    assert!(wb::estimate(&raw, AwbMethod::GreyWorld, &LINEAR_SRGB_TO_XYZ).is_err());
    let one = [100u16];
    let raw = RawFrame::new(&one, 1, 1, 1, 12, CfaPattern::Rggb, [0; 4], 4095).unwrap();
    assert!(wb::estimate(&raw, AwbMethod::GreyWorld, &LINEAR_SRGB_TO_XYZ).is_err());
    assert!(AwbMethod::from_name("grey-edge").is_ok());
    assert!(AwbMethod::from_name("magic").is_err());
}

/// The estimated CCT of a daylight neutral is its temperature (McCamy on the daylight locus is
/// good to tens of kelvin here).
#[test]
fn cct_of_a_daylight_neutral() {
    for cct in [5000.0, 6504.0, 7500.0] {
        let xyz = colour::xy_to_xyz(colour::cct_to_xy_daylight(cct).unwrap()).unwrap();
        let rgb = colour::mat3_mul_vec(&colour::XYZ_TO_LINEAR_SRGB, xyz);
        let neutral = [rgb[0] / rgb[1], 1.0, rgb[2] / rgb[1]].map(|v| v as f32);
        let est = wb::cct_of_neutral(neutral, &LINEAR_SRGB_TO_XYZ).unwrap();
        assert!((est - cct).abs() < 60.0, "{cct}: {est}");
    }
}

/// Calibration: a camera that sees linear sRGB gets the identity CCM at D65; a camera with a
/// different response gets a CCM that maps its colours back, greys stay grey under each
/// preset, and the DNG interpolation weight is linear in inverse CCT.
#[test]
fn calibration_ccm_and_presets() {
    // A camera whose RGB is a mix of sRGB primaries.
    let mix = [[0.8, 0.15, 0.05], [0.1, 0.8, 0.1], [0.02, 0.18, 0.8]];
    let camera_to_xyz = colour::mat3_mul(&LINEAR_SRGB_TO_XYZ, &colour::mat3_inverse(&mix).unwrap());
    let cal = Calibration::new([2856.0, 6504.0], [camera_to_xyz, camera_to_xyz]).unwrap();
    assert!((cal.weight(2856.0) - 1.0).abs() < 1e-12);
    assert!(cal.weight(6504.0).abs() < 1e-12);
    let mid = 2.0 / (1.0 / 2856.0 + 1.0 / 6504.0);
    assert!((cal.weight(mid) - 0.5).abs() < 1e-12);
    assert_eq!(cal.weight(1000.0), 1.0);
    let ccm = cal.ccm(colour::D65_XY, [1.0; 3]).unwrap();
    // Under D65 a camera colour mix * rgb comes back to rgb.
    let rgb = [0.2f64, 0.5, 0.7];
    let cam = colour::mat3_mul_vec(&mix, rgb);
    for i in 0..3 {
        let back: f64 = (0..3).map(|j| ccm[i][j] as f64 * cam[j]).sum();
        assert!((back - rgb[i]).abs() < 2e-3, "{i}: {back} vs {}", rgb[i]);
    }
    for preset in WbPreset::ALL {
        let gains = cal.preset_gains(preset).unwrap();
        // The preset's illuminant, seen by the camera and balanced, is neutral.
        let xyz = colour::xy_to_xyz(preset.xy().unwrap()).unwrap();
        let cam = colour::mat3_mul_vec(&colour::mat3_inverse(&camera_to_xyz).unwrap(), xyz);
        let balanced: Vec<f64> = (0..3).map(|i| cam[i] * gains[i] as f64).collect();
        assert!((balanced[0] / balanced[1] - 1.0).abs() < 1e-5, "{preset:?}");
        assert!((balanced[2] / balanced[1] - 1.0).abs() < 1e-5, "{preset:?}");
        // And the CCM for that white keeps it grey.
        let ccm = cal.ccm(preset.xy().unwrap(), gains).unwrap();
        let white: Vec<f32> = (0..3).map(|i| ccm[i].iter().sum()).collect();
        assert!(
            (white[0] - white[1]).abs() < 2e-3 && (white[2] - white[1]).abs() < 2e-3,
            "{preset:?}: {white:?}"
        );
    }
    // Tungsten needs more blue gain than daylight.
    let t = cal.preset_gains(WbPreset::Tungsten).unwrap();
    let d = cal.preset_gains(WbPreset::Daylight).unwrap();
    assert!(t[2] > d[2] && t[0] < d[0]);
    assert!(Calibration::new([5000.0, 5000.0], [camera_to_xyz; 2]).is_err());
    assert!(Calibration::single(6504.0, [[0.0; 3]; 3]).is_err());
}

/// The sRGB table is within 0.5 output LSB of the exact curve before rounding, at 8 and 16
/// bits, for every one of the 65536 inputs; rounded, it is within 1 LSB.
#[test]
fn encode_lut_within_half_lsb_of_exact_curve() {
    for bits in [8u8, 16] {
        let lut = EncodeLut::new(bits).unwrap();
        let max = lut.max() as f64;
        let mut worst: f64 = 0.0;
        for v in 0..=65535u16 {
            let x = v as f64 / 65535.0;
            let exact = if x <= 0.0031308 {
                12.92 * x
            } else {
                1.055 * x.powf(1.0 / 2.4) - 0.055
            } * max;
            let got = lut.lookup_q8(v) as f64 / 256.0;
            worst = worst.max((got - exact).abs());
            assert!((lut.lookup(v) as f64 - exact).abs() <= 1.0);
        }
        assert!(worst <= 0.5, "{bits}-bit: worst {worst} LSB");
    }
    assert!(EncodeLut::new(12).is_err());
    // The float curve itself: a spot check against the formula.
    assert!((srgb::encode(0.5) - 0.735_356_6).abs() < 1e-6);
}

/// The 8-bit lookup (a code per run of 16 inputs and where it steps) gives the interpolated
/// table's rounded value at every input.
#[test]
fn encode_lut_8bit_runs_equal_the_interpolated_codes() {
    let lut = EncodeLut::new(8).unwrap();
    for v in 0..=65535u16 {
        let interpolated = ((lut.lookup_q8(v) + 128) >> 8).min(255);
        assert_eq!(lut.lookup(v), interpolated, "input {v}");
    }
}

/// The float path's 8-bit encoder (thresholds) gives the exact curve's code: at every float
/// within 2^16 ulps of every threshold (where a non-monotone power could disagree), at a
/// spread of floats across [0, 1] and at the edges; and no bucket of its table is followed by
/// more than the one threshold its lookup steps over without a loop.
#[test]
fn encode_thresholds_give_the_exact_codes() {
    let codes = EncodeThresholds8::new();
    let t = codes.thresholds();
    assert_eq!(t.len(), 255);
    assert!(t.windows(2).all(|p| p[0] < p[1]));
    for &threshold in &t {
        let bits = threshold.to_bits();
        for b in bits.saturating_sub(1 << 16)..=(bits + (1 << 16)).min(1.0f32.to_bits()) {
            let x = f32::from_bits(b);
            assert_eq!(codes.code(x), exact_code8(x), "x = {x:e}");
        }
    }
    for b in (0..=1.0f32.to_bits()).step_by(4099) {
        let x = f32::from_bits(b);
        assert_eq!(codes.code(x), exact_code8(x), "x = {x:e}");
        assert_eq!(codes.code_clamped(srgb::clamp_unit(x)), codes.code(x));
    }
    for x in [
        0.0f32,
        -0.0,
        -1.0,
        1.0,
        2.0,
        f32::NAN,
        f32::INFINITY,
        f32::NEG_INFINITY,
        -f32::NAN,
        f32::MIN_POSITIVE,
        -f32::MIN_POSITIVE,
        0.999_999_94,
        1.000_000_1,
    ] {
        assert_eq!(codes.code(x), exact_code8(x), "x = {x}");
        // The vector loops' clamp, then the lookup without one: the same code.
        let clamped = srgb::clamp_unit(x);
        assert!((0.0..=1.0).contains(&clamped) && clamped.to_bits() <= 1.0f32.to_bits());
        assert_eq!(codes.code_clamped(clamped), exact_code8(x), "x = {x}");
    }
    // Buckets of 2^16 floats: at most one threshold after each bucket's first float.
    for bucket in 0..=(1.0f32.to_bits() >> 16) {
        let (first, last) = (bucket << 16, (bucket << 16) + (1 << 16) - 1);
        let inside = t
            .iter()
            .filter(|v| v.to_bits() > first && v.to_bits() <= last)
            .count();
        assert!(inside <= 1, "bucket {bucket}: {inside} thresholds");
    }
}

/// The tone table follows the exact tone function to well under an 8-bit step; the identity
/// look is the identity.
#[test]
fn tone_table_follows_the_tone_function() {
    let curve = ToneCurve::new(&[[0.0, 0.0], [0.25, 0.35], [0.7, 0.8], [1.0, 1.0]]).unwrap();
    for tone in [
        Look::Vivid.tone(),
        Look::HighContrast.tone(),
        Tone {
            saturation: 1.0,
            contrast: 0.6,
            curve,
        },
    ] {
        let lut = ToneLut::new(&tone);
        for v in (0..=65535u32).step_by(7) {
            let exact = tone.channel(v as f32 / 65535.0) * 65535.0;
            let got = lut.lookup(v as u16) as f32;
            // 8 / 65535 linear: at most 0.03 of an 8-bit sRGB step anywhere on the curve.
            assert!(
                (got - exact).abs() < 8.0,
                "{tone:?} at {v}: {got} vs {exact}"
            );
        }
    }
    let neutral = Look::Neutral.tone();
    assert!(neutral.saturation_is_identity() && neutral.curve_is_identity());
    assert_eq!(neutral.apply([0.1, 0.5, 0.9]), [0.1, 0.5, 0.9]);
    // Mono is grey.
    let mono = Look::Mono.tone().apply([0.8, 0.2, 0.1]);
    assert!((mono[0] - mono[1]).abs() < 1e-6 && (mono[1] - mono[2]).abs() < 1e-6);
    assert!(ToneCurve::new(&[[0.5, 0.1], [0.4, 0.2]]).is_err());
    assert!(Tone {
        saturation: 5.0,
        ..Tone::default()
    }
    .validate()
    .is_err());
}

fn strong_lens(w: usize, h: usize) -> LensDistortion {
    let model = BrownConrady::from_opencv([-0.3, 0.08, 0.002, -0.001, 0.0]).unwrap();
    let f = 0.85 * w as f64;
    LensDistortion::new(f, f, (w as f64 - 1.0) / 2.0, (h as f64 - 1.0) / 2.0, model)
        .unwrap()
        .fitted(w, h)
}

/// A smooth scene photographed through a barrel lens (each pixel shows the scene point the
/// lens bent onto it, found with optics-core's inverse model) comes back straight: within 1%
/// of the scene wherever the lens covered, while the uncorrected image is off by far more.
#[test]
fn distortion_correction_straightens_a_distorted_scene() {
    let (w, h) = (96, 64);
    let lens = strong_lens(w, h);
    let [fx, fy, cx, cy] = lens.camera();
    let scene = |x: f64, y: f64| 0.5 + 0.4 * (x / 7.0).sin() * (y / 5.0).cos();
    let mut photo = vec![0.0f32; w * h * 3];
    for y in 0..h {
        for x in 0..w {
            let d = [(x as f64 - cx) / fx, (y as f64 - cy) / fy];
            let ideal = lens.model().undistort(d).unwrap();
            let v = scene(fx * ideal[0] + cx, fy * ideal[1] + cy) as f32;
            photo[3 * (y * w + x)..3 * (y * w + x) + 3].fill(v);
        }
    }
    let mut out = vec![0.0f32; w * h * 3];
    lens.correct(
        &RgbView::new(&photo, w, h, 3 * w).unwrap(),
        &mut RgbViewMut::new(&mut out, w, h, 3 * w).unwrap(),
    )
    .unwrap();
    let (mut worst, mut worst_uncorrected, mut covered) = (0.0f64, 0.0f64, 0);
    for y in 0..h {
        for x in 0..w {
            // Barrel correction samples inside the frame everywhere: every pixel is covered.
            let [qx, qy] = lens.source_position(x, y).unwrap();
            assert!(qx >= 0 && qy >= 0 && qx <= 32 * (w as i32 - 1) && qy <= 32 * (h as i32 - 1));
            covered += 1;
            let truth = scene(x as f64, y as f64);
            worst = worst.max((out[3 * (y * w + x)] as f64 - truth).abs());
            worst_uncorrected =
                worst_uncorrected.max((photo[3 * (y * w + x)] as f64 - truth).abs());
        }
    }
    assert_eq!(covered, w * h);
    assert!(worst < 0.01, "corrected image off the scene by {worst}");
    assert!(
        worst_uncorrected > 0.2,
        "the lens bent too little to test: {worst_uncorrected}"
    );
}

/// Lateral colour corrected in the lens's resampling: alone, it is the stage's own correction
/// bit for bit; composed with the barrel lens, a scene photographed with red imaged 3 % larger
/// and blue 3 % smaller than green (in the lens's distorted image) comes back straight and
/// aligned in every colour, where distortion correction alone leaves red and blue off.
#[test]
fn lateral_colour_is_corrected_in_the_same_resampling() {
    let (w, h) = (96, 64);
    let centre = [(w as f64 - 1.0) / 2.0, (h as f64 - 1.0) / 2.0];
    let (red, blue) = (1.03, 0.97);
    let lca = LateralColour::new(w, h, centre, None, &[red; NODES], &[blue; NODES]).unwrap();

    // Alone: the stage's whole-frame correction, bit for bit, in integers and in floats.
    let samples: Vec<u16> = (0..w * h * 3).map(|i| ((i * 7919) % 4096) as u16).collect();
    let only = LensDistortion::lateral_colour_only(lca);
    assert!(!only.is_identity() && only.model().is_identity());
    fn both<T: Sample>(
        lca: &LateralColour,
        only: &LensDistortion,
        samples: &[T],
        (w, h): (usize, usize),
    ) -> (Vec<T>, Vec<T>) {
        let (mut by_stage, mut by_lens) =
            (vec![T::default(); w * h * 3], vec![T::default(); w * h * 3]);
        let src = RgbView::new(samples, w, h, 3 * w).unwrap();
        lca.correct(
            &src,
            &mut RgbViewMut::new(&mut by_stage, w, h, 3 * w).unwrap(),
        )
        .unwrap();
        only.correct(
            &src,
            &mut RgbViewMut::new(&mut by_lens, w, h, 3 * w).unwrap(),
        )
        .unwrap();
        (by_stage, by_lens)
    }
    let (by_stage, by_lens) = both(&lca, &only, &samples, (w, h));
    assert_eq!(by_lens, by_stage);
    assert_ne!(by_lens, samples, "the scales should move red and blue");
    let floats: Vec<f32> = samples.iter().map(|&v| f32::from(v) / 4095.0).collect();
    let (by_stage, by_lens) = both(&lca, &only, &floats, (w, h));
    assert_eq!(by_lens, by_stage);

    // Composed with distortion.
    let lens = strong_lens(w, h);
    let [fx, fy, cx, cy] = lens.camera();
    let scene = |x: f64, y: f64| 0.5 + 0.4 * (x / 7.0).sin() * (y / 5.0).cos();
    // Green's photo at distorted position p; red and blue show green's image scaled.
    let green_at = |px: f64, py: f64| {
        let ideal = lens
            .model()
            .undistort([(px - cx) / fx, (py - cy) / fy])
            .unwrap();
        scene(fx * ideal[0] + cx, fy * ideal[1] + cy)
    };
    let mut photo = vec![0.0f32; w * h * 3];
    for y in 0..h {
        for x in 0..w {
            let (dx, dy) = (x as f64 - centre[0], y as f64 - centre[1]);
            let i = 3 * (y * w + x);
            photo[i] = green_at(centre[0] + dx / red, centre[1] + dy / red) as f32;
            photo[i + 1] = green_at(x as f64, y as f64) as f32;
            photo[i + 2] = green_at(centre[0] + dx / blue, centre[1] + dy / blue) as f32;
        }
    }
    let worst = |corrector: &LensDistortion| {
        let mut out = vec![0.0f32; w * h * 3];
        corrector
            .correct(
                &RgbView::new(&photo, w, h, 3 * w).unwrap(),
                &mut RgbViewMut::new(&mut out, w, h, 3 * w).unwrap(),
            )
            .unwrap();
        let mut worst = [0.0f64; 3];
        // Away from the edge, where blue, imaged smaller, has no picture to read from.
        for y in 4..h - 4 {
            for x in 4..w - 4 {
                let truth = scene(x as f64, y as f64);
                for c in 0..3 {
                    worst[c] = worst[c].max((f64::from(out[3 * (y * w + x) + c]) - truth).abs());
                }
            }
        }
        worst
    };
    let both = worst(&lens.with_lateral_colour(lca));
    let distortion_alone = worst(&lens);
    assert!(both.iter().all(|&e| e < 0.01), "corrected: {both:?}");
    assert!(
        distortion_alone[0] > 0.05 && distortion_alone[2] > 0.05 && distortion_alone[1] < 0.01,
        "distortion alone: {distortion_alone:?}"
    );
}

/// The pipeline's scratch with distortion on: the size reported is enough and one element less
/// is refused naming that size; more scratch changes nothing; the distortion-free size is refused.
#[test]
fn distortion_scratch_is_sized_and_checked() {
    let (w, h) = (48, 40);
    let data: Vec<u16> = (0..w * h).map(|i| ((i * 7919) % 4096) as u16).collect();
    let raw = RawFrame::new(&data, w, h, w, 12, CfaPattern::Rggb, [64; 4], 4095).unwrap();
    let config = IspConfig {
        distortion: Some(strong_lens(w, h)),
        ..IspConfig::default()
    };
    let pipeline = FixedPipeline::new(&config, 8).unwrap();
    let needed = config.scratch_len(w, h).unwrap();
    assert_eq!(pipeline.scratch_len(w, h), Some(needed));
    let window = strong_lens(w, h).window_rows(w, h);
    // The ring of demosaiced rows the lens's window needs is part of it.
    assert!(needed > 3 * window * w);
    assert!(
        window > 3,
        "the lens should need a real window, got {window}"
    );
    let run = |len: usize| {
        let mut scratch = vec![0u16; len];
        let mut out = vec![0u8; w * h * 3];
        pipeline
            .run(
                &raw,
                0..h,
                &mut scratch,
                &mut RgbViewMut::new(&mut out, w, h, 3 * w).unwrap(),
            )
            .map(|_| out)
    };
    let exact = run(needed).unwrap();
    assert_eq!(run(needed + 7 * 3 * w).unwrap(), exact);
    for short in [needed - 1, scratch_len(w).unwrap()] {
        assert_eq!(
            run(short),
            Err(IspError::BufferTooSmall {
                needed,
                provided: short
            })
        );
    }
}

/// Bad camera matrices are refused; absurd coefficients give black, never a panic.
#[test]
fn distortion_parameters_are_checked() {
    let model = BrownConrady::from_opencv([0.1, 0.0, 0.0, 0.0, 0.0]).unwrap();
    for (fx, fy, cx, cy) in [
        (0.0, 10.0, 1.0, 1.0),
        (10.0, -1.0, 1.0, 1.0),
        (f64::NAN, 10.0, 1.0, 1.0),
        (10.0, 10.0, f64::INFINITY, 1.0),
    ] {
        assert!(LensDistortion::new(fx, fy, cx, cy, model).is_err());
    }
    let wild = BrownConrady::from_opencv([1e300, -1e300, 1e10, 1e10, 1e300]).unwrap();
    let lens = LensDistortion::new(1e-300, 1e-300, 0.0, 0.0, wild).unwrap();
    let src = [100u16; 5 * 4 * 3];
    let mut dst = [7u16; 5 * 4 * 3];
    lens.correct(
        &RgbView::new(&src, 5, 4, 15).unwrap(),
        &mut RgbViewMut::new(&mut dst, 5, 4, 15).unwrap(),
    )
    .unwrap();
    assert!(dst.iter().all(|v| *v == 0 || *v == 100), "{dst:?}");
    if dst.iter().all(|v| *v == 0) {
        // Nothing of the frame is seen, so no input row is needed.
        assert_eq!(lens.window_rows(5, 4), 0);
    }
}

/// Sharpening steepens an edge and leaves flat ground alone: on a vertical step from dark to
/// light grey, the output without sharpening is flat on each side; with it the dark side dips
/// and the light side rises next to the edge, and pixels beyond the blur's reach are
/// unchanged. Both paths.
#[test]
fn sharpening_steepens_an_edge_and_leaves_flat_ground() {
    use isp_core::pipeline::FloatPipeline;
    let (w, h) = (16, 8);
    // A grey mosaic: 600 left of column 8, 2400 from it on (12-bit, black 0).
    let data: Vec<u16> = (0..w * h)
        .map(|i| if i % w < 8 { 600 } else { 2400 })
        .collect();
    let raw = RawFrame::new(&data, w, h, w, 12, CfaPattern::Rggb, [0; 4], 4095).unwrap();
    let develop = |sharpen: f32, fixed: bool| {
        let config = IspConfig {
            demosaic: isp_core::demosaic::Method::Bilinear,
            sharpen,
            ..IspConfig::default()
        };
        let mut rgb = vec![0u8; w * h * 3];
        let mut out = RgbViewMut::new(&mut rgb, w, h, 3 * w).unwrap();
        if fixed {
            let p = FixedPipeline::new(&config, 8).unwrap();
            let mut scratch = vec![0u16; p.scratch_len(w, h).unwrap()];
            p.run(&raw, 0..h, &mut scratch, &mut out).unwrap();
        } else {
            let p = FloatPipeline::new(&config).unwrap();
            let mut scratch = vec![0f32; p.scratch_len(w, h).unwrap()];
            p.run(&raw, 0..h, &mut scratch, &mut out).unwrap();
        }
        // Green of row 3, every column.
        (0..w)
            .map(|x| i32::from(rgb[3 * (3 * w + x) + 1]))
            .collect::<Vec<_>>()
    };
    for fixed in [false, true] {
        let plain = develop(0.0, fixed);
        let sharp = develop(1.0, fixed);
        // Bilinear blends the two columns at the step; beyond them the sides are flat.
        assert!(plain[..7].iter().all(|v| *v == plain[0]), "{plain:?}");
        assert!(plain[9..].iter().all(|v| *v == plain[15]), "{plain:?}");
        for x in [0, 1, 2, 3, 4, 11, 12, 13, 14, 15] {
            assert_eq!(
                sharp[x], plain[x],
                "column {x}: {sharp:?} against {plain:?}"
            );
        }
        // The undershoot and overshoot beside the edge.
        assert!(
            sharp[6] < plain[6] && sharp[8] > plain[8],
            "{sharp:?} against {plain:?}"
        );
    }
    assert!(IspConfig {
        sharpen: 4.5,
        ..IspConfig::default()
    }
    .validate()
    .is_err());
}

/// A noisy 12-bit RGGB frame: a ramp with bright and dark bars, Poisson-Gaussian noise of
/// scale `s` and offset `o` (by a deterministic generator; the Poisson part as a Gaussian of
/// its variance).
fn noisy_frame(w: usize, h: usize, s: f64, o: f64) -> Vec<u16> {
    let mut state = 99u64;
    let mut uniform = move || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    };
    (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let level = if (y / 8) % 3 == 0 {
                0.3
            } else {
                x as f64 / w as f64
            };
            let gauss = (-2.0 * uniform().ln()).sqrt() * (std::f64::consts::TAU * uniform()).cos();
            let v = level + gauss * (s * level + o).sqrt();
            (256.0 + v * 3839.0).round().clamp(0.0, 4095.0) as u16
        })
        .collect()
}

/// Noise reduction's fixed path against its float path through the whole pipeline (gains,
/// colour matrix, sRGB toe all amplify what differs) at the three noise levels of the
/// quality bench: within 1 LSB on 99.9 % of samples, 2 at most; and it reduces the noise.
#[test]
fn denoise_fixed_path_tracks_float() {
    use isp_core::noise::NoiseProfile;
    use isp_core::pipeline::FloatPipeline;
    let (w, h) = (768, 48);
    for s in [0.0008, 0.0032, 0.0128] {
        let o = (2.18 * f64::ln(s) + 1.2).exp();
        let data = noisy_frame(w, h, s, o);
        let raw = RawFrame::new(&data, w, h, w, 12, CfaPattern::Rggb, [256; 4], 4095).unwrap();
        let config = IspConfig {
            wb_gains: [1.8, 1.0, 1.5],
            gain: 1.5,
            ccm: [[1.6, -0.4, -0.2], [-0.3, 1.5, -0.2], [0.0, -0.5, 1.5]],
            demosaic: isp_core::demosaic::Method::Mhc,
            highlight_knee: 0.9,
            denoise: 1.0,
            noise: Some(NoiseProfile::uniform(s as f32, o as f32).unwrap()),
            ..IspConfig::default()
        };
        let len = config.scratch_len(w, h).unwrap();
        let run = |fixed: bool, config: &IspConfig| {
            let mut out = vec![0u8; w * h * 3];
            let mut view = RgbViewMut::new(&mut out, w, h, 3 * w).unwrap();
            if fixed {
                let mut scratch = vec![0u16; len];
                let p = FixedPipeline::new(config, 8).unwrap();
                p.run(&raw, 0..h, &mut scratch, &mut view).unwrap();
            } else {
                let mut scratch = vec![0.0f32; len];
                let p = FloatPipeline::new(config).unwrap();
                p.run(&raw, 0..h, &mut scratch, &mut view).unwrap();
            }
            out
        };
        let (float, fixed) = (run(false, &config), run(true, &config));
        let beyond = float
            .iter()
            .zip(&fixed)
            .filter(|(a, b)| a.abs_diff(**b) > 1)
            .count();
        let worst = float
            .iter()
            .zip(&fixed)
            .map(|(a, b)| a.abs_diff(*b))
            .max()
            .unwrap();
        assert!(
            beyond * 1000 <= float.len() && worst <= 2,
            "S {s}: {beyond} beyond 1 LSB, worst {worst}"
        );
        // A flat bar's row: noise reduction lowers its spread.
        let off = run(
            false,
            &IspConfig {
                denoise: 0.0,
                ..config
            },
        );
        let spread = |img: &[u8]| {
            let v: Vec<f64> = (8..w - 8)
                .map(|x| f64::from(img[3 * (26 * w + x) + 1]))
                .collect();
            let m = v.iter().sum::<f64>() / v.len() as f64;
            (v.iter().map(|a| (a - m).powi(2)).sum::<f64>() / v.len() as f64).sqrt()
        };
        assert!(
            spread(&float) < 0.7 * spread(&off),
            "S {s}: {} vs {}",
            spread(&float),
            spread(&off)
        );
    }
}

/// A radial shading grid: gains are 1 / fall-off at each node's pixel; nodes beyond the image
/// circle take the gain found on the way in; bad grids and frames are refused.
#[test]
fn radial_shading_gains_undo_a_fall_off() {
    use isp_core::lsc::radial_gains;
    let (w, h, gw, gh) = (65, 49, 9, 7);
    let mut gains = vec![0u16; gw * gh * 4];
    // Light falls linearly to half at 30 pixels and stops beyond 35.
    let fall_off = |_: usize, r: f64| (r <= 35.0).then(|| 1.0 - r / 60.0);
    radial_gains(&mut gains, gw, gh, w, h, [32.0, 24.0], fall_off).unwrap();
    let lsc = LensShading::new(gw, gh, &gains).unwrap();
    // The centre node, on pixel (32, 24): gain 1. The node on (40, 24), 8 px out: 60 / 52.
    assert_eq!(lsc.gain_f32(32, 24, w, h), 1.0);
    assert!((lsc.gain_f32(40, 24, w, h) - 60.0 / 52.0).abs() < 1e-3);
    // The corner node, 40 px out, is dark: it takes a gain from just inside 35 px.
    let corner = lsc.gain_f32(0, 0, w, h);
    assert!(
        corner > 60.0 / 26.0 && corner <= 60.0 / 25.0 + 1e-3,
        "{corner}"
    );
    for (gw, gh, len) in [(1, 7, 28), (9, 7, 10), (65, 7, 65 * 28)] {
        let mut g = vec![0u16; len];
        assert!(radial_gains(&mut g, gw, gh, w, h, [32.0, 24.0], fall_off).is_err());
    }
    assert!(radial_gains(&mut gains, gw, gh, 0, h, [32.0, 24.0], fall_off).is_err());
    assert!(radial_gains(&mut gains, gw, gh, w, h, [f64::NAN, 24.0], fall_off).is_err());
}

#[test]
fn lens_corrections_are_derived_for_the_sensor_behind_the_lens() {
    use isp_core::lens_correction::{
        DistortionFit, IlluminationTable, LensCorrections, SensorFraming, RENDER_COLOURS_NM,
    };
    use optics_core::prescription::glass::{Medium, LAMBDA_D_NM};
    use optics_core::prescription::{Prescription, Shape, Surface};
    // A biconvex singlet of a dispersive model glass with the stop 10 mm in front of it: it
    // distorts, its colours differ in size, and its rim vignettes the field's edge.
    let glass = Medium::Model { nd: 1.6, vd: 35.0 };
    let surfaces = [
        Surface::aperture_stop(4.0, 10.0),
        Surface::new(Shape::sphere_radius(60.0), 5.0, 4.0, glass),
        Surface::new(Shape::sphere_radius(-60.0), 5.0, 48.0, Medium::Air),
    ];
    let lens = Prescription::new(&surfaces).unwrap();
    let film = lens.paraxial(LAMBDA_D_NM).unwrap().bfl;
    // Bad sensors are errors, not panics.
    assert!(SensorFraming::new(1, 48, 0.1, film).is_err());
    assert!(SensorFraming::new(64, 48, 0.0, film).is_err());
    assert!(SensorFraming::new(64, 48, 0.1, f64::NAN).is_err());
    let framing = SensorFraming::new(64, 48, 0.2, film).unwrap();
    assert!(framing.with_colours_nm([650.0, -1.0, 450.0]).is_err());

    // The chief-ray fit goes with the paraxial focal length at green.
    let fix = LensCorrections::derive(&lens, &framing, 0.3, DistortionFit::ChiefRays).unwrap();
    let efl = lens.paraxial(RENDER_COLOURS_NM[1]).unwrap().efl;
    assert_eq!(fix.focal_length_mm, efl);
    assert!(fix.k[0] != 0.0, "{:?}", fix.k);
    // Red's and blue's images differ in size, each within a percent of green's.
    let lca = fix.distortion.lateral_colour().unwrap();
    let (red, blue) = (
        lca.node_scale(0, 16).unwrap(),
        lca.node_scale(1, 16).unwrap(),
    );
    assert!(red != blue && (red - 1.0).abs() < 0.01 && (blue - 1.0).abs() < 0.01);
    assert!(lca.node_scale(2, 0).is_none() && lca.node_scale(0, 17).is_none());

    // The illumination table is 1 on the axis and falls off; the grid lifts the corners.
    assert!(IlluminationTable::<1>::derive(&lens, &framing, 8, &mut surfaces.clone()).is_err());
    let table: IlluminationTable =
        IlluminationTable::derive(&lens, &framing, 64, &mut surfaces.clone()).unwrap();
    for c in 0..3 {
        assert_eq!(table.at(c, 0.0), Some(1.0));
        assert!(table.at(c, framing.corner_mm()).unwrap() < 0.99);
    }
    assert!(table.at(3, 0.0).is_none());
    let mut gains = [0u16; 9 * 7 * 4];
    table
        .fill_grid(&framing, CfaPattern::Rggb.block(), &mut gains, 9, 7)
        .unwrap();
    let lsc = LensShading::new(9, 7, &gains).unwrap();
    let (centre, corner) = (lsc.gain_f32(32, 24, 64, 48), lsc.gain_f32(0, 0, 64, 48));
    assert!(
        (centre - 1.0).abs() < 0.01 && corner > 1.01,
        "{centre} {corner}"
    );
}

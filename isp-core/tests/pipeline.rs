//! The pipeline against a slow, obviously-correct reference of the documented float semantics
//! (written here in f64, whole frame, one stage after another), the fixed path against the
//! float path, and streaming against whole-frame runs.

use isp_core::demosaic::Method;
use isp_core::dpc::{Defect, DpcConfig};
use isp_core::frame::{RawFrame, RgbViewMut};
use isp_core::lsc::LensShading;
use isp_core::pipeline::{scratch_len, FixedPipeline, FloatPipeline, IspConfig};
use isp_core::tone::{Tone, ToneCurve};
use isp_core::CfaPattern;
use proptest::prelude::*;

/// A raw frame and everything the reference needs to know about it.
#[derive(Debug, Clone)]
struct Frame {
    data: Vec<u16>,
    w: usize,
    h: usize,
    stride: usize,
    bits: u8,
    pattern: CfaPattern,
    black: [u16; 4],
    white: u16,
}

impl Frame {
    fn raw(&self) -> RawFrame<'_> {
        RawFrame::new(
            &self.data,
            self.w,
            self.h,
            self.stride,
            self.bits,
            self.pattern,
            self.black,
            self.white,
        )
        .unwrap()
    }

    fn at(&self, x: usize, y: usize) -> u16 {
        self.data[y * self.stride + x]
    }

    fn colour(&self, x: usize, y: usize) -> usize {
        self.pattern.colour_at(x, y).index()
    }
}

/// Mirror without repeating the edge, folding until inside.
fn mirror(mut i: i64, n: usize) -> usize {
    let n = n as i64;
    if n == 1 {
        return 0;
    }
    loop {
        if i < 0 {
            i = -i;
        } else if i >= n {
            i = 2 * (n - 1) - i;
        } else {
            return i as usize;
        }
    }
}

/// Settings in a form the reference reads directly.
#[derive(Debug, Clone)]
struct Settings {
    defects: Vec<Defect>,
    threshold: Option<u16>,
    grid: Option<(usize, usize, Vec<u16>)>,
    gain: f32,
    wb: [f32; 3],
    denoise: f32,
    ccm: [[f32; 3]; 3],
    tone: Tone,
    method: Method,
}

impl Settings {
    fn config(&self) -> IspConfig<'_> {
        IspConfig {
            dpc: DpcConfig {
                static_defects: &self.defects,
                dynamic_threshold: self.threshold,
            },
            lsc: self
                .grid
                .as_ref()
                .map(|(gw, gh, g)| LensShading::new(*gw, *gh, g).unwrap()),
            gain: self.gain,
            wb_gains: self.wb,
            demosaic: self.method,
            denoise: self.denoise,
            ccm: self.ccm,
            tone: self.tone,
        }
    }

    fn plain() -> Self {
        Self {
            defects: vec![],
            threshold: None,
            grid: None,
            gain: 1.0,
            wb: [1.0; 3],
            denoise: 0.0,
            ccm: isp_core::pipeline::IDENTITY,
            tone: Tone::default(),
            method: Method::Bilinear,
        }
    }
}

fn dpc_reference(f: &Frame, s: &Settings) -> Vec<u16> {
    let listed = |x: usize, y: usize| {
        s.defects
            .iter()
            .any(|d| d.x as usize == x && d.y as usize == y)
    };
    let mut out = vec![0u16; f.w * f.h];
    for y in 0..f.h {
        for x in 0..f.w {
            let mut n: Vec<u16> = Vec::new();
            for dy in [-2i64, 0, 2] {
                for dx in [-2i64, 0, 2] {
                    if dx == 0 && dy == 0 {
                        continue;
                    }
                    // Off the frame: the mirror image about the pixel, if that is on it.
                    let about = |i: usize, d: i64, n: usize| {
                        [i as i64 + d, i as i64 - d]
                            .into_iter()
                            .find(|v| *v >= 0 && *v < n as i64)
                            .map(|v| v as usize)
                    };
                    let (Some(nx), Some(ny)) = (about(x, dx, f.w), about(y, dy, f.h)) else {
                        continue;
                    };
                    if (nx, ny) != (x, y) && !listed(nx, ny) {
                        n.push(f.at(nx, ny));
                    }
                }
            }
            n.sort();
            let median = || {
                let k = n.len();
                if k % 2 == 1 {
                    n[k / 2]
                } else {
                    (n[k / 2 - 1] as u32 + n[k / 2] as u32).div_ceil(2) as u16
                }
            };
            let v = f.at(x, y);
            out[y * f.w + x] = if listed(x, y) {
                if n.is_empty() {
                    v
                } else {
                    median()
                }
            } else if let (Some(t), true) = (s.threshold, n.len() >= 3) {
                let k = n.len();
                let outlier =
                    v as i64 > n[k - 2] as i64 + t as i64 || (v as i64) + (t as i64) < n[1] as i64;
                if outlier {
                    median()
                } else {
                    v
                }
            } else {
                v
            };
        }
    }
    out
}

fn lsc_reference(s: &Settings, x: usize, y: usize, w: usize, h: usize) -> f64 {
    let Some((gw, gh, g)) = &s.grid else {
        return 1.0;
    };
    let coord = |i: usize, n: usize, nodes: usize| -> (usize, f64) {
        if n == 1 {
            return (0, 0.0);
        }
        let t = i as f64 * (nodes - 1) as f64 / (n - 1) as f64;
        let k = (t.floor() as usize).min(nodes - 2);
        (k, t - k as f64)
    };
    let (gx, fx) = coord(x, w, *gw);
    let (gy, fy) = coord(y, h, *gh);
    let p = (y % 2) * 2 + x % 2;
    let node = |i: usize, j: usize| g[(j * gw + i) * 4 + p] as f64 / 4096.0;
    (node(gx, gy) * (1.0 - fx) + node(gx + 1, gy) * fx) * (1.0 - fy)
        + (node(gx, gy + 1) * (1.0 - fx) + node(gx + 1, gy + 1) * fx) * fy
}

/// Bilinear from the definition: each missing colour is the mean of that colour's pixels in the
/// (mirrored) 3x3 window, or along the line for 1-pixel frames.
fn bilinear_reference(m: &[f64], f: &Frame) -> Vec<[f64; 3]> {
    let (w, h) = (f.w, f.h);
    let mut out = vec![[0.0; 3]; w * h];
    for y in 0..h {
        for x in 0..w {
            let own = f.colour(x, y);
            let mut sum = [0.0; 3];
            let mut n = [0.0; 3];
            if w == 1 || h == 1 {
                for (dx, dy) in [(-1i64, 0i64), (1, 0), (0, -1), (0, 1)] {
                    let (nx, ny) = (x as i64 + dx, y as i64 + dy);
                    if nx >= 0 && ny >= 0 && (nx as usize) < w && (ny as usize) < h {
                        let c = f.colour(nx as usize, ny as usize);
                        sum[c] += m[ny as usize * w + nx as usize];
                        n[c] += 1.0;
                    }
                }
            } else {
                for dy in -1i64..=1 {
                    for dx in -1i64..=1 {
                        let (nx, ny) = (mirror(x as i64 + dx, w), mirror(y as i64 + dy, h));
                        let c = f
                            .pattern
                            .colour_at(x.wrapping_add(dx as usize), y.wrapping_add(dy as usize))
                            .index();
                        // The mirrored pixel has the colour the CFA puts at the unmirrored spot.
                        assert_eq!(c, f.colour(nx, ny));
                        sum[c] += m[ny * w + nx];
                        n[c] += 1.0;
                    }
                }
            }
            for c in 0..3 {
                out[y * w + x][c] = if c == own || n[c] == 0.0 {
                    m[y * w + x]
                } else {
                    sum[c] / n[c]
                };
            }
        }
    }
    out
}

fn denoise_reference(rgb: &[[f64; 3]], w: usize, h: usize, t: f64) -> Vec<[f64; 3]> {
    if t == 0.0 {
        return rgb.to_vec();
    }
    let mut out = vec![[0.0; 3]; w * h];
    for y in 0..h {
        for x in 0..w {
            let p = rgb[y * w + x];
            let (mut sum, mut wsum) = ([0.0; 3], 0.0);
            for dy in -1i64..=1 {
                for dx in -1i64..=1 {
                    let q = rgb[mirror(y as i64 + dy, h) * w + mirror(x as i64 + dx, w)];
                    let d: f64 = (0..3).map(|c| (q[c] - p[c]).abs()).sum();
                    let spatial =
                        [1.0, 2.0, 1.0][(dx + 1) as usize] * [1.0, 2.0, 1.0][(dy + 1) as usize];
                    let wgt = spatial * (1.0 - d / t).max(0.0);
                    wsum += wgt;
                    for c in 0..3 {
                        sum[c] += wgt * q[c];
                    }
                }
            }
            out[y * w + x] = sum.map(|v| v / wsum);
        }
    }
    out
}

fn tone_reference(tone: &Tone, rgb: [f64; 3]) -> [f64; 3] {
    let s = tone.saturation as f64;
    let yl = 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2];
    let sat = rgb.map(|c| (yl + s * (c - yl)).clamp(0.0, 1.0));
    let k = tone.contrast as f64;
    let p = 0.18;
    sat.map(|x| {
        let c = if x <= p {
            p * (x / p).powf(k)
        } else {
            1.0 - (1.0 - p) * ((1.0 - x) / (1.0 - p)).powf(k)
        };
        let pts = tone.curve.points();
        let v = if pts.is_empty() {
            c
        } else if c <= pts[0][0] as f64 {
            pts[0][1] as f64
        } else if c >= pts[pts.len() - 1][0] as f64 {
            pts[pts.len() - 1][1] as f64
        } else {
            let i = pts.iter().position(|q| c <= q[0] as f64).unwrap();
            let (a, b) = (pts[i - 1], pts[i]);
            let t = (c - a[0] as f64) / (b[0] as f64 - a[0] as f64);
            a[1] as f64 + t * (b[1] as f64 - a[1] as f64)
        };
        v.clamp(0.0, 1.0)
    })
}

fn srgb_reference(x: f64) -> f64 {
    if x <= 0.0031308 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    }
}

/// The whole documented float semantics: encoded values in [0, 1] before rounding.
fn reference(f: &Frame, s: &Settings) -> Vec<[f64; 3]> {
    let raw = dpc_reference(f, s);
    let white = f.white as f64;
    let mut m = vec![0.0; f.w * f.h];
    for y in 0..f.h {
        for x in 0..f.w {
            let black = f.black[(y % 2) * 2 + x % 2] as f64;
            let d = (raw[y * f.w + x] as f64 - black).max(0.0);
            let mut v = (lsc_reference(s, x, y, f.w, f.h) * d / (white - black)).clamp(0.0, 1.0);
            v = (s.gain as f64 * v).min(1.0);
            v = (s.wb[f.colour(x, y)] as f64 * v).min(1.0);
            m[y * f.w + x] = v;
        }
    }
    let rgb = bilinear_reference(&m, f);
    let rgb = denoise_reference(&rgb, f.w, f.h, s.denoise as f64);
    rgb.iter()
        .map(|p| {
            let lin: [f64; 3] = std::array::from_fn(|i| {
                (0..3)
                    .map(|j| s.ccm[i][j] as f64 * p[j])
                    .sum::<f64>()
                    .clamp(0.0, 1.0)
            });
            tone_reference(&s.tone, lin).map(srgb_reference)
        })
        .collect()
}

fn run_float(f: &Frame, s: &Settings, bands: &[usize]) -> Vec<u8> {
    let raw = f.raw();
    let config = s.config();
    let pipeline = FloatPipeline::new(&config).unwrap();
    let mut scratch = vec![f32::NAN; scratch_len(f.w).unwrap()];
    let mut out = vec![0u8; f.w * f.h * 3];
    let mut y = 0;
    for &band in bands {
        if y == f.h {
            break;
        }
        let rows = y..(y + band).min(f.h);
        let chunk = &mut out[3 * f.w * rows.start..3 * f.w * rows.end];
        let mut view = RgbViewMut::new(chunk, f.w, rows.len(), 3 * f.w).unwrap();
        pipeline
            .run(&raw, rows.clone(), &mut scratch, &mut view)
            .unwrap();
        y = rows.end;
    }
    assert_eq!(y, f.h);
    out
}

fn run_fixed(f: &Frame, s: &Settings, bands: &[usize]) -> Vec<u8> {
    let raw = f.raw();
    let config = s.config();
    let pipeline = FixedPipeline::new(&config, 8).unwrap();
    let mut scratch = vec![0xA5A5u16; scratch_len(f.w).unwrap()];
    let mut out = vec![0u8; f.w * f.h * 3];
    let mut y = 0;
    for &band in bands {
        if y == f.h {
            break;
        }
        let rows = y..(y + band).min(f.h);
        let chunk = &mut out[3 * f.w * rows.start..3 * f.w * rows.end];
        let mut view = RgbViewMut::new(chunk, f.w, rows.len(), 3 * f.w).unwrap();
        pipeline
            .run(&raw, rows.clone(), &mut scratch, &mut view)
            .unwrap();
        y = rows.end;
    }
    out
}

fn frame_strategy() -> impl Strategy<Value = Frame> {
    (1usize..=11, 1usize..=11, 0usize..3, 8u8..=16, 0usize..4)
        .prop_flat_map(|(w, h, pad, bits, p)| {
            let max = ((1u32 << bits) - 1) as u16;
            (
                Just((w, h, w + pad, bits, CfaPattern::ALL[p])),
                1u16..=max,
                proptest::collection::vec(any::<u16>(), 4),
                proptest::collection::vec(
                    prop_oneof![Just(0u16), Just(max), 0..=max],
                    (h - 1) * (w + pad) + w,
                ),
            )
        })
        .prop_map(
            |((w, h, stride, bits, pattern), white, black, data)| Frame {
                data,
                w,
                h,
                stride,
                bits,
                pattern,
                black: std::array::from_fn(|i| black[i] % white),
                white,
            },
        )
}

fn settings_strategy(w: usize, h: usize) -> impl Strategy<Value = Settings> {
    (
        proptest::collection::vec((0..w as u16, 0..h as u16), 0..4),
        proptest::option::of(0u16..2000),
        proptest::option::of((2usize..5, 2usize..5)),
        proptest::collection::vec(2048u16..12288, 4 * 4 * 4),
        prop_oneof![Just(1.0f32), 0.5f32..4.0],
        prop_oneof![
            Just([1.0f32; 3]),
            (0.5f32..3.0, 0.8f32..1.2, 0.5f32..3.0).prop_map(|(a, b, c)| [a, b, c])
        ],
        prop_oneof![Just(0.0f32), 0.01f32..0.3],
        prop_oneof![
            Just(isp_core::pipeline::IDENTITY),
            proptest::collection::vec(-0.6f32..0.6, 9).prop_map(|v| {
                // Rows summing to 1, like a real CCM.
                std::array::from_fn(|i| {
                    let (a, b) = (v[3 * i], v[3 * i + 1]);
                    let mut row = [a, b, 0.0];
                    row[i] = 0.0;
                    row[i] = 1.0 - row.iter().sum::<f32>();
                    row
                })
            })
        ],
        (
            prop_oneof![Just(1.0f32), 0.0f32..2.0],
            prop_oneof![Just(1.0f32), 0.5f32..2.0],
            any::<bool>(),
            0usize..3,
        ),
    )
        .prop_map(
            move |(
                defects,
                threshold,
                grid,
                nodes,
                gain,
                wb,
                denoise,
                ccm,
                (sat, contrast, curve, method),
            )| {
                let mut defects: Vec<Defect> =
                    defects.into_iter().map(|(x, y)| Defect { x, y }).collect();
                defects.sort();
                defects.dedup();
                let grid = grid.map(|(gw, gh)| (gw, gh, nodes[..gw * gh * 4].to_vec()));
                let curve = if curve {
                    ToneCurve::new(&[[0.0, 0.05], [0.3, 0.4], [0.8, 0.85], [1.0, 0.95]]).unwrap()
                } else {
                    ToneCurve::IDENTITY
                };
                Settings {
                    defects,
                    threshold,
                    grid,
                    gain,
                    wb,
                    denoise,
                    ccm,
                    tone: Tone {
                        saturation: sat,
                        contrast,
                        curve,
                    },
                    method: Method::ALL[method],
                }
            },
        )
}

fn case() -> impl Strategy<Value = (Frame, Settings, Vec<usize>)> {
    frame_strategy().prop_flat_map(|f| {
        let (w, h) = (f.w, f.h);
        (
            Just(f),
            settings_strategy(w, h),
            proptest::collection::vec(1usize..=h, h),
        )
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(400))]

    /// The float path is the documented semantics: within 1 LSB of the f64 reference (f32
    /// against f64 can fall either side of a rounding boundary), and exact where the reference
    /// is not near one.
    #[test]
    fn float_path_matches_reference((f, mut s, _bands) in case()) {
        s.method = Method::Bilinear; // the reference implements bilinear only
        let ours = run_float(&f, &s, &[f.h]);
        let theirs = reference(&f, &s);
        for (i, (o, t)) in ours.chunks(3).zip(&theirs).enumerate() {
            for c in 0..3 {
                let exact = t[c] * 255.0;
                let diff = (o[c] as f64 - exact).abs();
                prop_assert!(diff <= 0.5 + 2e-3, "pixel {} channel {}: ours {} reference {:.4}", i, c, o[c], exact);
            }
        }
    }

    /// Fixed against float: within 2 LSB everywhere (the 99.9% within 1 LSB is measured over
    /// the datasets, where the count is meaningful).
    #[test]
    fn fixed_path_within_two_lsb_of_float((f, s, _bands) in case()) {
        let float = run_float(&f, &s, &[f.h]);
        let fixed = run_fixed(&f, &s, &[f.h]);
        for (i, (a, b)) in float.iter().zip(&fixed).enumerate() {
            prop_assert!(a.abs_diff(*b) <= 2, "sample {}: float {} fixed {}", i, a, b);
        }
    }

    /// Any band heights give the whole-frame output bit for bit, in both paths.
    #[test]
    fn streaming_is_bit_identical((f, s, bands) in case()) {
        prop_assert_eq!(run_float(&f, &s, &bands), run_float(&f, &s, &[f.h]));
        prop_assert_eq!(run_fixed(&f, &s, &bands), run_fixed(&f, &s, &[f.h]));
    }
}

fn assert_matches_reference(f: &Frame, s: &Settings) {
    let ours = run_float(f, s, &[f.h]);
    let theirs = reference(f, s);
    for (o, t) in ours.chunks(3).zip(&theirs) {
        for c in 0..3 {
            assert!(
                (o[c] as f64 - t[c] * 255.0).abs() <= 0.502,
                "{f:?}: {o:?} vs {t:?}"
            );
        }
    }
    let fixed = run_fixed(f, s, &[f.h]);
    for (a, b) in ours.iter().zip(&fixed) {
        assert!(a.abs_diff(*b) <= 1, "{f:?}: float {a} fixed {b}");
    }
}

fn busy_settings() -> Settings {
    Settings {
        defects: vec![Defect { x: 0, y: 0 }],
        threshold: Some(100),
        grid: Some((2, 2, vec![5000; 16])),
        gain: 1.5,
        wb: [2.0, 1.0, 1.6],
        denoise: 0.05,
        ccm: [[1.6, -0.4, -0.2], [-0.3, 1.5, -0.2], [0.0, -0.5, 1.5]],
        tone: isp_core::tone::Look::Vivid.tone(),
        method: Method::Bilinear,
    }
}

/// Frames at the edges of what is allowed: 1x1, 2x2, odd sizes, stride > width, every pattern,
/// black = white - 1, all zero and all saturated, with every stage off and every stage on.
#[test]
fn edge_frames_match_reference() {
    for pattern in CfaPattern::ALL {
        for (w, h) in [(1, 1), (2, 2), (1, 5), (5, 1), (3, 3), (7, 5)] {
            for (fill, black, white) in [
                (0u16, 0u16, 4095u16),
                (4095, 64, 4095),
                (4094, 4094, 4095),
                (300, 4094, 4095),
            ] {
                let stride = w + 3;
                let data: Vec<u16> = (0..(h - 1) * stride + w)
                    .map(|i| {
                        if fill == 300 {
                            (i as u16 * 611) % 4096
                        } else {
                            fill
                        }
                    })
                    .collect();
                let f = Frame {
                    data,
                    w,
                    h,
                    stride,
                    bits: 12,
                    pattern,
                    black: [black; 4],
                    white,
                };
                assert_matches_reference(&f, &Settings::plain());
                assert_matches_reference(&f, &busy_settings());
            }
        }
    }
}

/// A flat field stays flat through every stage alone, for every pattern (with WB gains the
/// colour changes but every pixel is the same).
#[test]
fn flat_field_stays_flat_through_every_stage() {
    let base = Settings::plain();
    let mut variants = vec![("plain", base.clone())];
    let mut s = base.clone();
    s.threshold = Some(10);
    s.defects = vec![Defect { x: 3, y: 3 }];
    variants.push(("dpc", s));
    let mut s = base.clone();
    s.grid = Some((3, 3, vec![6000; 36]));
    variants.push(("lsc", s));
    let mut s = base.clone();
    s.gain = 2.5;
    variants.push(("gain", s));
    let mut s = base.clone();
    s.wb = [1.9, 1.0, 1.4];
    variants.push(("wb", s));
    for method in Method::ALL {
        let mut s = base.clone();
        s.method = method;
        s.wb = [1.9, 1.0, 1.4];
        variants.push(("demosaic", s));
    }
    let mut s = base.clone();
    s.denoise = 0.2;
    variants.push(("denoise", s));
    let mut s = base.clone();
    s.ccm = busy_settings().ccm;
    variants.push(("ccm", s));
    let mut s = base.clone();
    s.tone = isp_core::tone::Look::HighContrast.tone();
    variants.push(("tone", s));
    variants.push(("all", busy_settings()));
    for pattern in CfaPattern::ALL {
        let (w, h) = (9, 7);
        let f = Frame {
            data: vec![1000; w * h],
            w,
            h,
            stride: w,
            bits: 12,
            pattern,
            black: [200; 4],
            white: 4000,
        };
        for (name, s) in &variants {
            for out in [run_float(&f, s, &[h]), run_fixed(&f, s, &[h])] {
                assert!(
                    out.chunks(3).all(|p| p == &out[..3]),
                    "{name} {pattern:?}: {out:?}"
                );
            }
        }
    }
}

/// A clipped white patch stays neutral after white balance: every channel clips at white, so
/// the interior is exactly white whatever the gains and however far demosaicing reaches.
#[test]
fn saturated_patch_stays_neutral_after_white_balance() {
    for pattern in CfaPattern::ALL {
        for method in Method::ALL {
            let (w, h) = (24, 20);
            let mut data = vec![0u16; w * h];
            for y in 0..h {
                for x in 0..w {
                    // A dim bluish scene around a blown-out patch.
                    let c = pattern.colour_at(x, y).index();
                    let inside = (6..18).contains(&x) && (6..14).contains(&y);
                    data[y * w + x] = if inside { 4095 } else { [300, 500, 900][c] };
                }
            }
            let f = Frame {
                data,
                w,
                h,
                stride: w,
                bits: 12,
                pattern,
                black: [64; 4],
                white: 4095,
            };
            let mut s = busy_settings();
            s.method = method;
            s.defects.clear();
            s.threshold = None;
            s.tone = Tone::default();
            for out in [run_float(&f, &s, &[h]), run_fixed(&f, &s, &[h])] {
                for y in 9..11 {
                    for x in 9..15 {
                        let p = &out[3 * (y * w + x)..3 * (y * w + x) + 3];
                        assert_eq!(p, [255, 255, 255], "{pattern:?} {method:?} ({x}, {y})");
                    }
                }
            }
        }
    }
}

//! A slow, obviously-correct reference of isp-core's documented float semantics (the
//! `pipeline` module docs), in f64, whole frame, one stage after another, written without
//! looking at the pipeline's code paths: DPC, shading, gain, white balance, bilinear demosaic,
//! distortion correction, denoise, CCM, tone and sRGB encoding.

use isp_core::demosaic::Method;
use isp_core::denoise::Search;
use isp_core::distortion::LensDistortion;
use isp_core::dpc::{Defect, DpcConfig};
use isp_core::frame::{LinearFrame, RawFrame};
use isp_core::lsc::LensShading;
use isp_core::noise::NoiseProfile;
use isp_core::pipeline::IspConfig;
use isp_core::tone::Tone;
use isp_core::CfaPattern;

/// A raw frame and everything the reference needs to know about it.
#[derive(Debug, Clone)]
pub struct Frame {
    /// See the pipeline docs.
    pub data: Vec<u16>,
    /// See the pipeline docs.
    pub w: usize,
    /// See the pipeline docs.
    pub h: usize,
    /// See the pipeline docs.
    pub stride: usize,
    /// See the pipeline docs.
    pub bits: u8,
    /// See the pipeline docs.
    pub pattern: CfaPattern,
    /// See the pipeline docs.
    pub black: [u16; 4],
    /// See the pipeline docs.
    pub white: u16,
}

impl Frame {
    /// The frame as isp-core sees it.
    pub fn raw(&self) -> RawFrame<'_> {
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

    /// The sample at `(x, y)`.
    pub fn at(&self, x: usize, y: usize) -> u16 {
        self.data[y * self.stride + x]
    }

    /// The CFA colour index at `(x, y)`.
    pub fn colour(&self, x: usize, y: usize) -> usize {
        self.pattern.colour_at(x, y).index()
    }
}

/// A linear (already demosaiced) frame and everything the reference needs to know about it.
#[derive(Debug, Clone)]
pub struct LinearRef {
    /// Interleaved R, G, B samples.
    pub data: Vec<u16>,
    /// Width in pixels.
    pub w: usize,
    /// Height in pixels.
    pub h: usize,
    /// Samples from one row to the next (at least `3 * w`).
    pub stride: usize,
    /// Bits per sample.
    pub bits: u8,
    /// Black level per channel.
    pub black: [u16; 3],
    /// White level per channel.
    pub white: [u16; 3],
}

impl LinearRef {
    /// The frame as isp-core sees it.
    pub fn frame(&self) -> LinearFrame<'_> {
        LinearFrame::new(
            &self.data,
            self.w,
            self.h,
            self.stride,
            self.bits,
            self.black,
            self.white,
        )
        .unwrap()
    }
}

/// Mirror without repeating the edge, folding until inside.
/// Mirror without repeating the edge.
pub fn mirror(mut i: i64, n: usize) -> usize {
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
pub struct Settings {
    /// See the pipeline docs.
    pub defects: Vec<Defect>,
    /// See the pipeline docs.
    pub threshold: Option<u16>,
    /// See the pipeline docs.
    pub grid: Option<(usize, usize, Vec<u16>)>,
    /// See the pipeline docs.
    pub gain: f32,
    /// See the pipeline docs.
    pub wb: [f32; 3],
    /// See the pipeline docs.
    pub denoise: f32,
    /// See the pipeline docs.
    pub denoise_search: Search,
    /// See the pipeline docs.
    pub noise: Option<NoiseProfile>,
    /// See the pipeline docs.
    pub highlight_knee: f32,
    /// See the pipeline docs.
    pub ccm: [[f32; 3]; 3],
    /// See the pipeline docs.
    pub tone: Tone,
    /// See the pipeline docs.
    pub method: Method,
    /// See the pipeline docs.
    pub distortion: Option<LensDistortion>,
    /// See the pipeline docs.
    pub sharpen: f32,
    /// See the pipeline docs.
    pub chroma_denoise: f32,
}

impl Settings {
    /// The same settings as an isp-core configuration.
    pub fn config(&self) -> IspConfig<'_> {
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
            distortion: self.distortion,
            denoise: self.denoise,
            denoise_search: self.denoise_search,
            noise: self.noise,
            highlight_knee: self.highlight_knee,
            ccm: self.ccm,
            tone: self.tone,
            sharpen: self.sharpen,
            chroma_denoise: self.chroma_denoise,
        }
    }

    /// Every stage off.
    pub fn plain() -> Self {
        Self {
            defects: vec![],
            threshold: None,
            grid: None,
            gain: 1.0,
            wb: [1.0; 3],
            denoise: 0.0,
            denoise_search: Search::Wide,
            noise: None,
            highlight_knee: 1.0,
            ccm: isp_core::pipeline::IDENTITY,
            tone: Tone::default(),
            method: Method::Bilinear,
            distortion: None,
            sharpen: 0.0,
            chroma_denoise: 0.0,
        }
    }
}

/// Defect correction of the whole frame by its definition (isp-core's `dpc` module docs), row
/// by row, `w` samples each.
pub fn dpc_reference(f: &Frame, s: &Settings) -> Vec<u16> {
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

/// Distortion correction from its documented semantics (the `distortion` module docs): the
/// source position of every mesh node through the Brown-Conrady formula, rounded to 1/256
/// pixel; each output pixel's position the bilinear interpolation of its cell's nodes with
/// integer weights, rounded to 1/32 pixel; the bilinear mix of the four pixels around it,
/// black off the frame.
fn undistort_reference(
    rgb: &[[f64; 3]],
    w: usize,
    h: usize,
    lens: &LensDistortion,
) -> Vec<[f64; 3]> {
    let [fx, fy, cx, cy] = lens.camera();
    let [k1, k2, p1, p2, k3] = lens.model().to_opencv();
    let cell = lens.mesh_cell() as i64;
    let node = |i: i64, j: i64| -> Option<[i64; 2]> {
        let (x, y) = (((i * cell) as f64 - cx) / fx, ((j * cell) as f64 - cy) / fy);
        let r2 = x * x + y * y;
        let radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
        let xd = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x);
        let yd = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y;
        let (px, py) = (fx * xd + cx, fy * yd + cy);
        (px.abs() < 2f64.powi(18) && py.abs() < 2f64.powi(18)).then(|| {
            [
                (256.0 * px).round_ties_even() as i64,
                (256.0 * py).round_ties_even() as i64,
            ]
        })
    };
    let mut out = vec![[0.0; 3]; w * h];
    for v in 0..h {
        for u in 0..w {
            let (i, j) = (u as i64 / cell, v as i64 / cell);
            let (fu, fv) = (u as i64 % cell, v as i64 % cell);
            let (Some(a), Some(b), Some(c), Some(d)) = (
                node(i, j),
                node(i + 1, j),
                node(i, j + 1),
                node(i + 1, j + 1),
            ) else {
                continue;
            };
            // In 1 / (256 cell^2) pixel, then to 1/32 (half up).
            let q: [i64; 2] = std::array::from_fn(|k| {
                let top = (cell - fv) * a[k] + fv * c[k];
                let bottom = (cell - fv) * b[k] + fv * d[k];
                let sum = (cell - fu) * top + fu * bottom;
                let unit = 256 * cell * cell / 32;
                (sum + unit / 2).div_euclid(unit)
            });
            let (qx, qy) = (q[0] as f64, q[1] as f64);
            let (sx, sy) = ((qx / 32.0).floor(), (qy / 32.0).floor());
            let (ax, ay) = ((qx - 32.0 * sx) / 32.0, (qy - 32.0 * sy) / 32.0);
            let mut px = [0.0; 3];
            for (dx, dy, weight) in [
                (0.0, 0.0, (1.0 - ax) * (1.0 - ay)),
                (1.0, 0.0, ax * (1.0 - ay)),
                (0.0, 1.0, (1.0 - ax) * ay),
                (1.0, 1.0, ax * ay),
            ] {
                let (tx, ty) = (sx + dx, sy + dy);
                if tx >= 0.0 && ty >= 0.0 && tx < w as f64 && ty < h as f64 {
                    let p = rgb[ty as usize * w + tx as usize];
                    for c in 0..3 {
                        px[c] += weight * p[c];
                    }
                }
            }
            out[v * w + u] = px;
        }
    }
    out
}

/// Noise reduction from its documented semantics (the `denoise` module docs): non-local means
/// over the mosaic packed into 2x2 blocks, in f64, on the normalised mosaic `x`, its patch
/// distances between variance-stabilised values, over the 5x5 (or 3x3) window.
fn denoise_reference(
    x: &[f64],
    f: &Frame,
    profile: &NoiseProfile,
    strength: f64,
    search: Search,
) -> Vec<f64> {
    let (wp, hp) = (f.w / 2, f.h / 2);
    let at = |r: i64, i: i64, k: usize| {
        let (r, i) = (mirror(r, hp), mirror(i, wp));
        x[(2 * r + k / 2) * f.w + 2 * i + k % 2]
    };
    let (scale, offset) = (profile.scale(), profile.offset());
    let floor = 256.0 / (65535.0 * 65535.0);
    let term: [(f64, f64); 4] = std::array::from_fn(|k| {
        let c = f.pattern.colour_at(k % 2, k / 2).index();
        (scale[c] as f64, offset[c] as f64)
    });
    // The integral of 1 / sqrt(max(S t + O, Q)) from 0 to v, in closed form.
    let stabilise = |v: f64, k: usize| {
        let (s, o) = term[k];
        let knee = if o >= floor {
            0.0
        } else if s > 0.0 {
            (floor - o) / s
        } else {
            f64::INFINITY
        };
        if v <= knee {
            v / floor.sqrt()
        } else {
            knee / floor.sqrt() + 2.0 * ((s * v + o).sqrt() - (s * knee + o).sqrt()) / s
        }
    };
    let stable = |r: i64, i: i64, k: usize| stabilise(at(r, i, k), k);
    let h = [0.8, 1.0][search as usize] * strength;
    let radius = search.radius() as i64;
    let mut out = x.to_vec();
    for r in 0..hp as i64 {
        for i in 0..wp as i64 {
            let (mut num, mut den) = ([0.0; 4], 0.0);
            for dy in -radius..=radius {
                for dx in -radius..=radius {
                    let mut distance = 0.0;
                    for pr in -1..=1 {
                        for pi in -1..=1 {
                            let (qr, qi) = (r + pr, i + pi);
                            for k in 0..4 {
                                let d = stable(qr + dy, qi + dx, k) - stable(qr, qi, k);
                                distance += d * d;
                            }
                        }
                    }
                    let excess = (distance - 72.0).max(0.0);
                    let u = (1.0 - excess / (8.0 * 72.0 * h * h)).max(0.0);
                    let w = u.powi(8);
                    den += w;
                    for (k, n) in num.iter_mut().enumerate() {
                        *n += w * at(r + dy, i + dx, k);
                    }
                }
            }
            for k in 0..4 {
                out[(2 * r as usize + k / 2) * f.w + 2 * i as usize + k % 2] = num[k] / den;
            }
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
pub fn reference(f: &Frame, s: &Settings) -> Vec<[f64; 3]> {
    let raw = dpc_reference(f, s);
    let white = f.white as f64;
    let normalised: Vec<f64> = (0..f.w * f.h)
        .map(|i| {
            let black = f.black[((i / f.w) % 2) * 2 + (i % f.w) % 2] as f64;
            ((raw[i] as f64 - black).max(0.0) / (white - black)).clamp(0.0, 1.0)
        })
        .collect();
    let denoised = match (&s.noise, s.denoise > 0.0) {
        (Some(profile), true) => Some(denoise_reference(
            &normalised,
            f,
            profile,
            s.denoise as f64,
            s.denoise_search,
        )),
        _ => None,
    };
    let mut m = vec![0.0; f.w * f.h];
    for y in 0..f.h {
        for x in 0..f.w {
            let black = f.black[(y % 2) * 2 + x % 2] as f64;
            let d = (raw[y * f.w + x] as f64 - black).max(0.0);
            let shading = lsc_reference(s, x, y, f.w, f.h);
            let mut v = match &denoised {
                // Noise reduction runs on the clamped normalised sample, before shading.
                Some(n) => (shading * n[y * f.w + x]).clamp(0.0, 1.0),
                None => (shading * d / (white - black)).clamp(0.0, 1.0),
            };
            v = (s.gain as f64 * v).min(1.0);
            v = (s.wb[f.colour(x, y)] as f64 * v).min(1.0);
            m[y * f.w + x] = v;
        }
    }
    let rgb = bilinear_reference(&m, f);
    // Highlights: each channel towards the largest, in proportion to how far the largest of
    // the pixel's channels and the 3x3 prepared mosaic around it is from the knee to the clip.
    let knee = s.highlight_knee as f64;
    let rgb: Vec<[f64; 3]> = rgb
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let (x, y) = (i % f.w, i / f.w);
            let top = p[0].max(p[1]).max(p[2]);
            let mut level = top;
            for dy in -1..=1i64 {
                for dx in -1..=1i64 {
                    let (nx, ny) = (mirror(x as i64 + dx, f.w), mirror(y as i64 + dy, f.h));
                    level = level.max(m[ny * f.w + nx]);
                }
            }
            if knee < 1.0 && level > knee {
                let k = ((level - knee) / (1.0 - knee)).min(1.0);
                p.map(|v| v + k * (top - v))
            } else {
                *p
            }
        })
        .collect();
    finish_reference(rgb, f.w, f.h, s)
}

/// The documented semantics for a linear frame: the pointwise stages per channel, no defect
/// correction or demosaicing, highlights from the pixel's own channels, then the same stages
/// after demosaicing as a mosaic.
pub fn reference_linear(f: &LinearRef, s: &Settings) -> Vec<[f64; 3]> {
    let knee = s.highlight_knee as f64;
    let mut rgb = Vec::with_capacity(f.w * f.h);
    for y in 0..f.h {
        for x in 0..f.w {
            let p: [f64; 3] = std::array::from_fn(|c| {
                let (black, white) = (f.black[c] as f64, f.white[c] as f64);
                let d = (f.data[y * f.stride + 3 * x + c] as f64 - black).max(0.0);
                let mut v =
                    (lsc_reference(s, x, y, f.w, f.h) * d / (white - black)).clamp(0.0, 1.0);
                v = (s.gain as f64 * v).min(1.0);
                (s.wb[c] as f64 * v).min(1.0)
            });
            let top = p[0].max(p[1]).max(p[2]);
            rgb.push(if knee < 1.0 && top > knee {
                let k = ((top - knee) / (1.0 - knee)).min(1.0);
                p.map(|v| v + k * (top - v))
            } else {
                p
            });
        }
    }
    finish_reference(rgb, f.w, f.h, s)
}

/// Distortion, CCM, tone and encoding of demosaiced RGB.
fn finish_reference(rgb: Vec<[f64; 3]>, w: usize, h: usize, s: &Settings) -> Vec<[f64; 3]> {
    let rgb = match &s.distortion {
        Some(lens) => undistort_reference(&rgb, w, h, lens),
        None => rgb,
    };
    let encoded: Vec<[f64; 3]> = rgb
        .iter()
        .map(|p| {
            let lin: [f64; 3] = std::array::from_fn(|i| {
                (0..3)
                    .map(|j| s.ccm[i][j] as f64 * p[j])
                    .sum::<f64>()
                    .clamp(0.0, 1.0)
            });
            tone_reference(&s.tone, lin).map(srgb_reference)
        })
        .collect();
    let luma = |p: &[f64; 3]| 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2];
    let encoded = match s.chroma_denoise {
        0.0 => encoded,
        strength => chroma_reference(&encoded, w, h, strength as f64),
    };
    if s.sharpen == 0.0 {
        return encoded
            .iter()
            .map(|p| p.map(|v| v.clamp(0.0, 1.0)))
            .collect();
    }
    // Unsharp mask on Rec. 709 luma: the luma's difference from its 3x3 binomial blur
    // (reflect-101), times the amount, added to each channel.
    (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as i64, (i / w) as i64);
            let mut blur = 0.0;
            for dy in -1..=1i64 {
                for dx in -1..=1i64 {
                    let weight = ((2 - dx.abs()) * (2 - dy.abs())) as f64 / 16.0;
                    blur += weight * luma(&encoded[mirror(y + dy, h) * w + mirror(x + dx, w)]);
                }
            }
            let detail = s.sharpen as f64 * (luma(&encoded[i]) - blur);
            encoded[i].map(|v| (v + detail).clamp(0.0, 1.0))
        })
        .collect()
}

/// Chroma noise reduction from its documented semantics (isp-core's `chroma` module docs):
/// each pixel as luma and chroma, chroma the edge-aware mean over 7 pixels along the row, then
/// over 7 along the column of that, luma kept; unclamped.
fn chroma_reference(encoded: &[[f64; 3]], w: usize, h: usize, strength: f64) -> Vec<[f64; 3]> {
    let (ty, tc) = (0.08 * strength, 0.15 * strength);
    let luma = |p: &[f64; 3]| 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2];
    // (luma, chroma) of every pixel.
    let split: Vec<(f64, [f64; 3])> = encoded
        .iter()
        .map(|p| {
            let y = luma(p);
            (y, p.map(|v| v - y))
        })
        .collect();
    let pass = |input: &[(f64, [f64; 3])], along_row: bool| -> Vec<(f64, [f64; 3])> {
        (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as i64, (i / w) as i64);
                let (yp, cp) = input[i];
                let mut sum = [0.0; 3];
                let mut den = 0.0;
                for k in -3..=3i64 {
                    let j = if along_row {
                        y as usize * w + mirror(x + k, w)
                    } else {
                        mirror(y + k, h) * w + x as usize
                    };
                    let (yq, cq) = input[j];
                    let dc: f64 = (0..3).map(|c| (cq[c] - cp[c]).abs()).sum();
                    let weight = (1.0 - (yq - yp).abs() / ty - dc / tc).max(0.0);
                    for c in 0..3 {
                        sum[c] += weight * cq[c];
                    }
                    den += weight;
                }
                (yp, sum.map(|v| v / den))
            })
            .collect()
    };
    let filtered = pass(&pass(&split, true), false);
    filtered.iter().map(|(y, c)| c.map(|v| y + v)).collect()
}

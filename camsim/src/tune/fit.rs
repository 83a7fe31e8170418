//! The fits of `camsim tune`, each on plain arrays: black level, defects, photon transfer,
//! shading, the white-balance locus and the colour matrix.

use isp_core::CfaPattern;

use super::chart::solve;
use super::reference::delta_e_srgb;

/// Per 2x2 position (row-major) robust mean of dark frames: the mean of the samples within
/// eight robust standard deviations of the median (hot pixels and their kin left out), and
/// that standard deviation.
pub fn black_level(darks: &[&[u16]], width: usize) -> ([f64; 4], [f64; 4]) {
    let mut per: [Vec<u16>; 4] = Default::default();
    for d in darks {
        for (i, &v) in d.iter().enumerate() {
            let (x, y) = (i % width, i / width);
            per[(y % 2) * 2 + x % 2].push(v);
        }
    }
    let mut mean = [0.0; 4];
    let mut sigma = [0.0; 4];
    for p in 0..4 {
        let v = &mut per[p];
        if v.is_empty() {
            continue;
        }
        v.sort_unstable();
        let median = f64::from(v[v.len() / 2]);
        let mut dev: Vec<f64> = v.iter().map(|&s| (f64::from(s) - median).abs()).collect();
        dev.sort_by(f64::total_cmp);
        let s = (1.4826 * dev[dev.len() / 2]).max(0.5);
        let (mut sum, mut n) = (0.0, 0.0);
        for &x in v.iter() {
            if (f64::from(x) - median).abs() <= 8.0 * s {
                sum += f64::from(x);
                n += 1.0;
            }
        }
        mean[p] = sum / n;
        sigma[p] = s;
    }
    (mean, sigma)
}

/// Averages frames sample by sample.
pub fn average(frames: &[&[u16]]) -> Vec<f64> {
    let n = frames.len().max(1) as f64;
    let len = frames.first().map_or(0, |f| f.len());
    let mut out = vec![0.0; len];
    for f in frames {
        for (o, &v) in out.iter_mut().zip(f.iter()) {
            *o += f64::from(v);
        }
    }
    out.iter_mut().for_each(|o| *o /= n);
    out
}

/// Hot pixels of an averaged dark frame: above black by more than
/// `max(8 sigma / sqrt(frames), 16 DN)` at their position.
pub fn hot_pixels(
    dark_mean: &[f64],
    width: usize,
    black: [f64; 4],
    sigma: [f64; 4],
    frames: usize,
) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    for (i, &v) in dark_mean.iter().enumerate() {
        let (x, y) = (i % width, i / width);
        let p = (y % 2) * 2 + x % 2;
        let limit = (8.0 * sigma[p] / (frames.max(1) as f64).sqrt()).max(16.0);
        if v - black[p] > limit {
            out.push((x, y));
        }
    }
    out
}

/// Pixels of an averaged flat field that differ from the median of their eight nearest
/// same-colour neighbours by more than a quarter of it (dead, stuck or hot), black
/// subtracted. Pixels of the frame's outer two rows and columns compare with the neighbours
/// they have.
pub fn flat_outliers(
    flat: &[f64],
    width: usize,
    height: usize,
    black: [f64; 4],
) -> Vec<(usize, usize, f64, f64)> {
    let mut out = Vec::new();
    let value = |x: usize, y: usize| flat[y * width + x] - black[(y % 2) * 2 + x % 2];
    for y in 0..height {
        for x in 0..width {
            let mut n = [0.0f64; 8];
            let mut k = 0;
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
                let (nx, ny) = (x as i64 + dx, y as i64 + dy);
                if nx >= 0 && ny >= 0 && (nx as usize) < width && (ny as usize) < height {
                    n[k] = value(nx as usize, ny as usize);
                    k += 1;
                }
            }
            if k < 3 {
                continue;
            }
            let near = &mut n[..k];
            near.sort_by(f64::total_cmp);
            let median = near[k / 2];
            let v = value(x, y);
            if median > 0.0 && (v - median).abs() > 0.25 * median {
                out.push((x, y, v, median));
            }
        }
    }
    out
}

/// A photon-transfer point: mean signal above black and temporal variance, DN and DN^2.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TransferPoint {
    /// Mean above black, DN.
    pub mean: f64,
    /// Half the variance of the pair's difference, DN^2.
    pub variance: f64,
}

/// EMVA 1288's per-pair statistics for each colour: mean of the two frames above black, and
/// half the variance of their difference, over the whole frame, `skip` pixels left out.
pub fn transfer_point(
    a: &[u16],
    b: &[u16],
    width: usize,
    pattern: CfaPattern,
    black: [f64; 4],
    skip: &dyn Fn(usize, usize) -> bool,
) -> [TransferPoint; 3] {
    let (mut s, mut d, mut d2, mut n) = ([0.0f64; 3], [0.0f64; 3], [0.0f64; 3], [0.0f64; 3]);
    for (i, (&va, &vb)) in a.iter().zip(b).enumerate() {
        let (x, y) = (i % width, i / width);
        if skip(x, y) {
            continue;
        }
        let c = pattern.colour_at(x, y).index();
        let bl = black[(y % 2) * 2 + x % 2];
        s[c] += (f64::from(va) + f64::from(vb)) / 2.0 - bl;
        let diff = f64::from(va) - f64::from(vb);
        d[c] += diff;
        d2[c] += diff * diff;
        n[c] += 1.0;
    }
    std::array::from_fn(|c| {
        let m = d[c] / n[c];
        TransferPoint {
            mean: s[c] / n[c],
            variance: (d2[c] / n[c] - m * m) * n[c] / (n[c] - 1.0) / 2.0,
        }
    })
}

/// Fits `variance = slope mean + offset`: the offset from the dark pair when there is one
/// (EMVA 1288's read noise) and the slope through it by least squares weighted by the
/// variance's own uncertainty (proportional to it), else both by that weighted line.
pub fn transfer_fit(points: &[TransferPoint], dark: Option<TransferPoint>) -> Option<(f64, f64)> {
    match dark {
        Some(d) => {
            let (mut num, mut den) = (0.0, 0.0);
            for p in points {
                let (x, y) = (p.mean - d.mean, p.variance - d.variance);
                let w = 1.0 / (p.variance * p.variance).max(1e-12);
                num += w * x * y;
                den += w * x * x;
            }
            (den > 0.0).then(|| (num / den, d.variance))
        }
        None => {
            if points.len() < 2 {
                return None;
            }
            let mut gram = [[0.0f64; 2]; 2];
            let mut cross = [0.0f64; 2];
            for p in points {
                let w = 1.0 / (p.variance * p.variance).max(1e-12);
                let t = [p.mean, 1.0];
                for i in 0..2 {
                    for j in 0..2 {
                        gram[i][j] += w * t[i] * t[j];
                    }
                    cross[i] += w * t[i] * p.variance;
                }
            }
            solve::<2>(gram, cross).map(|s| (s[0], s[1]))
        }
    }
}

/// Fits `variance = S mean + O + P mean^2` to chart patches (spatial variance, so the
/// fixed-pattern PRNU is the quadratic term and is left out of the noise): returns `(S, O)`.
pub fn patch_noise_fit(points: &[TransferPoint]) -> Option<(f64, f64)> {
    if points.len() < 4 {
        return None;
    }
    let mut gram = [[0.0f64; 3]; 3];
    let mut cross = [0.0f64; 3];
    for p in points {
        let w = 1.0 / (p.variance * p.variance).max(1e-12);
        let t = [p.mean, 1.0, p.mean * p.mean];
        for i in 0..3 {
            for j in 0..3 {
                gram[i][j] += w * t[i] * t[j];
            }
            cross[i] += w * t[i] * p.variance;
        }
    }
    solve::<3>(gram, cross).map(|s| (s[0], s[1].max(0.0)))
}

/// Fits `variance = zero + S mean + P mean^2` to chart patches with the zero-signal variance
/// `zero` known (the dark frames' spatial variance, [`DarkVariance::spatial`]): returns `S`.
/// Pinning the intercept leaves the fit nothing to extrapolate below the darkest patch.
pub fn patch_scale_fit(points: &[TransferPoint], zero: f64) -> Option<f64> {
    if points.len() < 3 || !zero.is_finite() {
        return None;
    }
    let mut gram = [[0.0f64; 2]; 2];
    let mut cross = [0.0f64; 2];
    for p in points {
        let w = 1.0 / (p.variance * p.variance).max(1e-12);
        let t = [p.mean, p.mean * p.mean];
        for i in 0..2 {
            for j in 0..2 {
                gram[i][j] += w * t[i] * t[j];
            }
            cross[i] += w * t[i] * (p.variance - zero);
        }
    }
    solve::<2>(gram, cross).map(|s| s[0])
}

/// The noise of dark frames per colour (R, G, B), DN^2, defects left out.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DarkVariance {
    /// Temporal: half the variance of the difference of two frames (frames 1-2, 3-4, ...
    /// averaged), which the fixed pattern (DSNU) cancels out of; `None` with one frame.
    pub temporal: Option<[f64; 3]>,
    /// Spatial: one frame's variance about its mean at each CFA position, averaged over the
    /// frames; the temporal noise plus the DSNU, what a chart patch holds at zero signal.
    pub spatial: [f64; 3],
}

/// The noise of `darks` (same size, `width` wide) per colour of `pattern`, pixels where
/// `skip(x, y)` left out; samples beyond 8 robust deviations (an unmarked hot pixel) too.
/// `None` without frames or with a colour left empty.
pub fn dark_variance(
    darks: &[&[u16]],
    width: usize,
    pattern: CfaPattern,
    skip: &dyn Fn(usize, usize) -> bool,
) -> Option<DarkVariance> {
    if darks.is_empty() || width == 0 {
        return None;
    }
    // Variance per CFA position of `value` (a frame or a difference), pooled per colour.
    let per_colour = |value: &dyn Fn(usize) -> f64, len: usize| -> Option<[f64; 3]> {
        let mut by_position: [Vec<f64>; 4] = Default::default();
        for i in 0..len {
            let (x, y) = (i % width, i / width);
            if !skip(x, y) {
                by_position[(y % 2) * 2 + x % 2].push(value(i));
            }
        }
        let (mut sum, mut count) = ([0.0f64; 3], [0.0f64; 3]);
        for (p, v) in by_position.iter_mut().enumerate() {
            if v.len() < 16 {
                continue;
            }
            v.sort_by(f64::total_cmp);
            let median = v[v.len() / 2];
            let mut dev: Vec<f64> = v.iter().map(|s| (s - median).abs()).collect();
            dev.sort_by(f64::total_cmp);
            let limit = 8.0 * (1.4826 * dev[dev.len() / 2]).max(0.5);
            let kept: Vec<f64> = v
                .iter()
                .copied()
                .filter(|s| (s - median).abs() <= limit)
                .collect();
            let n = kept.len() as f64;
            let mean = kept.iter().sum::<f64>() / n;
            let var = kept.iter().map(|s| (s - mean) * (s - mean)).sum::<f64>() / (n - 1.0);
            let c = pattern.colour_at(p % 2, p / 2).index();
            sum[c] += var * n;
            count[c] += n;
        }
        (count.iter().all(|&n| n > 0.0)).then(|| std::array::from_fn(|c| sum[c] / count[c]))
    };
    let len = darks[0].len();
    let mut spatial = [0.0; 3];
    for d in darks {
        let v = per_colour(&|i| f64::from(d[i]), len.min(d.len()))?;
        (0..3).for_each(|c| spatial[c] += v[c] / darks.len() as f64);
    }
    let pairs: Vec<[f64; 3]> = darks
        .chunks_exact(2)
        .map(|ab| {
            let (a, b) = (ab[0], ab[1]);
            per_colour(
                &|i| f64::from(a[i]) - f64::from(b[i]),
                len.min(a.len()).min(b.len()),
            )
            .map(|v| v.map(|x| x / 2.0))
        })
        .collect::<Option<_>>()?;
    let temporal = (!pairs.is_empty()).then(|| {
        std::array::from_fn(|c| pairs.iter().map(|v| v[c]).sum::<f64>() / pairs.len() as f64)
    });
    Some(DarkVariance { temporal, spatial })
}

/// Degree of the shading polynomial.
const SHADING_DEGREE: usize = 6;
/// Its term count: (d + 1)(d + 2) / 2.
const SHADING_TERMS: usize = (SHADING_DEGREE + 1) * (SHADING_DEGREE + 2) / 2;

fn shading_terms(u: f64, v: f64) -> [f64; SHADING_TERMS] {
    let mut t = [0.0; SHADING_TERMS];
    let mut k = 0;
    for total in 0..=SHADING_DEGREE {
        for i in 0..=total {
            t[k] = u.powi(i as i32) * v.powi((total - i) as i32);
            k += 1;
        }
    }
    t
}

/// A smooth model of one colour of a flat field: a polynomial of degree six in the frame's
/// coordinates scaled to [-1, 1], fitted to 16 x 16-pixel block means (defects left out).
#[derive(Debug, Clone)]
pub struct FlatModel {
    coefficients: [f64; SHADING_TERMS],
    width: f64,
    height: f64,
}

impl FlatModel {
    /// Fits colour `colour` of `flat` (black subtracted by the caller's `value`).
    pub fn fit(
        width: usize,
        height: usize,
        pattern: CfaPattern,
        colour: usize,
        value: &dyn Fn(usize, usize) -> Option<f64>,
    ) -> Option<FlatModel> {
        const BLOCK: usize = 16;
        let mut gram = vec![[0.0f64; SHADING_TERMS]; SHADING_TERMS];
        let mut cross = [0.0f64; SHADING_TERMS];
        let (w, h) = (width as f64, height as f64);
        let mut blocks = 0;
        for by in (0..height).step_by(BLOCK) {
            for bx in (0..width).step_by(BLOCK) {
                let (mut s, mut sx, mut sy, mut n) = (0.0, 0.0, 0.0, 0.0);
                for y in by..(by + BLOCK).min(height) {
                    for x in bx..(bx + BLOCK).min(width) {
                        if pattern.colour_at(x, y).index() != colour {
                            continue;
                        }
                        if let Some(v) = value(x, y) {
                            s += v;
                            sx += x as f64 + 0.5;
                            sy += y as f64 + 0.5;
                            n += 1.0;
                        }
                    }
                }
                if n < 4.0 {
                    continue;
                }
                let t = shading_terms(2.0 * sx / n / w - 1.0, 2.0 * sy / n / h - 1.0);
                for i in 0..SHADING_TERMS {
                    for j in 0..SHADING_TERMS {
                        gram[i][j] += t[i] * t[j];
                    }
                    cross[i] += t[i] * s / n;
                }
                blocks += 1;
            }
        }
        if blocks < SHADING_TERMS {
            return None;
        }
        let mut a = [[0.0f64; SHADING_TERMS]; SHADING_TERMS];
        a.copy_from_slice(&gram);
        let coefficients = solve::<SHADING_TERMS>(a, cross)?;
        Some(FlatModel {
            coefficients,
            width: w,
            height: h,
        })
    }

    /// The model's value at pixel position `(x, y)` (continuous, pixel centres at +0.5).
    pub fn at(&self, x: f64, y: f64) -> f64 {
        let t = shading_terms(2.0 * x / self.width - 1.0, 2.0 * y / self.height - 1.0);
        t.iter().zip(&self.coefficients).map(|(a, b)| a * b).sum()
    }
}

/// Bilinear interpolation of a `gw x gh` grid whose node `i` sits on pixel `i (w - 1) / (gw -
/// 1)` (isp-core's lens-shading layout), at pixel `(x, y)`.
pub fn grid_at(
    grid: &[f64],
    gw: usize,
    gh: usize,
    width: usize,
    height: usize,
    x: f64,
    y: f64,
) -> f64 {
    let fx = (x * (gw - 1) as f64 / (width.max(2) - 1) as f64).clamp(0.0, (gw - 1) as f64);
    let fy = (y * (gh - 1) as f64 / (height.max(2) - 1) as f64).clamp(0.0, (gh - 1) as f64);
    let (ix, iy) = ((fx as usize).min(gw - 2), (fy as usize).min(gh - 2));
    let (tx, ty) = (fx - ix as f64, fy - iy as f64);
    let g = |i: usize, j: usize| grid[j * gw + i];
    (1.0 - ty) * ((1.0 - tx) * g(ix, iy) + tx * g(ix + 1, iy))
        + ty * ((1.0 - tx) * g(ix, iy + 1) + tx * g(ix + 1, iy + 1))
}

/// The node positions of a `gw x gh` grid over a frame, pixels (isp-core's layout).
pub fn grid_nodes(gw: usize, gh: usize, width: usize, height: usize) -> Vec<(f64, f64)> {
    let mut nodes = Vec::with_capacity(gw * gh);
    for j in 0..gh {
        for i in 0..gw {
            nodes.push((
                i as f64 * (width.max(2) - 1) as f64 / (gw - 1) as f64,
                j as f64 * (height.max(2) - 1) as f64 / (gh - 1) as f64,
            ));
        }
    }
    nodes
}

/// A white-balance locus: `b = c0 + c1 r + c2 r^2` in normalised chromaticity (`r = R / (R +
/// G + B)`, `b = B / (R + G + B)` of the light's camera colour), and the CCTs of its points.
#[derive(Debug, Clone, PartialEq)]
pub struct Locus {
    /// `c0, c1, c2`.
    pub coefficients: [f64; 3],
    /// The fitted points: CCT, r, b, sorted by r.
    pub points: Vec<(f64, f64, f64)>,
}

/// Normalised chromaticity of a camera colour.
pub fn chromaticity(rgb: [f64; 3]) -> [f64; 2] {
    let s = rgb[0] + rgb[1] + rgb[2];
    [rgb[0] / s, rgb[2] / s]
}

impl Locus {
    /// Fits the quadratic (a line through two points); `None` with fewer than two points or
    /// two at one `r`.
    pub fn fit(points: &[(f64, [f64; 3])]) -> Option<Locus> {
        let mut pts: Vec<(f64, f64, f64)> = points
            .iter()
            .map(|(cct, rgb)| {
                let [r, b] = chromaticity(*rgb);
                (*cct, r, b)
            })
            .collect();
        pts.sort_by(|a, b| a.1.total_cmp(&b.1));
        if pts.len() < 2 || pts.windows(2).any(|p| (p[1].1 - p[0].1).abs() < 1e-6) {
            return None;
        }
        let coefficients = if pts.len() == 2 {
            let slope = (pts[1].2 - pts[0].2) / (pts[1].1 - pts[0].1);
            [pts[0].2 - slope * pts[0].1, slope, 0.0]
        } else {
            let mut gram = [[0.0f64; 3]; 3];
            let mut cross = [0.0f64; 3];
            for &(_, r, b) in &pts {
                let t = [1.0, r, r * r];
                for i in 0..3 {
                    for j in 0..3 {
                        gram[i][j] += t[i] * t[j];
                    }
                    cross[i] += t[i] * b;
                }
            }
            solve::<3>(gram, cross)?
        };
        Some(Locus {
            coefficients,
            points: pts,
        })
    }

    /// `b` on the locus at `r`.
    pub fn b_at(&self, r: f64) -> f64 {
        let [c0, c1, c2] = self.coefficients;
        c0 + c1 * r + c2 * r * r
    }

    /// The point of the locus nearest `(r, b)`, and the signed distance to it (positive
    /// above: more blue than the locus).
    pub fn project(&self, [r, b]: [f64; 2]) -> ([f64; 2], f64) {
        let (lo, hi) = (self.points[0].1, self.points[self.points.len() - 1].1);
        let span = hi - lo;
        let mut best = (f64::INFINITY, [r, self.b_at(r)]);
        for k in 0..=2000 {
            let rr = lo - 0.5 * span + 2.0 * span * k as f64 / 2000.0;
            let p = [rr, self.b_at(rr)];
            let d = (p[0] - r).hypot(p[1] - b);
            if d < best.0 {
                best = (d, p);
            }
        }
        let sign = if b >= self.b_at(r) { 1.0 } else { -1.0 };
        (best.1, sign * best.0)
    }

    /// The CCT at `r` on the locus: linear in reciprocal temperature (mired) between the
    /// points, extended along the end segments, held within 1500..=15000 K.
    pub fn cct_at(&self, r: f64) -> f64 {
        let p = &self.points;
        let k = p
            .windows(2)
            .position(|w| r <= w[1].1)
            .unwrap_or(p.len() - 2);
        let (a, b) = (p[k], p[k + 1]);
        let t = (r - a.1) / (b.1 - a.1);
        let mired = 1e6 / a.0 + t * (1e6 / b.0 - 1e6 / a.0);
        (1e6 / mired.max(1e6 / 15000.0)).clamp(1500.0, 15000.0)
    }
}

/// A colour matrix fit: white-balanced camera RGB (neutral at 1, 1, 1) to linear sRGB, rows
/// summing to one (white preserved), with the exposure scale it was fitted with.
#[derive(Debug, Clone, PartialEq)]
pub struct CcmFit {
    /// The matrix.
    pub matrix: [[f64; 3]; 3],
    /// The exposure scale applied to the camera values before the matrix.
    pub scale: f64,
    /// Per-patch CIEDE2000 after the fit.
    pub delta_e: Vec<f64>,
}

/// [`ccm_errors`] with the exposure the ISP would give (not the matrix's business): scaled so
/// the matrix's green on the five brighter greys (white to neutral 3.5) matches the target's
/// by least squares.
pub fn ccm_errors_at_grey_exposure(
    matrix: &[[f64; 3]; 3],
    camera: &[[f64; 3]],
    target: &[[f64; 3]],
) -> Vec<f64> {
    let (mut num, mut den) = (0.0, 0.0);
    for &g in &super::chart::NEUTRALS[..5] {
        let out: f64 = (0..3).map(|k| matrix[1][k] * camera[g][k]).sum();
        num += out * target[g][1];
        den += out * out;
    }
    ccm_errors(matrix, num / den.max(f64::MIN_POSITIVE), camera, target)
}

/// Per-patch CIEDE2000 of `matrix` and `scale` on white-balanced `camera` against `target`.
pub fn ccm_errors(
    matrix: &[[f64; 3]; 3],
    scale: f64,
    camera: &[[f64; 3]],
    target: &[[f64; 3]],
) -> Vec<f64> {
    camera
        .iter()
        .zip(target)
        .map(|(c, t)| {
            let out: [f64; 3] =
                std::array::from_fn(|r| scale * (0..3).map(|k| matrix[r][k] * c[k]).sum::<f64>());
            delta_e_srgb(out, *t)
        })
        .collect()
}

/// Fits the matrix: least squares with rows summing to one for a start, then the mean
/// CIEDE2000 minimised over the six free entries and the exposure scale (Nelder-Mead).
pub fn fit_ccm(camera: &[[f64; 3]], target: &[[f64; 3]], greys: &[usize]) -> Option<CcmFit> {
    if camera.len() != target.len() || camera.len() < 6 {
        return None;
    }
    // Exposure from the greys' green.
    let (mut ct, mut cc) = (0.0, 0.0);
    for &g in greys {
        ct += target[g][1] * camera[g][1];
        cc += camera[g][1] * camera[g][1];
    }
    let scale0 = if cc > 0.0 { ct / cc } else { 1.0 };
    // Row r: m = (a, b, 1 - a - b), so t - x3 = a (x1 - x3) + b (x2 - x3).
    let mut start = [[0.0f64; 3]; 3];
    for r in 0..3 {
        let mut gram = [[0.0f64; 2]; 2];
        let mut cross = [0.0f64; 2];
        for (c, t) in camera.iter().zip(target) {
            let x = c.map(|v| v * scale0);
            let u = [x[0] - x[2], x[1] - x[2]];
            let y = t[r] - x[2];
            for i in 0..2 {
                for j in 0..2 {
                    gram[i][j] += u[i] * u[j];
                }
                cross[i] += u[i] * y;
            }
        }
        let [a, b] = solve::<2>(gram, cross)?;
        start[r] = [a, b, 1.0 - a - b];
    }
    let unpack = |p: &[f64; 7]| -> ([[f64; 3]; 3], f64) {
        let m = std::array::from_fn(|r| [p[2 * r], p[2 * r + 1], 1.0 - p[2 * r] - p[2 * r + 1]]);
        (m, scale0 * p[6].exp())
    };
    let cost = |p: &[f64; 7]| -> f64 {
        let (m, s) = unpack(p);
        let e = ccm_errors(&m, s, camera, target);
        let mean = e.iter().sum::<f64>() / e.len() as f64;
        if mean.is_finite() {
            mean
        } else {
            f64::INFINITY
        }
    };
    let p0 = [
        start[0][0],
        start[0][1],
        start[1][0],
        start[1][1],
        start[2][0],
        start[2][1],
        0.0,
    ];
    let best = nelder_mead(&cost, p0, 0.1, 20000);
    let (matrix, scale) = unpack(&best);
    let delta_e = ccm_errors(&matrix, scale, camera, target);
    Some(CcmFit {
        matrix,
        scale,
        delta_e,
    })
}

/// Nelder-Mead minimisation from `start` with initial steps `step`, restarted once from its
/// own answer (the simplex collapses early on a kinked cost such as a mean of CIEDE2000s).
fn nelder_mead<const N: usize>(
    f: &dyn Fn(&[f64; N]) -> f64,
    start: [f64; N],
    step: f64,
    iterations: usize,
) -> [f64; N] {
    let mut best = start;
    for round in 0..8 {
        let s = step / (1 + round % 4) as f64;
        let mut simplex: Vec<([f64; N], f64)> = (0..=N)
            .map(|i| {
                let mut p = best;
                if i > 0 {
                    p[i - 1] += s;
                }
                (p, f(&p))
            })
            .collect();
        for _ in 0..iterations {
            simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
            let worst = simplex[N];
            let centroid: [f64; N] = std::array::from_fn(|k| {
                simplex[..N].iter().map(|p| p.0[k]).sum::<f64>() / N as f64
            });
            let along = |t: f64| -> [f64; N] {
                std::array::from_fn(|k| centroid[k] + t * (worst.0[k] - centroid[k]))
            };
            let reflected = along(-1.0);
            let fr = f(&reflected);
            if fr < simplex[0].1 {
                let expanded = along(-2.0);
                let fe = f(&expanded);
                simplex[N] = if fe < fr {
                    (expanded, fe)
                } else {
                    (reflected, fr)
                };
            } else if fr < simplex[N - 1].1 {
                simplex[N] = (reflected, fr);
            } else {
                let contracted = along(0.5);
                let fc = f(&contracted);
                if fc < worst.1 {
                    simplex[N] = (contracted, fc);
                } else {
                    let b = simplex[0].0;
                    for p in simplex.iter_mut().skip(1) {
                        p.0 = std::array::from_fn(|k| b[k] + 0.5 * (p.0[k] - b[k]));
                        p.1 = f(&p.0);
                    }
                }
            }
            let spread = simplex
                .iter()
                .map(|p| p.1)
                .fold(f64::NEG_INFINITY, f64::max)
                - simplex.iter().map(|p| p.1).fold(f64::INFINITY, f64::min);
            if spread < 1e-10 {
                break;
            }
        }
        simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
        best = simplex[0].0;
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn transfer_fit_recovers_a_line() {
        let points: Vec<TransferPoint> = [10.0, 100.0, 1000.0]
            .iter()
            .map(|&m| TransferPoint {
                mean: m,
                variance: 0.5 * m + 3.0,
            })
            .collect();
        let (s, o) = transfer_fit(&points, None).unwrap();
        assert!((s - 0.5).abs() < 1e-9 && (o - 3.0).abs() < 1e-6, "{s} {o}");
        let dark = TransferPoint {
            mean: 0.0,
            variance: 3.0,
        };
        let (s, o) = transfer_fit(&points, Some(dark)).unwrap();
        assert!((s - 0.5).abs() < 1e-9 && o == 3.0);
    }

    #[test]
    fn locus_cct_interpolates_in_mired() {
        let locus = Locus::fit(&[
            (2856.0, [2.0, 1.0, 0.4]),
            (4000.0, [1.5, 1.0, 0.6]),
            (6500.0, [1.0, 1.0, 0.9]),
        ])
        .unwrap();
        let r = chromaticity([1.5, 1.0, 0.6])[0];
        assert!((locus.cct_at(r) - 4000.0).abs() < 1e-6);
        let (on, d) = locus.project(chromaticity([1.5, 1.0, 0.6]));
        assert!(d.abs() < 1e-3, "{on:?} {d}");
    }
}

//! The ColorChecker 24 in a raw frame: its geometry, finding it, and sampling its patches.
//!
//! **Geometry.** Chart units put the patch pitch at 1: patch `i` (0 = dark skin, 18 = white,
//! 23 = black; row-major, 6 across) has its centre at `(i % 6 + 0.5, i / 6 + 0.5)` and a side
//! of [`PATCH_SIDE`]. The chart's *corners* are the outer corners of the four corner patches
//! (dark skin, bluish green, black, white: top left, top right, bottom right, bottom left as
//! the chart is read), the points `--chart` takes and detection returns, in pixel coordinates
//! where pixel `(x, y)` covers `[x, x + 1) x [y, y + 1)`. A homography maps chart units to
//! pixels, so a chart seen at an angle is sampled where it is.
//!
//! **Detection** ([`detect`]) works on the raw mosaic with no colour knowledge: 2x2
//! superpixels in log RGB, an edge map from neighbour differences (the threshold set from the
//! frame's own noise), connected flat regions, the square ones of a common size, their pitch
//! and angle from nearest neighbours, integer grid positions, the 6 x 4 window holding most
//! of them, a least-squares affine fit of the grid to their centroids, and of the two ways the
//! window can be read (the chart upright or upside down) the one whose bottom row is the
//! neutral series: equal in chromaticity, falling in brightness. Regions that touch (the black
//! patch on the chart's black border) are simply missing: the fit needs 12 of 24.

use isp_core::CfaPattern;

/// A patch's side in chart units (the pitch is 1): 0.86, leaving black gaps of 0.14 as the
/// X-Rite chart's 40 mm patches at a pitch of about 46.5 mm do.
pub const PATCH_SIDE: f64 = 0.86;

/// How far the black frame reaches beyond the patch grid's cells, chart units.
pub const BORDER: f64 = 0.45;

/// Patches across and down.
pub const COLUMNS: usize = 6;
/// Patch rows.
pub const ROWS: usize = 4;
/// The fraction of the range from black to white above which a sample counts as clipped.
pub const SATURATION: f64 = 0.97;

/// Patch count.
pub const PATCHES: usize = 24;

/// Indices of the neutral series, white to black.
pub const NEUTRALS: [usize; 6] = [18, 19, 20, 21, 22, 23];

/// The chart's four corners in chart units, in the order of [`Corners`].
pub fn corner_units() -> [[f64; 2]; 4] {
    let gap = (1.0 - PATCH_SIDE) / 2.0;
    let (x1, y1) = (COLUMNS as f64 - gap, ROWS as f64 - gap);
    [[gap, gap], [x1, gap], [x1, y1], [gap, y1]]
}

/// The four corners of a chart in pixels: top left (dark skin), top right (bluish green),
/// bottom right (black), bottom left (white).
pub type Corners = [[f64; 2]; 4];

/// A projective map from chart units to pixels.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ChartMap {
    h: [[f64; 3]; 3],
}

impl ChartMap {
    /// The homography taking [`corner_units`] to `corners`; `None` when the corners are
    /// degenerate (three on a line, or not finite).
    pub fn from_corners(corners: &Corners) -> Option<ChartMap> {
        if corners.iter().flatten().any(|v| !v.is_finite()) {
            return None;
        }
        let src = corner_units();
        // Eight equations a h = b for h11..h32 (h33 = 1).
        let mut a = [[0.0f64; 8]; 8];
        let mut b = [0.0f64; 8];
        for k in 0..4 {
            let ([u, v], [x, y]) = (src[k], corners[k]);
            a[2 * k] = [u, v, 1.0, 0.0, 0.0, 0.0, -u * x, -v * x];
            b[2 * k] = x;
            a[2 * k + 1] = [0.0, 0.0, 0.0, u, v, 1.0, -u * y, -v * y];
            b[2 * k + 1] = y;
        }
        let h = solve::<8>(a, b)?;
        let map = ChartMap {
            h: [[h[0], h[1], h[2]], [h[3], h[4], h[5]], [h[6], h[7], 1.0]],
        };
        // Degenerate when the quadrilateral folds: every patch centre must map with a
        // positive denominator and the corners' orientation must agree.
        let area = signed_area(corners);
        (area.abs() > 1.0 && (0..4).all(|k| map.denominator(src[k]) > 0.0)).then_some(map)
    }

    /// The affine map `x = a u + b v + c`, rows for x and y.
    pub fn affine(m: [[f64; 3]; 2]) -> ChartMap {
        ChartMap {
            h: [m[0], m[1], [0.0, 0.0, 1.0]],
        }
    }

    fn denominator(&self, [u, v]: [f64; 2]) -> f64 {
        self.h[2][0] * u + self.h[2][1] * v + self.h[2][2]
    }

    /// The pixel position of chart point `(u, v)`.
    pub fn apply(&self, [u, v]: [f64; 2]) -> [f64; 2] {
        let d = self.denominator([u, v]);
        let h = &self.h;
        [
            (h[0][0] * u + h[0][1] * v + h[0][2]) / d,
            (h[1][0] * u + h[1][1] * v + h[1][2]) / d,
        ]
    }

    /// The chart's corners in pixels.
    pub fn corners(&self) -> Corners {
        corner_units().map(|p| self.apply(p))
    }

    /// The centre of patch `i` in pixels.
    pub fn patch_centre(&self, i: usize) -> [f64; 2] {
        self.apply(patch_centre_units(i))
    }

    /// The pitch in pixels (mean of the chart's two side lengths over the grid).
    pub fn pitch_px(&self) -> f64 {
        let c = self.corners();
        let d = |a: [f64; 2], b: [f64; 2]| ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt();
        let span_x = COLUMNS as f64 - 1.0 + PATCH_SIDE;
        let span_y = ROWS as f64 - 1.0 + PATCH_SIDE;
        0.25 * ((d(c[0], c[1]) + d(c[3], c[2])) / span_x + (d(c[0], c[3]) + d(c[1], c[2])) / span_y)
    }
}

fn signed_area(c: &Corners) -> f64 {
    let mut a = 0.0;
    for k in 0..4 {
        let (p, q) = (c[k], c[(k + 1) % 4]);
        a += p[0] * q[1] - q[0] * p[1];
    }
    a / 2.0
}

/// Patch `i`'s centre in chart units.
pub fn patch_centre_units(i: usize) -> [f64; 2] {
    [(i % COLUMNS) as f64 + 0.5, (i / COLUMNS) as f64 + 0.5]
}

/// Gaussian elimination with partial pivoting; `None` when singular or not finite.
#[allow(clippy::needless_range_loop)] // matrix code reads best with indices
pub(crate) fn solve<const N: usize>(mut a: [[f64; N]; N], mut b: [f64; N]) -> Option<[f64; N]> {
    for col in 0..N {
        let pivot = (col..N).max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))?;
        if a[pivot][col].abs().partial_cmp(&1e-300) != Some(std::cmp::Ordering::Greater) {
            return None;
        }
        a.swap(col, pivot);
        b.swap(col, pivot);
        for row in col + 1..N {
            let f = a[row][col] / a[col][col];
            for k in col..N {
                a[row][k] -= f * a[col][k];
            }
            b[row] -= f * b[col];
        }
    }
    let mut x = [0.0; N];
    for row in (0..N).rev() {
        let s: f64 = (row + 1..N).map(|k| a[row][k] * x[k]).sum();
        x[row] = (b[row] - s) / a[row][row];
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// A raw frame as detection and sampling read it.
#[derive(Debug, Clone, Copy)]
pub struct Mosaic<'a> {
    /// Samples, row-major.
    pub samples: &'a [u16],
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// CFA pattern.
    pub pattern: CfaPattern,
    /// Black level per 2x2 position (row-major).
    pub black: [f64; 4],
    /// White level.
    pub white: f64,
}

impl<'a> Mosaic<'a> {
    /// A raw frame with the black level `black` (per 2x2 position).
    pub fn of(raw: &'a raw_formats::RawImage, black: [f64; 4]) -> Self {
        Mosaic {
            samples: &raw.samples,
            width: raw.width,
            height: raw.height,
            pattern: raw.pattern,
            black,
            white: f64::from(raw.white_level),
        }
    }

    /// The level from which a sample counts as clipped: 97 % of the way from black to white
    /// (sensors saturate a little below the white level: the full well, less the dark charge
    /// the clamp takes away, lands under it).
    pub fn saturation(&self, x: usize, y: usize) -> f64 {
        let black = self.black[(y % 2) * 2 + x % 2];
        black + SATURATION * (self.white - black)
    }

    fn value(&self, x: usize, y: usize) -> f64 {
        f64::from(self.samples[y * self.width + x]) - self.black[(y % 2) * 2 + x % 2]
    }
}

/// Why no chart was found.
#[derive(Debug, Clone, PartialEq)]
pub enum NotFound {
    /// The frame is smaller than 32 x 32 pixels.
    TooSmall,
    /// Fewer than 12 patch-like regions of one size in a 6 x 4 grid.
    TooFewPatches {
        /// How many were found in the best grid.
        found: usize,
    },
}

impl std::fmt::Display for NotFound {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            NotFound::TooSmall => write!(f, "the frame is too small for a chart (32 x 32 at least)"),
            NotFound::TooFewPatches { found } => write!(
                f,
                "no ColorChecker 24 found (best 6 x 4 grid had {found} of the 12 square patches it needs); \
                 give its corners with --chart x0,y0,x1,y1,x2,y2,x3,y3"
            ),
        }
    }
}

/// A flat region of the superpixel image.
#[derive(Debug, Clone, Copy)]
struct Region {
    area: f64,
    centre: [f64; 2],
    /// Eigenvalues of the second-moment matrix, larger first.
    spread: [f64; 2],
}

/// Finds a ColorChecker 24 in `mosaic`: its corners, or why not.
pub fn detect(mosaic: &Mosaic<'_>) -> Result<Corners, NotFound> {
    let (w, h) = (mosaic.width / 2, mosaic.height / 2);
    if w < 16 || h < 16 || mosaic.samples.len() < mosaic.width * mosaic.height {
        return Err(NotFound::TooSmall);
    }
    // Superpixels in log RGB, floored at 1/1000 of the range so black stays finite.
    let floor =
        (mosaic.white - mosaic.black.iter().fold(0.0f64, |a, &b| a.max(b))).max(1.0) / 1000.0;
    let mut log_rgb = vec![[0.0f64; 3]; w * h];
    for sy in 0..h {
        for sx in 0..w {
            let mut rgb = [0.0f64; 3];
            let mut n = [0.0f64; 3];
            for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                let (x, y) = (2 * sx + dx, 2 * sy + dy);
                let c = mosaic.pattern.colour_at(x, y).index();
                rgb[c] += mosaic.value(x, y);
                n[c] += 1.0;
            }
            log_rgb[sy * w + sx] = std::array::from_fn(|c| (rgb[c] / n[c]).max(floor).ln());
        }
    }
    // A 3x3 box blur takes the noise down by three before edges are judged.
    let blurred = box3(&log_rgb, w, h);
    // Neighbour differences; the threshold is six times their robust spread (most
    // differences are inside flat regions), at least 0.08 in log units.
    let diff = |i: usize, j: usize| -> f64 {
        (0..3)
            .map(|c| (blurred[i][c] - blurred[j][c]).abs())
            .fold(0.0, f64::max)
    };
    let mut sample = Vec::with_capacity(w * h / 4);
    for y in (0..h - 1).step_by(2) {
        for x in (0..w - 1).step_by(2) {
            sample.push(diff(y * w + x, y * w + x + 1));
        }
    }
    sample.sort_by(f64::total_cmp);
    let median = sample[sample.len() / 2];
    let threshold = (6.0 * 1.4826 * median).max(0.08);
    let mut edge = vec![false; w * h];
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            let right = x + 1 < w && diff(i, i + 1) > threshold;
            let down = y + 1 < h && diff(i, i + w) > threshold;
            let left = x > 0 && diff(i, i - 1) > threshold;
            let up = y > 0 && diff(i, i - w) > threshold;
            edge[i] = right || down || left || up;
        }
    }
    let regions = flat_regions(&edge, w, h);
    let squares: Vec<Region> = regions
        .into_iter()
        .filter(|r| {
            let [a, b] = r.spread;
            r.area >= 16.0
                && a <= 1.5 * b
                && (0.8..1.25).contains(&(r.area / (12.0 * (a * b).sqrt())))
        })
        .collect();
    let mut best: Option<(usize, ChartMap)> = None;
    // Each square of a common size proposes a grid; the best grid wins.
    let mut tried_sizes: Vec<f64> = Vec::new();
    for r in &squares {
        if tried_sizes.iter().any(|&a| (r.area / a - 1.0).abs() < 0.1) {
            continue;
        }
        tried_sizes.push(r.area);
        let same: Vec<&Region> = squares
            .iter()
            .filter(|q| (q.area / r.area - 1.0).abs() < 0.4)
            .collect();
        if same.len() < 12 {
            continue;
        }
        if let Some((count, map)) = fit_grid(&same) {
            if best.as_ref().is_none_or(|b| count > b.0) {
                best = Some((count, map));
            }
        }
    }
    let Some((count, map)) = best else {
        return Err(NotFound::TooFewPatches { found: 0 });
    };
    if count < 12 {
        return Err(NotFound::TooFewPatches { found: count });
    }
    // Superpixel coordinates (centre of superpixel i at i + 0.5) to pixels: times two.
    let corners = map.corners().map(|[x, y]| [2.0 * x, 2.0 * y]);
    let upright = orient(&corners, mosaic);
    Ok(upright)
}

fn box3(src: &[[f64; 3]], w: usize, h: usize) -> Vec<[f64; 3]> {
    let mut out = vec![[0.0f64; 3]; w * h];
    for y in 0..h {
        for x in 0..w {
            let mut s = [0.0f64; 3];
            let mut n = 0.0;
            for yy in y.saturating_sub(1)..(y + 2).min(h) {
                for xx in x.saturating_sub(1)..(x + 2).min(w) {
                    for c in 0..3 {
                        s[c] += src[yy * w + xx][c];
                    }
                    n += 1.0;
                }
            }
            out[y * w + x] = s.map(|v| v / n);
        }
    }
    out
}

/// 4-connected components of the non-edge superpixels, with their moments.
fn flat_regions(edge: &[bool], w: usize, h: usize) -> Vec<Region> {
    let mut label = vec![u32::MAX; w * h];
    let mut regions = Vec::new();
    let mut stack = Vec::new();
    for start in 0..w * h {
        if edge[start] || label[start] != u32::MAX {
            continue;
        }
        let id = regions.len() as u32;
        label[start] = id;
        stack.push(start);
        let (mut n, mut sx, mut sy, mut sxx, mut syy, mut sxy) = (0.0f64, 0.0, 0.0, 0.0, 0.0, 0.0);
        let mut touches_border = false;
        while let Some(i) = stack.pop() {
            let (x, y) = (i % w, i / w);
            let (fx, fy) = (x as f64 + 0.5, y as f64 + 0.5);
            n += 1.0;
            sx += fx;
            sy += fy;
            sxx += fx * fx;
            syy += fy * fy;
            sxy += fx * fy;
            touches_border |= x == 0 || y == 0 || x + 1 == w || y + 1 == h;
            let mut visit = |j: usize| {
                if !edge[j] && label[j] == u32::MAX {
                    label[j] = id;
                    stack.push(j);
                }
            };
            if x > 0 {
                visit(i - 1);
            }
            if x + 1 < w {
                visit(i + 1);
            }
            if y > 0 {
                visit(i - w);
            }
            if y + 1 < h {
                visit(i + w);
            }
        }
        let (mx, my) = (sx / n, sy / n);
        let (cxx, cyy, cxy) = (sxx / n - mx * mx, syy / n - my * my, sxy / n - mx * my);
        let tr = cxx + cyy;
        let det = cxx * cyy - cxy * cxy;
        let disc = (tr * tr / 4.0 - det).max(0.0).sqrt();
        let region = Region {
            area: n,
            centre: [mx, my],
            spread: [tr / 2.0 + disc, (tr / 2.0 - disc).max(1e-9)],
        };
        // A region cut by the frame's edge is not a whole patch.
        regions.push(if touches_border {
            Region {
                area: 0.0,
                ..region
            }
        } else {
            region
        });
    }
    regions
}

/// Fits the 6 x 4 grid to regions of one size: the number of its cells holding a region and
/// the map from chart units to superpixel coordinates (as found, possibly upside down).
fn fit_grid(regions: &[&Region]) -> Option<(usize, ChartMap)> {
    // Pitch and angle from each region's nearest neighbour.
    let mut distances = Vec::new();
    let (mut c4, mut s4) = (0.0f64, 0.0f64);
    for r in regions {
        let nearest = regions
            .iter()
            .filter(|q| !std::ptr::eq(**q, *r))
            .map(|q| [q.centre[0] - r.centre[0], q.centre[1] - r.centre[1]])
            .min_by(|a, b| (a[0].hypot(a[1])).total_cmp(&b[0].hypot(b[1])))?;
        let d = nearest[0].hypot(nearest[1]);
        distances.push(d);
        let angle = nearest[1].atan2(nearest[0]);
        c4 += (4.0 * angle).cos();
        s4 += (4.0 * angle).sin();
    }
    distances.sort_by(f64::total_cmp);
    let pitch = distances[distances.len() / 2];
    let theta = s4.atan2(c4) / 4.0;
    if pitch.is_nan() || pitch <= 2.0 {
        return None;
    }
    let (cos, sin) = (theta.cos(), theta.sin());
    let to_grid = |p: [f64; 2]| -> [f64; 2] {
        [
            (cos * p[0] + sin * p[1]) / pitch,
            (-sin * p[0] + cos * p[1]) / pitch,
        ]
    };
    let uv: Vec<[f64; 2]> = regions.iter().map(|r| to_grid(r.centre)).collect();
    // The grid's phase: the circular mean of the fractional parts.
    let phase = |k: usize| -> f64 {
        let (c, s) = uv.iter().fold((0.0, 0.0), |(c, s), p| {
            let a = std::f64::consts::TAU * p[k];
            (c + a.cos(), s + a.sin())
        });
        s.atan2(c) / std::f64::consts::TAU
    };
    let (pu, pv) = (phase(0), phase(1));
    let cells: Vec<Option<(i64, i64)>> = uv
        .iter()
        .map(|p| {
            let (fu, fv) = (p[0] - pu, p[1] - pv);
            let (iu, iv) = (fu.round(), fv.round());
            ((fu - iu).abs() < 0.25 && (fv - iv).abs() < 0.25).then_some((iu as i64, iv as i64))
        })
        .collect();
    let occupied: Vec<(i64, i64)> = cells.iter().flatten().copied().collect();
    if occupied.is_empty() {
        return None;
    }
    // The 6 x 4 window with the most occupied cells.
    let (min_u, max_u) = occupied
        .iter()
        .fold((i64::MAX, i64::MIN), |(a, b), c| (a.min(c.0), b.max(c.0)));
    let (min_v, max_v) = occupied
        .iter()
        .fold((i64::MAX, i64::MIN), |(a, b), c| (a.min(c.1), b.max(c.1)));
    let mut best = (0usize, 0i64, 0i64);
    for u0 in min_u - 5..=max_u {
        for v0 in min_v - 3..=max_v {
            let mut seen = [false; PATCHES];
            for &(u, v) in &occupied {
                if (u0..u0 + 6).contains(&u) && (v0..v0 + 4).contains(&v) {
                    seen[((v - v0) * 6 + (u - u0)) as usize] = true;
                }
            }
            let count = seen.iter().filter(|s| **s).count();
            if count > best.0 {
                best = (count, u0, v0);
            }
        }
    }
    let (count, u0, v0) = best;
    // Least squares: centre = A (col + 0.5, row + 0.5, 1).
    let mut gram = [[0.0f64; 3]; 3];
    let mut cross = [[0.0f64; 3]; 2];
    let mut used = 0;
    for (r, cell) in regions.iter().zip(&cells) {
        let Some((u, v)) = *cell else { continue };
        if !((u0..u0 + 6).contains(&u) && (v0..v0 + 4).contains(&v)) {
            continue;
        }
        let t = [(u - u0) as f64 + 0.5, (v - v0) as f64 + 0.5, 1.0];
        for i in 0..3 {
            for j in 0..3 {
                gram[i][j] += t[i] * t[j];
            }
            cross[0][i] += r.centre[0] * t[i];
            cross[1][i] += r.centre[1] * t[i];
        }
        used += 1;
    }
    if used < 3 {
        return None;
    }
    let ax = solve::<3>(gram, cross[0])?;
    let ay = solve::<3>(gram, cross[1])?;
    Some((count, ChartMap::affine([ax, ay])))
}

/// Of the found corners and the same read upside down, the reading whose bottom row is the
/// neutral series: the least spread in log chromaticity over the five brighter greys, with
/// brightness falling along it.
fn orient(corners: &Corners, mosaic: &Mosaic<'_>) -> Corners {
    let flipped = [corners[2], corners[3], corners[0], corners[1]];
    let score = |c: &Corners| -> f64 {
        let Some(map) = ChartMap::from_corners(c) else {
            return f64::INFINITY;
        };
        let patches = sample_patches(mosaic, &map, 0.25);
        let greys: Vec<[f64; 3]> = NEUTRALS[..5].iter().map(|&i| patches[i].mean).collect();
        let chroma = |k: usize| -> Vec<f64> {
            greys
                .iter()
                .map(|g| (g[k].max(1e-6) / g[1].max(1e-6)).ln())
                .collect()
        };
        let spread = |v: Vec<f64>| {
            let m = v.iter().sum::<f64>() / v.len() as f64;
            v.iter().map(|x| (x - m).powi(2)).sum::<f64>()
        };
        let falling = greys.windows(2).filter(|p| p[1][1] > p[0][1]).count() as f64;
        spread(chroma(0)) + spread(chroma(2)) + falling
    };
    if score(&flipped) < score(corners) {
        flipped
    } else {
        *corners
    }
}

/// One patch sampled from a raw frame: per colour mean (black subtracted, in DN), the count
/// of samples per colour, and how many were at the white level.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PatchSample {
    /// Mean per colour (R, G, B), black subtracted, DN.
    pub mean: [f64; 3],
    /// Variance per colour of the samples, DN^2 (noise plus fixed pattern).
    pub variance: [f64; 3],
    /// Samples per colour.
    pub count: [usize; 3],
    /// Samples at or above saturation ([`Mosaic::saturation`]).
    pub clipped: usize,
}

/// Samples each patch's inner square (half-side `half` in chart units) through `map`, with
/// no gain.
pub fn sample_patches(mosaic: &Mosaic<'_>, map: &ChartMap, half: f64) -> Vec<PatchSample> {
    sample_patches_corrected(mosaic, map, half, &|_, _, _| 1.0)
}

/// [`sample_patches`] with `gain(x, y, colour)` applied to each sample (lens shading
/// correction); samples whose gain is not finite (defects) are left out.
pub fn sample_patches_corrected(
    mosaic: &Mosaic<'_>,
    map: &ChartMap,
    half: f64,
    gain: &dyn Fn(usize, usize, usize) -> f64,
) -> Vec<PatchSample> {
    (0..PATCHES)
        .map(|i| {
            let [cu, cv] = patch_centre_units(i);
            let quad = [
                map.apply([cu - half, cv - half]),
                map.apply([cu + half, cv - half]),
                map.apply([cu + half, cv + half]),
                map.apply([cu - half, cv + half]),
            ];
            let x0 = quad
                .iter()
                .map(|p| p[0])
                .fold(f64::INFINITY, f64::min)
                .floor()
                .max(0.0) as usize;
            let x1 = (quad
                .iter()
                .map(|p| p[0])
                .fold(f64::NEG_INFINITY, f64::max)
                .ceil()
                .max(0.0) as usize)
                .min(mosaic.width);
            let y0 = quad
                .iter()
                .map(|p| p[1])
                .fold(f64::INFINITY, f64::min)
                .floor()
                .max(0.0) as usize;
            let y1 = (quad
                .iter()
                .map(|p| p[1])
                .fold(f64::NEG_INFINITY, f64::max)
                .ceil()
                .max(0.0) as usize)
                .min(mosaic.height);
            let (mut s, mut s2, mut n) = ([0.0f64; 3], [0.0f64; 3], [0usize; 3]);
            let mut clipped = 0;
            for y in y0..y1 {
                for x in x0..x1 {
                    if !inside(&quad, [x as f64 + 0.5, y as f64 + 0.5]) {
                        continue;
                    }
                    let c = mosaic.pattern.colour_at(x, y).index();
                    let g = gain(x, y, c);
                    if !g.is_finite() {
                        continue; // a defect
                    }
                    let raw = mosaic.samples[y * mosaic.width + x];
                    if f64::from(raw) >= mosaic.saturation(x, y) {
                        clipped += 1;
                    }
                    let v = mosaic.value(x, y) * g;
                    s[c] += v;
                    s2[c] += v * v;
                    n[c] += 1;
                }
            }
            let mean: [f64; 3] = std::array::from_fn(|c| s[c] / n[c].max(1) as f64);
            PatchSample {
                mean,
                variance: std::array::from_fn(|c| {
                    if n[c] > 1 {
                        (s2[c] - s[c] * mean[c]) / (n[c] - 1) as f64
                    } else {
                        0.0
                    }
                }),
                count: n,
                clipped,
            }
        })
        .collect()
}

/// Whether `p` is inside the convex quadrilateral `q` (either orientation).
fn inside(q: &[[f64; 2]; 4], p: [f64; 2]) -> bool {
    let mut sign = 0.0f64;
    for k in 0..4 {
        let (a, b) = (q[k], q[(k + 1) % 4]);
        let cross = (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0]);
        if cross != 0.0 {
            if sign != 0.0 && cross.signum() != sign {
                return false;
            }
            sign = cross.signum();
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn homography_maps_corners_and_centres() {
        let corners = [[100.0, 50.0], [700.0, 80.0], [680.0, 480.0], [90.0, 450.0]];
        let map = ChartMap::from_corners(&corners).expect("a proper quadrilateral");
        for (got, want) in map.corners().iter().zip(&corners) {
            assert!((got[0] - want[0]).abs() < 1e-6 && (got[1] - want[1]).abs() < 1e-6);
        }
        // Degenerate corners are refused, never a panic.
        assert!(ChartMap::from_corners(&[[0.0, 0.0]; 4]).is_none());
        assert!(ChartMap::from_corners(&[[f64::NAN, 0.0]; 4]).is_none());
    }
}

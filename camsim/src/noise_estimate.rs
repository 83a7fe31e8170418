//! A raw frame's noise profile estimated from the frame itself, for raws whose file states none.
//!
//! The approach is Foi, Trimeche, Katkovnik and Egiazarian's ("Practical Poissonian-Gaussian
//! noise modeling and fitting for single-image raw-data", IEEE Trans. Image Processing 17(10),
//! 2008): measure the noise variance in sets of the frame's areas of similar signal level, and
//! fit `var = S x + O` to those (level, variance) points. How each set's variance is measured
//! is this module's own, chosen for texture, which any single-image estimate mistakes for
//! noise:
//!
//! 1. **A fine high-pass.** Around every other non-green site the four green neighbours N, S,
//!    E, W form a diamond whose detail `(N + S - E - W) / 2` has the noise's variance, no
//!    response to a linear gradient, and, being a second difference at a one-pixel step, the
//!    least of the image's structure a CFA allows (a lens passes little at that frequency).
//!    The diamonds share no pixel and cover every green once. Cells of 16 diamonds (16x8
//!    pixels) give a level and a variance; a cell with a sample at white or at 0 is clipped and
//!    left out.
//! 2. **Level sets and a low quantile.** Cells are sorted by level and split into sets of
//!    128. Texture only adds to a cell's variance, so a set's noise is its 5 %
//!    quantile of cell variances over that quantile's ratio to the mean on a flat cell
//!    (chi-square with 16 degrees of freedom; Wilson and Hilferty's approximation). Each cell's
//!    variance is taken relative to the model at its own level (from the previous fit), so the
//!    spread of levels within a set does not bias the quantile. Sets whose noise reaches white
//!    are dropped once a model says so.
//! 3. **A one-sided fit.** Least squares weighted by `count / model^2`, `S, O >= 0`; a set
//!    more than 35 % above the line is taken for texture and left out, and the line refitted.
//!
//! The profile is the same for every colour: the greens are sampled twice as densely, and the
//! colours of one sensor share its conversion gain and read noise. Row and column noise cancel
//! in the diamond detail only partly. `O` is seen only where the frame has areas dark enough
//! for it to matter beside `S x`. What the estimate is worth, measured on Kodak and McMaster
//! raws of known noise, is in `tests/tests/noise_estimate.rs`: within 25 % where the noise
//! stands above the image's fine structure, and an overestimate of `S` for faint noise over
//! strong texture.

use isp_core::frame::RawFrame;
use isp_core::noise::NoiseProfile;
use isp_core::CfaColour;

use crate::error::Error;

/// A cell holds `CELL^2` = 16 diamond details (16x8 raw pixels): the degrees of freedom of
/// its variance.
const CELL: usize = 4;
/// Cells in each level set.
const PER_SET: usize = 128;
/// Fewest level sets a colour needs for a fit.
const MIN_SETS: usize = 3;
/// The quantile of a level set's cell variances taken as its noise: texture only adds to a
/// cell's variance, so a low quantile reads the set's flattest cells.
const QUANTILE: f64 = 0.05;
/// The standard normal's [`QUANTILE`] quantile.
const QUANTILE_Z: f64 = -1.644_854;

/// What [`estimate`] found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NoiseEstimate {
    /// The fitted profile.
    pub profile: NoiseProfile,
    /// Level sets fitted.
    pub sets: usize,
    /// How much wider than noise alone the level sets' cell variances spread: the median over
    /// the sets of the ratio of the median to the 5 % quantile of the cells' variances
    /// relative to the fitted model, over that ratio for pure noise (chi-square with 16
    /// degrees of freedom, about 1.93). About 1 where the cells are noise; texture spreads
    /// them, and the low quantile then still holds texture.
    pub texture_spread: f64,
}

/// A [`NoiseEstimate::texture_spread`] above this is outside the estimate's domain: the
/// frame's fine texture stands above its noise, and `S` is overestimated. Measured on Kodak
/// and McMaster raws (`tests/tests/noise_estimate.rs`): every case where the estimate holds
/// within 25 % spreads less, every overestimate of `S` by more than double spreads more.
pub const TEXTURE_SPREAD_LIMIT: f64 = 1.1;

/// The default noise-reduction strength where the estimate is not confident. Distances are
/// taken in units of the estimated variance, so an estimate `k` times too high acts as a
/// strength `sqrt(k)` times too high; 0.5 undoes up to `k = 4`, and the worst overestimate
/// measured outside the domain is 2.9x, so the default never smooths more than the true
/// profile's default would.
pub const LOW_CONFIDENCE_STRENGTH: f32 = 0.5;

impl NoiseEstimate {
    /// Whether the estimate is within its domain (noise above the image's fine texture).
    pub fn confident(&self) -> bool {
        self.texture_spread <= TEXTURE_SPREAD_LIMIT
    }

    /// The noise-reduction strength to default to: 1 where the estimate is confident, else
    /// [`LOW_CONFIDENCE_STRENGTH`] (texture read as noise would otherwise be smoothed away).
    pub fn default_strength(&self) -> f32 {
        if self.confident() {
            1.0
        } else {
            LOW_CONFIDENCE_STRENGTH
        }
    }
}

/// One cell: its mean signal and detail variance, in units of the white level above black.
#[derive(Clone, Copy)]
struct Cell {
    level: f64,
    variance: f64,
}

/// Estimates the noise profile of `raw` (its pattern, per-position black levels and white
/// level as the pipeline will develop it). The same profile for every colour (see the module
/// docs). Fails when the frame has too few unclipped cells for three level sets (a frame under
/// about 200x200 pixels, or one clipped throughout).
pub fn estimate(raw: &RawFrame<'_>) -> Result<NoiseEstimate, Error> {
    let mut cells = green_cells(raw);
    let Some(((s, o), sets, texture_spread)) = fit_cells(&mut cells) else {
        return Err(Error::NoiseEstimate {
            reason: "too few unclipped areas for three level sets (a frame too small, or clipped throughout)",
        });
    };
    // A fit of exactly zero noise (a synthetic frame without any) has no profile; keep the
    // quantisation floor of the range instead.
    let range = f64::from(raw.white_level() - raw.black_at(0, 0));
    let offset = (o as f32).max((1.0 / (12.0 * range * range)) as f32);
    let profile = NoiseProfile::uniform(s as f32, offset).map_err(|_| Error::NoiseEstimate {
        reason: "the fit is outside a noise profile's range (noise as large as the signal)",
    })?;
    Ok(NoiseEstimate {
        profile,
        sets,
        texture_spread,
    })
}

/// The unclipped cells of the green quincunx. Around every other non-green site (those of the
/// 2x2 block's first non-green position `(px, py)` whose block indices sum to an even number),
/// the four green neighbours N, S, E, W form a diamond whose detail `(N + S - E - W) / 2`
/// has the noise's variance and no response to a linear gradient: a second difference at a
/// one-pixel step, so little of the image's structure. These diamonds share no pixel and
/// cover every green once. A cell is the 16 diamonds of a 16x8-pixel area.
fn green_cells(raw: &RawFrame<'_>) -> Vec<Cell> {
    let mosaic = raw.mosaic();
    let pattern = mosaic.pattern();
    let Some(site) = (0..4).find(|p| pattern.colour_at(p % 2, p / 2) != CfaColour::Green) else {
        return Vec::new();
    };
    let (px, py) = (site % 2, site / 2);
    let white = raw.white_level();
    // A sample at white or at 0 is clipped (and one outside the frame, which no cell reads,
    // would read as 0).
    let sample = |x: usize, y: usize| mosaic.get(x, y).filter(|s| *s < white && *s > 0);
    let unit = |x: usize, y: usize, s: u16| {
        let b = raw.black_at(x, y);
        (f64::from(s) - f64::from(b)) / f64::from(white - b)
    };
    // A cell: raw columns 16u + 2..16u + 18 and rows 8v + 2..8v + 10 (a margin of 2 keeps every
    // diamond inside the frame), the diamonds at its sites of position (px, py) with block
    // indices of even sum.
    let mut out = Vec::new();
    let cells_w = mosaic.width().saturating_sub(4) / 16;
    let cells_h = mosaic.height().saturating_sub(4) / 8;
    for cv in 0..cells_h {
        'cell: for cu in 0..cells_w {
            let (mut detail2, mut sum, mut n) = (0.0, 0.0, 0usize);
            for by in 0..4 {
                for bx in 0..8 {
                    let (x, y) = (16 * cu + 2 + 2 * bx + px, 8 * cv + 2 + 2 * by + py);
                    if (x / 2 + y / 2) % 2 == 1 {
                        continue;
                    }
                    let mut around = [0.0; 4];
                    for (v, (x, y)) in
                        around
                            .iter_mut()
                            .zip([(x, y - 1), (x, y + 1), (x + 1, y), (x - 1, y)])
                    {
                        let Some(s) = sample(x, y) else {
                            continue 'cell;
                        };
                        *v = unit(x, y, s);
                    }
                    let [n_, s_, e_, w_] = around;
                    let d = (n_ + s_ - e_ - w_) / 2.0;
                    detail2 += d * d;
                    sum += n_ + s_ + e_ + w_;
                    n += 1;
                }
            }
            out.push(Cell {
                level: sum / (4 * n) as f64,
                variance: detail2 / n as f64,
            });
        }
    }
    out
}

/// `(S, O)` from the green cells: sorted by level and split into level sets of
/// [`PER_SET`]; each set's noise is its [`QUANTILE`] cell variance over that quantile's
/// expected ratio to the mean on a flat cell (chi-square with `CELL^2` degrees of freedom over
/// its mean, by Wilson and Hilferty's cube-root approximation). A set spans a range of levels,
/// and with them of variances, so each cell's variance is taken relative to the model at its
/// own level: the model from the sets' plain means first, then from the previous fit. `None`
/// with fewer than [`MIN_SETS`] sets. Also the texture spread (see
/// [`NoiseEstimate::texture_spread`]) under the final fit.
fn fit_cells(cells: &mut [Cell]) -> Option<((f64, f64), usize, f64)> {
    let k = (CELL * CELL) as f64;
    let a = 2.0 / (9.0 * k);
    let ratio = (1.0 - a + QUANTILE_Z * a.sqrt()).powi(3);
    cells.sort_by(|a, b| a.level.total_cmp(&b.level));
    let sets: Vec<&[Cell]> = cells
        .chunks(PER_SET)
        .filter(|set| set.len() >= PER_SET / 2)
        .collect();
    if sets.len() < MIN_SETS {
        return None;
    }
    let mean =
        |set: &[Cell], f: &dyn Fn(&Cell) -> f64| set.iter().map(f).sum::<f64>() / set.len() as f64;
    let points: Vec<_> = sets
        .iter()
        .map(|set| {
            let n = set.len() as f64;
            (mean(set, &|c| c.level), mean(set, &|c| c.variance), n)
        })
        .collect();
    let mut line = fit(&points);
    for pass in 0..4 {
        let (s, o) = line;
        let model = |x: f64| (s * x + o).max(1e-12);
        let points: Vec<_> = sets
            .iter()
            // A set whose noise reaches white has lost its brightest samples' cells (those
            // with a clipped sample are left out), so its variance reads low.
            // The first model, from plain means, is inflated by texture: not yet.
            .filter(|set| {
                let top = set.last().map_or(1.0, |c| c.level);
                pass == 0 || top + 3.0 * model(top).sqrt() < 1.0
            })
            .map(|set| {
                let mut relative: Vec<f64> =
                    set.iter().map(|c| c.variance / model(c.level)).collect();
                let q = (relative.len() as f64 * QUANTILE) as usize;
                let low = *relative.select_nth_unstable_by(q, f64::total_cmp).1;
                let level = mean(set, &|c| c.level);
                (level, low / ratio * model(level), set.len() as f64)
            })
            .collect();
        if points.len() < MIN_SETS {
            break; // too few below the clip: keep the fit of every set
        }
        line = fit(&points);
    }
    let (s, o) = line;
    let model = |x: f64| (s * x + o).max(1e-12);
    let quantile = |z: f64| (1.0 - a + z * a.sqrt()).powi(3);
    let flat_spread = quantile(0.0) / ratio;
    let mut spreads: Vec<f64> = sets
        .iter()
        .map(|set| {
            let mut relative: Vec<f64> = set.iter().map(|c| c.variance / model(c.level)).collect();
            let n = relative.len();
            let low = *relative
                .select_nth_unstable_by((n as f64 * QUANTILE) as usize, f64::total_cmp)
                .1;
            let middle = *relative.select_nth_unstable_by(n / 2, f64::total_cmp).1;
            middle / low.max(1e-30) / flat_spread
        })
        .collect();
    let middle = spreads.len() / 2;
    let spread = *spreads.select_nth_unstable_by(middle, f64::total_cmp).1;
    Some((line, sets.len(), spread))
}

/// `(S, O)`, both at least 0, fitted to `(level, variance, count)` points by least squares
/// with weights `count / variance^2` (a variance estimate's spread is proportional to its
/// value), the variance taken from the model after a first pass on the measured values.
/// Texture only ever adds to a set's variance, so the fit is one-sided: a point more than
/// [`TEXTURED`] above the line is taken for a textured set and left out, and the line fitted
/// again, while at least [`MIN_SETS`] points remain.
fn fit(points: &[(f64, f64, f64)]) -> (f64, f64) {
    let mut used: Vec<bool> = vec![true; points.len()];
    let mut line = weighted_fit(points, &used);
    for _ in 0..points.len() {
        let (s, o) = line;
        let worst = points
            .iter()
            .enumerate()
            .filter(|(i, _)| used[*i])
            .map(|(i, &(x, v, _))| (i, v / (s * x + o).max(1e-30) - 1.0))
            .max_by(|a, b| a.1.total_cmp(&b.1));
        match worst {
            Some((i, excess))
                if excess > TEXTURED && used.iter().filter(|u| **u).count() > MIN_SETS =>
            {
                used[i] = false;
                line = weighted_fit(points, &used);
            }
            _ => break,
        }
    }
    line
}

/// A level set's variance this far (relative) above the fitted line is taken for texture.
const TEXTURED: f64 = 0.35;

/// The weighted least-squares line through the `used` points, iterated on the model's weights.
fn weighted_fit(points: &[(f64, f64, f64)], used: &[bool]) -> (f64, f64) {
    let solve = |weight: &dyn Fn(f64, f64) -> f64| {
        let (mut sw, mut sx, mut sy, mut sxx, mut sxy) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for (&(x, v, n), _) in points.iter().zip(used).filter(|(_, u)| **u) {
            let w = weight(x, v) * n;
            sw += w;
            sx += w * x;
            sy += w * v;
            sxx += w * x * x;
            sxy += w * x * v;
        }
        let det = sw * sxx - sx * sx;
        let s = if det > 0.0 {
            (sw * sxy - sx * sy) / det
        } else {
            0.0
        };
        let o = (sy - s * sx) / sw;
        if o < 0.0 {
            // Through the origin: the best S with O = 0.
            ((sxy / sxx).max(0.0), 0.0)
        } else if s < 0.0 {
            (0.0, sy / sw)
        } else {
            (s, o)
        }
    };
    let (mut s, mut o) = solve(&|_, v| 1.0 / (v * v).max(1e-30));
    for _ in 0..3 {
        (s, o) = solve(&|x, _| 1.0 / (s * x + o).powi(2).max(1e-30));
    }
    (s, o)
}

#[cfg(test)]
mod tests {
    use super::*;
    use isp_core::CfaPattern;

    #[test]
    fn the_weighted_fit_recovers_a_line() {
        let points: Vec<_> = (1..20)
            .map(|i| {
                let x = i as f64 / 20.0;
                (x, 0.003 * x + 2e-5, 40.0)
            })
            .collect();
        let (s, o) = fit(&points);
        assert!(
            (s - 0.003).abs() < 1e-9 && (o - 2e-5).abs() < 1e-11,
            "{s} {o}"
        );
        // A line with a negative offset is refitted through the origin.
        let points: Vec<_> = points.iter().map(|p| (p.0, p.1 - 4e-5, p.2)).collect();
        let (s, o) = fit(&points);
        assert!(s > 0.0 && o == 0.0);
    }

    /// On a smooth frame (a ramp in x, a gentle wave in y) of known Poisson-Gaussian noise
    /// the estimate is within 10 % of the truth.
    #[test]
    fn a_smooth_frame_gives_its_profile() {
        use host_tracer::random::Rng;
        use host_tracer::sensor::pixel;
        let (w, h) = (512, 384);
        for (scale, offset) in [(0.0008, 6e-7), (0.0032, 1.2e-5), (0.0128, 2.5e-4)] {
            let mut rng = Rng::new(3, 9);
            let raw: Vec<u16> = (0..w * h)
                .map(|i| {
                    let (x, y) = ((i % w) as f64 / w as f64, (i / w) as f64 / h as f64);
                    let truth = 0.9 * x * x * x * (0.8 + 0.2 * (6.0 * y).sin());
                    let noisy = scale * pixel::poisson(&mut rng, truth / scale)
                        + f64::sqrt(offset) * pixel::normal(&mut rng);
                    (256.0 + noisy * 3839.0).round().clamp(0.0, 4095.0) as u16
                })
                .collect();
            let frame = RawFrame::new(&raw, w, h, w, 12, CfaPattern::Rggb, [256; 4], 4095).unwrap();
            let e = estimate(&frame).unwrap();
            for c in 0..3 {
                let (s, o) = (e.profile.scale()[c] as f64, e.profile.offset()[c] as f64);
                assert!(
                    (s / scale - 1.0).abs() < 0.1 && (o / offset - 1.0).abs() < 0.1,
                    "S {scale} O {offset}: estimated S {s} O {o}"
                );
            }
        }
    }

    #[test]
    fn a_small_or_mismatched_frame_is_refused() {
        let small = vec![300u16; 40 * 40];
        let frame = |w, black| RawFrame::new(&small, w, 40, w, 12, CfaPattern::Rggb, black, 4095);
        assert!(estimate(&frame(40, [256; 4]).unwrap()).is_err());
        // A mismatched size or levels cannot reach the estimate: the frame refuses them.
        assert!(frame(41, [256; 4]).is_err());
        assert!(frame(40, [4095; 4]).is_err());
    }
}

//! Noise reduction: a 3x3 joint bilateral filter on linear RGB after demosaicing, small enough
//! for firmware (three line buffers, no transcendental functions).
//!
//! Each neighbour `n` of pixel `p` (reflect-101 at the frame edges) gets the weight
//! `s_n * max(0, 1 - D / T)` with spatial weights `s` = `[1 2 1; 2 4 2; 1 2 1]`, the colour
//! distance `D = |R_n - R_p| + |G_n - G_p| + |B_n - B_p|` and the strength `T` (linear units,
//! `0..=1`): neighbours that differ by `T` or more are ignored, so edges survive while noise
//! smaller than `T` is averaged away. One weight for all three channels keeps colours together.
//! The output is `sum(w x) / sum(w)`; the centre always has weight 4. Strength 0 skips the
//! stage, an exact identity.
//!
//! The float path computes exactly this. The fixed path works on `u16` (65535 is 1.0), range
//! weights in Q12 (`4096 - D * (4096 / T)`, truncated) and rounds the division to nearest.

use crate::demosaic::reflect;

/// Spatial weights, row by row.
const SPATIAL: [[u32; 3]; 3] = [[1, 2, 1], [2, 4, 2], [1, 2, 1]];

/// Columns of the 3x3 window around `x` in a row `w` wide, reflected at the edges.
#[inline]
fn columns(x: usize, w: usize) -> [usize; 3] {
    [reflect(x as isize - 1, w), x, reflect(x as isize + 1, w)]
}

/// Filters pixel `x` of the middle row of `rows` (interleaved RGB, rows above, at and below,
/// already reflected) with strength `strength` in `(0, 1]`: the float reference.
pub fn pixel_f32(rows: [&[f32]; 3], x: usize, strength: f32) -> [f32; 3] {
    let w = rows[1].len() / 3;
    let cols = columns(x, w);
    let centre = [rows[1][3 * x], rows[1][3 * x + 1], rows[1][3 * x + 2]];
    let mut sum = [0.0f32; 3];
    let mut weight = 0.0f32;
    for (r, srow) in rows.iter().zip(SPATIAL) {
        for (&c, s) in cols.iter().zip(srow) {
            let n = [r[3 * c], r[3 * c + 1], r[3 * c + 2]];
            let d = (n[0] - centre[0]).abs() + (n[1] - centre[1]).abs() + (n[2] - centre[2]).abs();
            let range = 1.0 - d / strength;
            if range > 0.0 {
                let wgt = s as f32 * range;
                weight += wgt;
                for k in 0..3 {
                    sum[k] += wgt * n[k];
                }
            }
        }
    }
    sum.map(|v| (v / weight).clamp(0.0, 1.0))
}

/// Reciprocal of a strength for [`pixel_u16`]: `round(4096 * 65536 / T)` with `T` in `u16`
/// units (at least 1).
pub fn inverse_strength_q16(strength: f32) -> u64 {
    let t = (strength * 65535.0 + 0.5).max(1.0) as u64;
    ((4096u64 << 16) + t / 2) / t
}

/// Filters pixel `x` of the middle row of `rows` (interleaved `u16` RGB) with the strength given
/// as [`inverse_strength_q16`]: the fixed-point path.
pub fn pixel_u16(rows: [&[u16]; 3], x: usize, inverse_strength: u64) -> [u16; 3] {
    let w = rows[1].len() / 3;
    let cols = columns(x, w);
    let centre = [rows[1][3 * x], rows[1][3 * x + 1], rows[1][3 * x + 2]];
    let mut sum = [0u64; 3];
    let mut weight = 0u64;
    for (r, srow) in rows.iter().zip(SPATIAL) {
        for (&c, s) in cols.iter().zip(srow) {
            let n = [r[3 * c], r[3 * c + 1], r[3 * c + 2]];
            let d = n[0].abs_diff(centre[0]) as u64
                + n[1].abs_diff(centre[1]) as u64
                + n[2].abs_diff(centre[2]) as u64;
            let penalty = (d * inverse_strength) >> 16;
            if penalty < 4096 {
                let wgt = s as u64 * (4096 - penalty);
                weight += wgt;
                for k in 0..3 {
                    sum[k] += wgt * n[k] as u64;
                }
            }
        }
    }
    sum.map(|v| ((v + weight / 2) / weight).min(65535) as u16)
}

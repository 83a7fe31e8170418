//! Image-quality figures, in one place for every test, benchmark and report: PSNR, CPSNR over
//! an image's interior, the angular error of a white-balance estimate, and the mean and largest
//! of a list (for per-patch CIE 2000 errors from [`crate::colour::delta_e_2000`]). All `f64`,
//! heap-free, so firmware tests can use them too.
//!
//! ```
//! use isp_core::metrics::{angular_error_deg, mean_max, psnr};
//! assert_eq!(psnr(&[10, 20], &[10, 20], 255.0), f64::INFINITY);
//! assert!((psnr(&[0, 0], &[1, 1], 255.0) - 48.13).abs() < 0.01);
//! assert!((angular_error_deg([1.0, 0.0, 0.0], [0.0, 1.0, 0.0]) - 90.0).abs() < 1e-9);
//! assert_eq!(mean_max(&[1.0, 3.0]), (2.0, 3.0));
//! ```

use crate::math;

fn psnr_of(squared_error: f64, count: usize, peak: f64) -> f64 {
    if squared_error == 0.0 {
        return f64::INFINITY;
    }
    let mse = squared_error / count.max(1) as f64;
    10.0 * math::log10(peak * peak / mse)
}

/// PSNR in dB of `a` against `b` (same length, samples in `0..=peak`): `10 log10(peak^2 /
/// MSE)`; infinite when they are equal. Extra samples of the longer slice are ignored.
pub fn psnr(a: &[u16], b: &[u16], peak: f64) -> f64 {
    let se: f64 = a
        .iter()
        .zip(b)
        .map(|(x, y)| {
            let d = *x as f64 - *y as f64;
            d * d
        })
        .sum();
    psnr_of(se, a.len().min(b.len()), peak)
}

/// CPSNR in dB of `out` against `truth` (both interleaved RGB of `width` x `height`, samples in
/// `0..=peak`) over the image minus a `border`-pixel frame: one MSE over all three channels, as
/// demosaicing papers report it. Infinite when equal; a border that leaves nothing gives NaN.
pub fn cpsnr(
    out: &[u16],
    truth: &[u16],
    width: usize,
    height: usize,
    border: usize,
    peak: f64,
) -> f64 {
    let mut se = 0.0;
    let mut n = 0usize;
    for y in border..height.saturating_sub(border) {
        for x in border..width.saturating_sub(border) {
            for c in 0..3 {
                let i = 3 * (y * width + x) + c;
                let (Some(o), Some(t)) = (out.get(i), truth.get(i)) else {
                    continue;
                };
                let d = *o as f64 - *t as f64;
                se += d * d;
                n += 1;
            }
        }
    }
    if n == 0 {
        return f64::NAN;
    }
    psnr_of(se, n, peak)
}

/// The angle in degrees between two colours (say an AWB's neutral and the true illuminant's,
/// both in camera RGB): the standard white-balance error, blind to brightness.
pub fn angular_error_deg(a: [f64; 3], b: [f64; 3]) -> f64 {
    let dot: f64 = (0..3).map(|i| a[i] * b[i]).sum();
    let na = math::sqrt(a.iter().map(|v| v * v).sum::<f64>());
    let nb = math::sqrt(b.iter().map(|v| v * v).sum::<f64>());
    math::acos((dot / (na * nb)).clamp(-1.0, 1.0)).to_degrees()
}

/// Mean and largest value of a list (0 and 0 for an empty one).
pub fn mean_max(values: &[f64]) -> (f64, f64) {
    let mean = values.iter().sum::<f64>() / values.len().max(1) as f64;
    (mean, values.iter().copied().fold(0.0, f64::max))
}

//! The noise profile estimated from a raw frame (`camsim::noise_estimate`, Foi et al. 2008)
//! against the truth: Kodak and McMaster images as 12-bit RGGB raws with Poisson-Gaussian noise
//! of known `S` and `O`, at three noise levels and three exposures.

use camsim::noise_estimate::estimate;
use camsim_tests::dataset;
use host_tracer::random::Rng;
use host_tracer::sensor::pixel;
use isp_core::frame::RawFrame;
use isp_core::CfaPattern;
use raw_formats::image as imageio;

const BLACK: u16 = 256;
const WHITE: u16 = 4095;

/// The unprocessing paper's read-against-shot fit (Brooks et al. 2019): `log O = 2.18 log S +
/// 1.2`.
fn offset_for(scale: f64) -> f64 {
    (2.18 * scale.ln() + 1.2).exp()
}

/// A 12-bit RGGB raw of an 8-bit RGB image at `exposure` (255 is `exposure` of white), with
/// noise `S * Poisson(x / S) + sqrt(O) N(0, 1)`.
fn noisy_raw(rgb: &Blurred, exposure: f64, scale: f64, seed: u64) -> Vec<u16> {
    let mut rng = Rng::new(seed, 0x4015e);
    let range = f64::from(WHITE - BLACK);
    let offset = offset_for(scale);
    (0..rgb.height)
        .flat_map(|y| (0..rgb.width).map(move |x| (x, y)))
        .map(|(x, y)| {
            let c = CfaPattern::Rggb.colour_at(x, y).index();
            let truth = rgb.data[3 * (y * rgb.width + x) + c] / 255.0 * exposure;
            let noisy = scale * pixel::poisson(&mut rng, truth / scale)
                + offset.sqrt() * pixel::normal(&mut rng);
            (f64::from(BLACK) + noisy * range)
                .round()
                .clamp(0.0, f64::from(WHITE)) as u16
        })
        .collect()
}

/// The image through a lens: a Gaussian blur of sd 0.6 pixel (a sharp lens and an
/// anti-aliasing filter pass little above half the sampling frequency), kept as f64 in 0..=255.
fn blurred(rgb: &imageio::Image) -> Blurred {
    let sd = 0.6f64;
    let taps: Vec<f64> = (-3..=3)
        .map(|i| (-(i * i) as f64 / (2.0 * sd * sd)).exp())
        .collect();
    let norm: f64 = taps.iter().sum();
    let (w, h) = (rgb.width, rgb.height);
    let src: Vec<f64> = rgb.data.iter().map(|v| f64::from(*v)).collect();
    let pass = |src: &[f64], dx: isize, dy: isize| -> Vec<f64> {
        let mut out = vec![0.0; src.len()];
        for y in 0..h {
            for x in 0..w {
                for c in 0..3 {
                    let mut acc = 0.0;
                    for (k, t) in taps.iter().enumerate() {
                        let o = k as isize - 3;
                        let xx = (x as isize + o * dx).clamp(0, w as isize - 1) as usize;
                        let yy = (y as isize + o * dy).clamp(0, h as isize - 1) as usize;
                        acc += t * src[3 * (yy * w + xx) + c];
                    }
                    out[3 * (y * w + x) + c] = acc / norm;
                }
            }
        }
        out
    };
    let data = pass(&pass(&src, 1, 0), 0, 1);
    Blurred {
        width: w,
        height: h,
        data,
    }
}

struct Blurred {
    width: usize,
    height: usize,
    data: Vec<f64>,
}

/// Where the estimate holds within 25 % on every image (`S`, and `O` where asked): the noise
/// must stand above the images' fine structure, which reads as noise. Measured on this set
/// (worst relative error over the images, `S` / `O`):
///
/// | S \ exposure | 0.08 | 0.3 | 1 |
/// |---|---|---|---|
/// | 0.0008 | 0.29 / 5.3 | 0.72 / 47 | 1.9 / 540 |
/// | 0.0032 | 0.16 / 2.1 | 0.29 / 5.3 | 0.70 / 5.5 |
/// | 0.0128 | 0.13 / 0.24 | 0.17 / 1.8 | 0.28 / 3.2 (one image not estimated: clipped) |
///
/// `O` is only seen where the frame has areas dark enough for it to matter beside `S x`, and
/// Kodak's and McMaster's textures at full exposure outweigh noise of `S` = 0.0008.
const HOLDS: [(f64, f64, bool); 3] = [
    (0.0032, 0.08, false),
    (0.0128, 0.08, true),
    (0.0128, 0.3, false),
];

#[test]
fn estimated_profile_is_within_a_quarter_of_the_truth_where_noise_dominates() {
    let images: Vec<_> = dataset("kodak")
        .into_iter()
        .step_by(4)
        .chain(dataset("mcmaster").into_iter().step_by(3))
        .collect();
    let mut failures = Vec::new();
    // Where the estimate holds it says it is confident; where it doubles S or more it says it
    // is not (and its default strength drops).
    let mut flag_failures = Vec::new();
    for (i, path) in images.iter().enumerate() {
        let rgb = blurred(&imageio::read(path).unwrap());
        for scale in [0.0008, 0.0032, 0.0128] {
            for exposure in [1.0, 0.3, 0.08] {
                let raw = noisy_raw(&rgb, exposure, scale, i as u64);
                let holds = HOLDS.iter().find(|h| (h.0, h.1) == (scale, exposure));
                let name = path.file_name().unwrap().to_string_lossy();
                let (w, h) = (rgb.width, rgb.height);
                let frame =
                    RawFrame::new(&raw, w, h, w, 12, CfaPattern::Rggb, [BLACK; 4], WHITE).unwrap();
                let e = match estimate(&frame) {
                    Ok(e) => e,
                    Err(error) => {
                        println!("{name} S {scale} exposure {exposure}: {error}");
                        if holds.is_some() {
                            failures.push(format!("{name} S {scale} exposure {exposure}: {error}"));
                        }
                        continue;
                    }
                };
                let ds = f64::from(e.profile.scale()[1]) / scale - 1.0;
                let dof = f64::from(e.profile.offset()[1]) / offset_for(scale) - 1.0;
                println!(
                    "{name} S {scale} exposure {exposure}: S {ds:+.3} O {dof:+.3} ({} level sets, spread {:.3})",
                    e.sets, e.texture_spread
                );
                if (holds.is_some() && !e.confident()) || (ds > 1.0 && e.confident()) {
                    flag_failures.push(format!(
                        "{name} S {scale} exposure {exposure}: S {ds:+.3}, spread {:.3}",
                        e.texture_spread
                    ));
                }
                assert_eq!(e.default_strength() < 1.0, !e.confident());
                if let Some(&(_, _, check_o)) =
                    HOLDS.iter().find(|h| (h.0, h.1) == (scale, exposure))
                {
                    if ds.abs() >= 0.25 || (check_o && dof.abs() >= 0.25) {
                        failures.push(format!(
                            "{name} S {scale} exposure {exposure}: S {ds:+.3} O {dof:+.3}"
                        ));
                    }
                }
            }
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
    assert!(flag_failures.is_empty(), "{flag_failures:#?}");
}

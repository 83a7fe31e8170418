//! The sensor model's noise statistics and the colour calibration, end to end.

use host_tracer::calibrate::calibrate;
use host_tracer::sensor::{capture, LensGeometry, NoiseConfig, SensorConfig};
use isp_core::metrics::mean_max;

const LENS: LensGeometry = LensGeometry {
    f_number: 2.8,
    focal_length_mm: 50.0,
    sensor_mm: [36.0, 24.0],
};

/// Electrons per pixel of a flat field through the model, and the frame's conversion gain.
fn flat_field(config: &SensorConfig, radiance: f32, side: usize) -> (Vec<f64>, f64, f64) {
    let frame = vec![radiance; side * side * 3];
    let c = capture(&frame, side, side, LENS, config).unwrap();
    let gain = config.dn_per_electron();
    let (black, white) = (c.raw.black_level[0], c.raw.white_level);
    let electrons: Vec<f64> = c
        .raw
        .samples
        .iter()
        .map(|v| (*v as f64 - black as f64) / gain)
        .collect();
    let expected_e = c.units_per_radiance * radiance as f64 * (white - black) as f64 / gain;
    (electrons, expected_e, gain)
}

fn mean_var(v: &[f64]) -> (f64, f64) {
    let m = v.iter().sum::<f64>() / v.len() as f64;
    let var = v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (v.len() - 1) as f64;
    (m, var)
}

#[test]
fn shot_noise_variance_equals_the_mean_signal() {
    for (exposure, label) in [(0.002, "dim"), (0.02, "bright")] {
        let config = SensorConfig {
            exposure_s: Some(exposure),
            noise: NoiseConfig {
                shot: true,
                ..NoiseConfig::default()
            },
            ..SensorConfig::ideal()
        };
        let (e, expected, gain) = flat_field(&config, 100.0, 512);
        let (mean, var) = mean_var(&e);
        // The ADC's rounding adds 1/12 DN^2 of variance, which is known and taken out.
        let var = var - 1.0 / 12.0 / (gain * gain);
        println!("{label}: mean {mean:.1} e- (expected {expected:.1}), variance {var:.1} e-^2, ratio {:.4}", var / mean);
        assert!((mean / expected - 1.0).abs() < 0.01, "{mean} vs {expected}");
        assert!(
            (var / mean - 1.0).abs() < 0.03,
            "variance {var} vs mean {mean}"
        );
    }
}

#[test]
fn read_noise_standard_deviation_matches_the_setting() {
    for read_e in [1.5, 4.0, 10.0] {
        let config = SensorConfig {
            exposure_s: Some(1e-3),
            iso: 1600.0,
            noise: NoiseConfig {
                read_e,
                ..NoiseConfig::default()
            },
            ..SensorConfig::ideal()
        };
        // A dark frame: read noise alone.
        let (e, _, gain) = flat_field(&config, 0.0, 512);
        let (_, var) = mean_var(&e);
        let sd = (var - 1.0 / 12.0 / (gain * gain)).sqrt();
        println!("read noise {read_e} e-: measured {sd:.3} e-");
        assert!((sd / read_e - 1.0).abs() < 0.03, "{sd} vs {read_e}");
    }
}

#[test]
fn nikon_5100_calibration_under_d65() {
    let c = calibrate("nikon-5100", "D65").unwrap();
    let (mean, max) = mean_max(&c.delta_e_matrix);
    let (rp_mean, _) = mean_max(&c.delta_e_root_polynomial);
    println!("nikon-5100 D65: 3x3 mean {mean:.3} max {max:.3}; root-polynomial mean {rp_mean:.3}; CCT {:.0}", c.cct_k);
    assert!(mean <= 1.5, "{mean}");
    assert!((c.cct_k - 6504.0).abs() < 60.0, "{}", c.cct_k);
    let a = calibrate("nikon-5100", "A").unwrap();
    println!(
        "nikon-5100 A: 3x3 mean {:.3}, CCT {:.0}",
        mean_max(&a.delta_e_matrix).0,
        a.cct_k
    );
    assert!((a.cct_k - 2856.0).abs() < 30.0, "{}", a.cct_k);
}

/// Leave-one-out scores each patch with fits to the other 23: never better on average than
/// the fit that saw it, and nearly exact for a camera whose response is the CIE observer
/// itself (any 23 patches determine its matrix; the ADC's quantisation is what remains).
#[test]
fn held_out_patch_errors() {
    let c = calibrate("nikon-5100", "D65").unwrap();
    for (fitted, held_out) in [
        (&c.delta_e_matrix, &c.delta_e_matrix_held_out),
        (
            &c.delta_e_root_polynomial,
            &c.delta_e_root_polynomial_held_out,
        ),
    ] {
        assert_eq!(held_out.len(), 24);
        let (fitted, held_out) = (mean_max(fitted).0, mean_max(held_out).0);
        println!("in-sample {fitted:.3}, held out {held_out:.3}");
        assert!(
            held_out >= fitted && held_out < 3.0 * fitted + 0.5,
            "{held_out} vs {fitted}"
        );
    }
    let ideal = calibrate("cie1931", "D65").unwrap();
    let worst = mean_max(&ideal.delta_e_matrix_held_out).1;
    println!("cie1931 held out: worst {worst:.3}");
    assert!(worst < 0.5, "the observer's own matrix, held out: {worst}");
}

//! The closed loop of `camsim tune`: cameras with known parameters (two spectral responses,
//! black levels, noise, shading and defects that differ) shoot a capture set through the
//! simulator, the set is tuned, and the recovered parameters are checked against the truth.
//! Each camera's figures are printed (`cargo test --release -p camsim --test tune_loop --
//! --nocapture`); the README's table is that output.

// Colour and corner indices address several arrays at once.
#![allow(clippy::needless_range_loop)]

mod common;

use std::path::{Path, PathBuf};

use camsim::tune::{self, chart, fit, reference, simulate, TuneSettings, Tuned};
use host_tracer::sensor::{DefectKind, LensGeometry, SensorConfig};
use host_tracer::spectra::Table;

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("camsim-tune-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

/// A small set of the realistic sensor: `width x height`, one dark, one flat per light, no
/// photon-transfer pairs (the noise from the chart patches).
fn small_set(width: usize, height: usize) -> simulate::CaptureSetSpec {
    let mut spec = simulate::CaptureSetSpec::standard(SensorConfig::realistic());
    spec.width = width;
    spec.height = height;
    spec.ptc_isos.clear();
    spec.darks = 1;
    spec.flats_per_illuminant = 1;
    spec
}

/// The held-out light: shot, then moved out of the folder before tuning.
const HELD_OUT: &str = "D50";

struct Camera {
    name: &'static str,
    spec: simulate::CaptureSetSpec,
}

fn cameras() -> Vec<Camera> {
    let mut nikon = simulate::CaptureSetSpec::standard(SensorConfig {
        camera: "nikon-5100".into(),
        adc_bits: 12,
        black_level: Some(256),
        defects: host_tracer::sensor::DefectConfig {
            hot_per_million: 1000.0,
            dead_per_million: 500.0,
            stuck_per_million: 300.0,
        },
        seed: 3,
        ..SensorConfig::realistic()
    });
    nikon.chart_illuminants.push(HELD_OUT.into());
    let mut canon = simulate::CaptureSetSpec::standard(SensorConfig {
        camera: "canon-eos-5d-mark-ii".into(),
        adc_bits: 14,
        black_level: Some(2048),
        full_well_e: 30000.0,
        noise: host_tracer::sensor::NoiseConfig {
            read_e: 4.0,
            row_e: 1.0,
            column_e: 0.7,
            ..SensorConfig::realistic().noise
        },
        shading: host_tracer::sensor::ShadingConfig {
            cos4: true,
            colour: [0.05, 0.0, 0.15],
        },
        defects: host_tracer::sensor::DefectConfig {
            hot_per_million: 600.0,
            dead_per_million: 800.0,
            stuck_per_million: 200.0,
        },
        seed: 11,
        ..SensorConfig::realistic()
    });
    canon.lens = LensGeometry {
        f_number: 2.8,
        focal_length_mm: 9.0,
        sensor_mm: [6.4, 4.8],
    };
    canon.chart = simulate::ChartPlacement {
        centre: [0.45, 0.55],
        width_fraction: 0.5,
        rotation_deg: -8.0,
        border: false,
    };
    canon.chart_illuminants.push(HELD_OUT.into());
    vec![
        Camera {
            name: "nikon-5100",
            spec: nikon,
        },
        Camera {
            name: "canon-eos-5d-mark-ii",
            spec: canon,
        },
    ]
}

/// Shoots the set, moves the held-out chart aside; returns the truth and that chart's path.
fn shoot(camera: &Camera, dir: &Path) -> (simulate::CaptureTruth, PathBuf) {
    let truth =
        simulate::write_capture_set(&camera.spec, dir, &mut |_| {}).expect("the capture set");
    let held = truth
        .files
        .iter()
        .find(|f| {
            f.file_name()
                .unwrap()
                .to_string_lossy()
                .contains(&format!("_{HELD_OUT}_"))
        })
        .expect("the held-out chart")
        .clone();
    let aside = dir.with_extension("held-out.dng");
    std::fs::rename(&held, &aside).unwrap();
    (truth, aside)
}

fn relative(a: f64, b: f64) -> f64 {
    (a / b - 1.0).abs()
}

fn check_noise(tuned: &Tuned, truth: &simulate::CaptureTruth, name: &str) {
    for (iso, profile) in &truth.noise {
        let entry = tuned
            .tuning
            .noise
            .iter()
            .find(|n| n.iso == *iso)
            .unwrap_or_else(|| panic!("{name}: no noise entry at ISO {iso}"));
        for c in 0..3 {
            let (s, o) = (
                f64::from(profile.scale()[c]),
                f64::from(profile.offset()[c]),
            );
            let (es, eo) = (relative(entry.scale[c], s), relative(entry.offset[c], o));
            println!(
                "{name} ISO {iso} colour {c}: S {:.4e} (true {s:.4e}, {:.1} %), O {:.4e} (true {o:.4e}, {:.1} %)",
                entry.scale[c],
                100.0 * es,
                entry.offset[c],
                100.0 * eo
            );
            assert!(es <= 0.05, "{name} ISO {iso}: S off by {:.1} %", 100.0 * es);
            assert!(eo <= 0.15, "{name} ISO {iso}: O off by {:.1} %", 100.0 * eo);
        }
    }
}

fn check_defects(
    tuned: &Tuned,
    truth: &simulate::CaptureTruth,
    spec: &simulate::CaptureSetSpec,
    name: &str,
) {
    let d = &tuned.tuning.defects;
    let found: std::collections::BTreeSet<(usize, usize)> = d
        .hot
        .iter()
        .chain(&d.dead)
        .chain(&d.stuck)
        .map(|p| (p[0], p[1]))
        .collect();
    let planted: std::collections::BTreeSet<(usize, usize)> =
        truth.defects.iter().map(|&(x, y, _)| (x, y)).collect();
    let hits = planted.intersection(&found).count();
    let false_flags = found.difference(&planted).count();
    let good = spec.width * spec.height - planted.len();
    let kinds_right = truth
        .defects
        .iter()
        .filter(|&&(x, y, k)| {
            let list = match k {
                DefectKind::Hot => &d.hot,
                DefectKind::Dead => &d.dead,
                DefectKind::Stuck => &d.stuck,
            };
            list.contains(&[x, y])
        })
        .count();
    println!(
        "{name} defects: {hits} of {} planted found ({kinds_right} of the right kind), {false_flags} good pixels flagged of {good}",
        planted.len()
    );
    assert!(
        hits as f64 >= 0.99 * planted.len() as f64,
        "{name}: found {hits} of {}",
        planted.len()
    );
    assert!(
        false_flags as f64 <= 1e-4 * good as f64,
        "{name}: {false_flags} good pixels flagged"
    );
}

fn check_shading(
    tuned: &Tuned,
    truth: &simulate::CaptureTruth,
    spec: &simulate::CaptureSetSpec,
    name: &str,
) {
    let t = &tuned.tuning;
    for table in &t.shading.colour {
        for c in 0..3 {
            let gain = |x: f64, y: f64| t.shading_gain(x + 0.5, y + 0.5, c, table.cct);
            let (corner, rms) = simulate::shading_residual(&truth.shading, spec, c, &gain);
            let (cx, cy) = (spec.width as f64 / 2.0, spec.height as f64 / 2.0);
            println!(
                "{name} shading {} K colour {c}: residual {:.2} % at the corners, {:.2} % RMS (uncorrected corner {:.1} %)",
                table.cct,
                100.0 * corner,
                100.0 * rms,
                100.0 * (1.0 - truth.shading.factor(0.0, 0.0, c) / truth.shading.factor(cx, cy, c))
            );
            assert!(
                corner <= 0.01 && rms <= 0.005,
                "{name}: shading residual {corner} / {rms}"
            );
        }
    }
}

/// The fitted lights' matrices, and the held-out light through the locus and the
/// interpolated matrix.
fn check_colour(tuned: &Tuned, truth: &simulate::CaptureTruth, held: &Path, name: &str) {
    let illuminants = Table::parse(host_tracer::spectra::ILLUMINANTS).unwrap();
    for shot in &tuned.charts {
        let (_, light_name, _) = truth
            .illuminants
            .iter()
            .map(|(n, cct, rgb)| (cct, n, rgb))
            .find(|(cct, _, _)| (**cct - shot.cct).abs() < 1.0)
            .unwrap();
        let mean = shot.delta_e_after.iter().sum::<f64>() / 24.0;
        // Against the truth: the tuned matrix at the light's CCT on the 24 patches as the
        // camera sees them noise-free, white-balanced by the light itself (what `camsim bench
        // tune` measures every tool on).
        let balanced = simulate::balanced_patches(name, light_name).unwrap();
        let target =
            reference::chart_srgb(illuminants.named("illuminant", light_name).unwrap()).unwrap();
        let ccm = tuned.tuning.ccm_at(shot.cct);
        let truth_errors = fit::ccm_errors_at_grey_exposure(&ccm, &balanced, &target);
        let on_truth = truth_errors.iter().sum::<f64>() / 24.0;
        println!(
            "{name} {light_name}: CCM mean CIEDE2000 {on_truth:.2} on the true patches (max {:.2}); {mean:.2} on the sampled ones it was fitted to (max {:.2}), before the matrix {:.2}",
            truth_errors.iter().fold(0.0f64, |a, &b| a.max(b)),
            shot.delta_e_after.iter().fold(0.0f64, |a, &b| a.max(b)),
            shot.delta_e_before.iter().sum::<f64>() / 24.0
        );
        assert!(
            on_truth <= 1.0,
            "{name} {light_name}: mean CIEDE2000 {on_truth} on the true patches"
        );
        assert!(mean <= 1.5, "{name} {light_name}: mean CIEDE2000 {mean}");
    }
    // Held out: chart found, sampled with the tuning's shading and defects, white balanced
    // through the locus, matrix interpolated at the locus's CCT.
    let t = &tuned.tuning;
    let dng = raw_formats::dng::Dng::read(held).unwrap();
    let raw = &dng.image;
    let black = t.black_level.values;
    let mosaic = chart::Mosaic::of(raw, black);
    let corners = chart::detect(&mosaic).expect("the held-out chart is found");
    let map = chart::ChartMap::from_corners(&corners).unwrap();
    let defects: std::collections::BTreeSet<[usize; 2]> = t
        .defects
        .hot
        .iter()
        .chain(&t.defects.dead)
        .chain(&t.defects.stuck)
        .copied()
        .collect();
    // First pass at the middle of the locus for shading, then at the estimated CCT.
    let mut cct = 5000.0;
    let mut result = None;
    for _ in 0..2 {
        let gain = |x: usize, y: usize, c: usize| {
            if defects.contains(&[x, y]) {
                f64::NAN
            } else {
                t.shading_gain(x as f64 + 0.5, y as f64 + 0.5, c, cct)
            }
        };
        let patches = chart::sample_patches_corrected(&mosaic, &map, 0.3, &gain);
        let mut neutral = [0.0; 3];
        for &g in &chart::NEUTRALS[..5] {
            for k in 0..3 {
                neutral[k] += patches[g].mean[k] / patches[g].mean[1] / 5.0;
            }
        }
        let (gains, estimated) = t
            .constrain_white(neutral)
            .expect("a white through the locus");
        cct = estimated;
        result = Some((patches, gains));
    }
    let (patches, gains) = result.unwrap();
    let (_, true_cct, true_rgb) = truth
        .illuminants
        .iter()
        .find(|(n, _, _)| n == HELD_OUT)
        .unwrap();
    let true_gains = [1.0 / true_rgb[0], 1.0, 1.0 / true_rgb[2]];
    let angle = {
        let a = gains.map(|g| 1.0 / g);
        let b = true_gains.map(|g| 1.0 / g);
        let dot: f64 = (0..3).map(|k| a[k] * b[k]).sum();
        let na = a.iter().map(|v| v * v).sum::<f64>().sqrt();
        let nb = b.iter().map(|v| v * v).sum::<f64>().sqrt();
        (dot / (na * nb)).clamp(-1.0, 1.0).acos().to_degrees()
    };
    let ccm = t.ccm_at(cct);
    let range = f64::from(raw.white_level) - black[0];
    let balanced: Vec<[f64; 3]> = patches
        .iter()
        .map(|p| std::array::from_fn(|k| p.mean[k] * gains[k] / range))
        .collect();
    let target = reference::chart_srgb(illuminants.named("illuminant", HELD_OUT).unwrap()).unwrap();
    // The exposure is the ISP's, not the matrix's: the best scale, as for the fitted lights.
    let errors = fit::ccm_errors_at_grey_exposure(&ccm, &balanced, &target);
    let mean = errors.iter().sum::<f64>() / 24.0;
    let true_patches = simulate::balanced_patches(name, HELD_OUT).unwrap();
    let on_truth = fit::ccm_errors_at_grey_exposure(&ccm, &true_patches, &target)
        .iter()
        .sum::<f64>()
        / 24.0;
    println!(
        "{name} held out {HELD_OUT} ({true_cct} K): locus CCT {cct:.0} K, white balance {angle:.2} degrees off, CCM mean CIEDE2000 {mean:.2} (max {:.2}) on the sampled patches, {on_truth:.2} on the true ones",
        errors.iter().fold(0.0f64, |a, &b| a.max(b))
    );
    assert!(
        on_truth <= 2.0,
        "{name}: held-out mean CIEDE2000 {on_truth} on the true patches"
    );
    assert!(
        angle <= 1.0,
        "{name}: held-out white balance {angle} degrees off"
    );
    assert!(mean <= 2.0, "{name}: held-out mean CIEDE2000 {mean}");
}

/// `camsim isp --tuning`'s options ([`tune::options_for`]) develop the held-out chart: the
/// patches of the 8-bit output, decoded, against the chart under D50 adapted to D65, with the
/// tuning and with the plain defaults (grey world, no shading correction, no matrix).
fn check_isp_uses_it(
    tuned: &Tuned,
    truth: &simulate::CaptureTruth,
    held: &Path,
    spec: &simulate::CaptureSetSpec,
    name: &str,
) {
    use camsim::develop::{develop, RawInput, RunOptions};
    use camsim::isp_options::{IspOptions, WhiteBalance};
    let input = RawInput::read(held).unwrap();
    let applied = tune::options_for(
        &tuned.tuning,
        &input.raw,
        isp_core::wb::AwbMethod::GreyWorld,
        Some(100.0),
    )
    .unwrap();
    let illuminants = Table::parse(host_tracer::spectra::ILLUMINANTS).unwrap();
    let target = reference::chart_srgb(illuminants.named("illuminant", HELD_OUT).unwrap()).unwrap();
    let map = spec.chart.map(spec.width, spec.height);
    let score_of = |input: &RawInput, options: &IspOptions| -> f64 {
        let run = RunOptions {
            threads: 1,
            stage_times: false,
        };
        let (_, image) = develop(input, options, None, run).unwrap();
        let pitch = map.pitch_px();
        let patches: Vec<[f64; 3]> = (0..24)
            .map(|i| {
                let [cx, cy] = map.patch_centre(i);
                let r = (0.2 * pitch) as isize;
                let mut sum = [0.0; 3];
                let mut n = 0.0;
                for dy in -r..=r {
                    for dx in -r..=r {
                        let (x, y) = ((cx as isize + dx) as usize, (cy as isize + dy) as usize);
                        for c in 0..3 {
                            let v =
                                f32::from(image.data[3 * (y * image.width + x) + c] as u8) / 255.0;
                            sum[c] += f64::from(isp_core::srgb::decode(v));
                        }
                        n += 1.0;
                    }
                }
                sum.map(|v| v / n)
            })
            .collect();
        // The exposure is the ISP's gain, not the tuning's: the best scale over the greys.
        let (mut num, mut den) = (0.0, 0.0);
        for &g in &chart::NEUTRALS[1..5] {
            num += patches[g][1] * target[g][1];
            den += patches[g][1] * patches[g][1];
        }
        let e = fit::ccm_errors(
            &[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            num / den,
            &patches,
            &target,
        );
        e.iter().sum::<f64>() / 24.0
    };
    let plain = IspOptions {
        white_balance: Some(WhiteBalance::Auto(isp_core::wb::AwbMethod::GreyWorld)),
        black_level: Some(vec![truth.black]),
        ..IspOptions::default()
    };
    let (with, without) = (score_of(&input, &applied.options), score_of(&input, &plain));
    println!(
        "{name} held out {HELD_OUT} through the ISP: locus {:.0} K, output mean CIEDE2000 {with:.2} with the tuning, {without:.2} without",
        applied.cct
    );
    assert!(
        with < 3.0 && with < 0.5 * without,
        "{name}: {with} with the tuning, {without} without"
    );

    // The DNG a camera holding the tuning writes (what `camsim demo --tuning` and `camsim
    // dataset --tuning` write) develops with no options as the tuning does: its tags carry
    // the black level, defects, noise, white balance, shading and colour.
    let mut dng = raw_formats::dng::Dng::read(held).unwrap();
    let carried_applied = tune::carry_in_dng(
        &tuned.tuning,
        &mut dng,
        isp_core::wb::AwbMethod::GreyWorld,
        Some(100.0),
    )
    .unwrap();
    assert_eq!(carried_applied.gains, applied.gains);
    let carried_path = held.with_extension("tuned.dng");
    dng.write(&carried_path).unwrap();
    let carried = RawInput::read(&carried_path).unwrap();
    let back = raw_formats::dng::Dng::read(&carried_path).unwrap();
    assert_eq!(
        Some(back.processing.bad_pixels.clone()),
        applied.options.defects,
        "{name}: the defect map read back"
    );
    assert_eq!(back.processing.noise_profile, applied.options.noise_profile);
    assert_eq!(
        back.image.black_level.map(u32::from).to_vec(),
        applied
            .options
            .black_level
            .clone()
            .unwrap()
            .iter()
            .map(|&b| u32::from(b))
            .collect::<Vec<_>>()
    );
    let from_tags = score_of(&carried, &IspOptions::default());
    println!(
        "{name} held out {HELD_OUT}, its DNG carrying the tuning, developed from its tags alone: mean CIEDE2000 {from_tags:.2}"
    );
    assert!(
        from_tags < 3.0 && (from_tags - with).abs() < 0.5,
        "{name}: {from_tags} from the DNG's tags, {with} with the tuning"
    );
    let _ = std::fs::remove_file(&carried_path);
}

#[test]
fn tuning_recovers_the_simulated_cameras() {
    for camera in cameras() {
        let dir = scratch(camera.name);
        let (truth, held) = shoot(&camera, &dir);
        let tuned = tune::tune(&TuneSettings::new(&dir), &mut |_| {}).expect("the set tunes");
        let name = camera.name;
        let t = &tuned.tuning;
        for (p, b) in t.black_level.values.iter().enumerate() {
            println!("{name} black position {p}: {b:.2} (true {})", truth.black);
            assert!(
                (b - f64::from(truth.black)).abs() <= 0.5,
                "{name}: black {b}"
            );
        }
        for (shot, corner) in tuned.charts.iter().map(|s| (s, truth.chart_corners)) {
            for k in 0..4 {
                let d =
                    (shot.corners[k][0] - corner[k][0]).hypot(shot.corners[k][1] - corner[k][1]);
                assert!(
                    d < 2.0,
                    "{name}: chart corner {k} off by {d} px in {}",
                    shot.path.display()
                );
            }
        }
        check_noise(&tuned, &truth, name);
        check_defects(&tuned, &truth, &camera.spec, name);
        check_shading(&tuned, &truth, &camera.spec, name);
        check_colour(&tuned, &truth, &held, name);
        check_isp_uses_it(&tuned, &truth, &held, &camera.spec, name);

        // Without photon-transfer pairs the noise comes from the chart patches: within 20 %.
        for f in &truth.files {
            if f.file_name().unwrap().to_string_lossy().starts_with("ptc_") {
                std::fs::remove_file(f).unwrap();
            }
        }
        let from_patches =
            tune::tune(&TuneSettings::new(&dir), &mut |_| {}).expect("the set tunes without pairs");
        let entry = &from_patches.tuning.noise[0];
        assert_eq!(entry.source, "chart patches and dark frames");
        let p = truth.chart_noise;
        for c in 0..3 {
            let (s, o) = (f64::from(p.scale()[c]), f64::from(p.offset()[c]));
            println!(
                "{name} from chart patches colour {c}: S {:.1} % off, O {:.1} % off",
                100.0 * relative(entry.scale[c], s),
                100.0 * relative(entry.offset[c], o)
            );
            assert!(relative(entry.scale[c], s) <= 0.2, "{name}: S from patches");
            assert!(
                relative(entry.offset[c], o) <= 0.2,
                "{name}: O from patches"
            );
        }
        let _ = std::fs::remove_dir_all(&dir);
        let _ = std::fs::remove_file(&held);
    }
}

/// The chart is found at drawn positions, scales and rotations, with and without its border,
/// to within a pixel and a half at every corner.
#[test]
fn chart_is_found_where_it_was_drawn() {
    let mut spec = simulate::CaptureSetSpec::standard(SensorConfig::realistic());
    let placements = [
        ([0.5, 0.5], 0.3, 0.0, true),
        ([0.4, 0.45], 0.45, 10.0, false),
        ([0.6, 0.55], 0.6, -10.0, true),
        ([0.5, 0.5], 0.8, 3.0, false),
        ([0.3, 0.3], 0.3, -6.0, false),
    ];
    for (centre, width_fraction, rotation_deg, border) in placements {
        spec.chart = simulate::ChartPlacement {
            centre,
            width_fraction,
            rotation_deg,
            border,
        };
        let raw = simulate::chart_frame(&spec, "D65").unwrap();
        let mosaic = chart::Mosaic::of(&raw, raw.black_level.map(f64::from));
        let found = chart::detect(&mosaic)
            .unwrap_or_else(|e| panic!("{centre:?} {width_fraction} {rotation_deg}: {e}"));
        let truth = spec.chart.map(spec.width, spec.height).corners();
        let worst = (0..4)
            .map(|k| (found[k][0] - truth[k][0]).hypot(found[k][1] - truth[k][1]))
            .fold(0.0f64, f64::max);
        println!("chart at {centre:?}, width {width_fraction}, {rotation_deg} degrees, border {border}: corners within {worst:.2} px");
        assert!(
            worst < 1.5,
            "{centre:?} {width_fraction} {rotation_deg} {border}: {worst} px"
        );
    }
    // A frame with no chart is refused with a reason, not a guess.
    let flat = vec![1000u16; 320 * 240];
    let mosaic = chart::Mosaic {
        samples: &flat,
        width: 320,
        height: 240,
        pattern: isp_core::CfaPattern::Rggb,
        black: [256.0; 4],
        white: 4095.0,
    };
    assert!(chart::detect(&mosaic).is_err());
}

/// Sets that cannot be tuned are refused before any fit, naming the file.
#[test]
fn untunable_sets_are_refused_with_the_file_named() {
    let tune_dir = |dir: &Path, case: &str| match tune::tune(&TuneSettings::new(dir), &mut |_| {}) {
        Ok(_) => panic!("{case}: tuned"),
        Err(e) => e.to_string(),
    };
    // One light only.
    let dir = scratch("one-light");
    let mut spec = small_set(240, 180);
    spec.chart_illuminants = vec!["D65".into()];
    simulate::write_capture_set(&spec, &dir, &mut |_| {}).unwrap();
    let e = tune_dir(&dir, "one light");
    assert!(e.contains("at least two lights"), "{e}");
    // A frame of another size.
    spec.chart_illuminants = vec!["A".into(), "D65".into()];
    simulate::write_capture_set(&spec, &dir, &mut |_| {}).unwrap();
    let mut other = small_set(256, 180);
    other.flat_illuminants.clear();
    other.chart_illuminants = vec!["D50".into()];
    let odd = dir.join("zz");
    let truth = simulate::write_capture_set(&other, &odd, &mut |_| {}).unwrap();
    let chart = truth
        .files
        .iter()
        .find(|f| f.to_string_lossy().contains("chart_"))
        .unwrap();
    std::fs::rename(chart, dir.join("zz_5003k_100l.dng")).unwrap();
    let e = tune_dir(&dir, "mixed sizes");
    assert!(e.contains("zz_5003k_100l.dng") && e.contains("size"), "{e}");
    std::fs::remove_file(dir.join("zz_5003k_100l.dng")).unwrap();
    // A chart shot with no chart in it.
    let flat = dir.join("alsc_6499k_0.dng");
    std::fs::copy(&flat, dir.join("nochart_5000k_100l.dng")).unwrap();
    let e = tune_dir(&dir, "no chart");
    assert!(
        e.contains("nochart_5000k_100l.dng") && e.contains("no ColorChecker"),
        "{e}"
    );
    std::fs::remove_file(dir.join("nochart_5000k_100l.dng")).unwrap();
    // A clipped chart: the patches named.
    spec.chart_level = 1.6;
    let clipped = scratch("clipped");
    simulate::write_capture_set(&spec, &clipped, &mut |_| {}).unwrap();
    let e = tune_dir(&clipped, "clipped");
    assert!(e.contains("clipped") && e.contains("19"), "{e}");
    // A damaged file.
    std::fs::write(clipped.join("broken_4000k_100l.dng"), b"II*\0garbage").unwrap();
    let e = tune_dir(&clipped, "damaged");
    assert!(e.contains("broken_4000k_100l.dng"), "{e}");
    // And a set that tunes writes whole or not at all: nothing partial is left.
    let _ = std::fs::remove_dir_all(&dir);
    let _ = std::fs::remove_dir_all(&clipped);
}

/// Hostile and damaged DNGs in the folder are refused one by one, each with its name, never
/// a panic: a chart shot cut short at many lengths, and with bytes of its header and IFDs
/// overwritten (sizes, offsets, counts, types), each put beside a good set in turn.
#[test]
fn hostile_dngs_are_refused_one_by_one() {
    let dir = scratch("hostile");
    let mut spec = small_set(160, 120);
    spec.chart_illuminants = vec!["A".into(), "D65".into()];
    let truth = simulate::write_capture_set(&spec, &dir, &mut |_| {}).unwrap();
    let good = truth
        .files
        .iter()
        .find(|f| f.to_string_lossy().contains("_6504k_"))
        .or_else(|| {
            truth
                .files
                .iter()
                .find(|f| f.extension().is_some_and(|e| e == "dng"))
        })
        .unwrap();
    let bytes = std::fs::read(good).unwrap();
    // The set reads as it is.
    tune::read_captures(&dir, &mut |_| {}).expect("the good set reads");

    let mut mutants: Vec<(String, Vec<u8>)> = Vec::new();
    for k in 0..40 {
        let len = bytes.len() * k / 40;
        mutants.push((format!("cut at {len} bytes"), bytes[..len].to_vec()));
    }
    // The structure sits before the samples: overwrite there, one to four bytes at a time,
    // with what breaks readers (zeros, all ones, large counts and offsets).
    let structure = bytes.len().min(1024);
    let mut state: u64 = 0x9e37_79b9_7f4a_7c15;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    for _ in 0..200 {
        let at = (next() % structure as u64) as usize;
        let run = 1 + (next() % 4) as usize;
        let value = match next() % 4 {
            0 => 0x00,
            1 => 0xff,
            2 => 0x7f,
            _ => (next() & 0xff) as u8,
        };
        let mut m = bytes.clone();
        for b in m.iter_mut().skip(at).take(run) {
            *b = value;
        }
        mutants.push((format!("{run} bytes at {at} set to {value:#04x}"), m));
    }
    let (mut refused, mut read) = (0, 0);
    for (what, data) in &mutants {
        let name = "hostile_5000k_100l.dng";
        let path = dir.join(name);
        std::fs::write(&path, data).unwrap();
        let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            tune::read_captures(&dir, &mut |_| {})
        }));
        match outcome {
            Err(_) => panic!("a hostile DNG ({what}) panicked the reader"),
            Ok(Err(e)) => {
                let e = e.to_string();
                assert!(
                    e.contains(name),
                    "{what}: refused without the file's name: {e}"
                );
                refused += 1;
            }
            // A change the file survives (a byte of a tag the reader does not use): it reads
            // as a capture like the others.
            Ok(Ok(_)) => read += 1,
        }
        std::fs::remove_file(&path).unwrap();
    }
    println!(
        "{} hostile DNGs: {refused} refused with their name, {read} still read as captures",
        mutants.len()
    );
    assert!(refused >= 40, "only {refused} refused");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The tuning peers' Python (`scripts/test-all.sh` makes `.venv-tune`; `$CAMSIM_TUNE_PYTHON`
/// overrides), or `None` with a note where it is missing and not required (outside CI).
fn tune_python() -> Option<PathBuf> {
    let python = std::env::var_os("CAMSIM_TUNE_PYTHON")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../.venv-tune/bin/python"));
    if python.is_file() {
        return Some(python);
    }
    let why = format!(
        "no tuning peers' Python at {} (scripts/test-all.sh makes .venv-tune)",
        python.display()
    );
    if std::env::var_os("CAMSIM_REQUIRE_ORACLE").is_some() {
        panic!("{why}; required here (CAMSIM_REQUIRE_ORACLE is set)");
    }
    eprintln!("NOTE: {why}: the comparison did not run; CI requires it");
    None
}

/// The same drawn charts through colour-checker-detection (PyPI, its segmentation detector)
/// and camsim's detector. Each frame is shown to colour-checker-detection as an 8-bit sRGB
/// PNG at half size (each 2x2 block one pixel, white-balanced on the chart's white); camsim
/// detects on the raw mosaic and samples the same PNG at the patch centres it found. A patch
/// is identified when its sampled colour is nearer its own drawn colour than any other's.
#[test]
fn chart_detection_beside_colour_checker_detection() {
    let Some(python) = tune_python() else {
        return;
    };
    let dir = scratch("ccd");
    std::fs::create_dir_all(&dir).unwrap();
    let mut spec = simulate::CaptureSetSpec::standard(SensorConfig::realistic());
    let placements = [
        ([0.5, 0.5], 0.3, 0.0, true),
        ([0.4, 0.45], 0.45, 10.0, false),
        ([0.6, 0.55], 0.6, -10.0, true),
        ([0.5, 0.5], 0.8, 3.0, false),
        ([0.3, 0.3], 0.3, -6.0, false),
        ([0.55, 0.5], 0.5, 7.0, true),
        ([0.45, 0.55], 0.7, -4.0, true),
        ([0.6, 0.4], 0.35, 2.0, false),
    ];
    let (w, h) = (spec.width / 2, spec.height / 2);
    let mut frames = Vec::new();
    let mut ours = Vec::new();
    for (k, (centre, width_fraction, rotation_deg, border)) in placements.into_iter().enumerate() {
        spec.chart = simulate::ChartPlacement {
            centre,
            width_fraction,
            rotation_deg,
            border,
        };
        let raw = simulate::chart_frame(&spec, "D65").unwrap();
        let black = raw.black_level.map(f64::from);
        let sample = |x: usize, y: usize| f64::from(raw.samples[y * raw.width + x]);
        // Half size, each block's red, mean green and blue above black.
        let mut rgb = vec![[0.0f64; 3]; w * h];
        for by in 0..h {
            for bx in 0..w {
                let mut sum = [0.0; 3];
                let mut count = [0.0; 3];
                for p in 0..4 {
                    let (x, y) = (2 * bx + p % 2, 2 * by + p / 2);
                    let c = raw.pattern.colour_at(x, y).index();
                    sum[c] += sample(x, y) - black[(y % 2) * 2 + x % 2];
                    count[c] += 1.0;
                }
                rgb[by * w + bx] = std::array::from_fn(|c| sum[c] / count[c]);
            }
        }
        let truth_map = spec.chart.map(spec.width, spec.height);
        let at = |img: &[[f64; 3]], [cx, cy]: [f64; 2]| -> [f64; 3] {
            let r = (0.15 * truth_map.pitch_px() / 2.0).max(1.0) as isize;
            let (x0, y0) = ((cx / 2.0) as isize, (cy / 2.0) as isize);
            let mut sum = [0.0; 3];
            let mut n = 0.0f64;
            for dy in -r..=r {
                for dx in -r..=r {
                    let (x, y) = (x0 + dx, y0 + dy);
                    if x >= 0 && y >= 0 && (x as usize) < w && (y as usize) < h {
                        let v = img[y as usize * w + x as usize];
                        for c in 0..3 {
                            sum[c] += v[c];
                        }
                        n += 1.0;
                    }
                }
            }
            sum.map(|s| s / n.max(1.0))
        };
        let white = at(&rgb, truth_map.patch_centre(18));
        let encoded: Vec<[f64; 3]> = rgb
            .iter()
            .map(|p| {
                std::array::from_fn(|c| {
                    let v = (0.9 * p[c] / white[c]).clamp(0.0, 1.0) as f32;
                    (f64::from(isp_core::srgb::encode(v)) * 255.0).round() / 255.0
                })
            })
            .collect();
        let png = dir.join(format!("chart_{k}.png"));
        raw_formats::image::write(
            &png,
            &raw_formats::image::Image {
                width: w,
                height: h,
                channels: 3,
                bits: 8,
                data: encoded
                    .iter()
                    .flat_map(|p| p.map(|v| (v * 255.0).round() as u16))
                    .collect(),
            },
        )
        .unwrap();
        let truth: Vec<[f64; 3]> = (0..24)
            .map(|i| at(&encoded, truth_map.patch_centre(i)))
            .collect();
        // camsim: found on the raw mosaic, sampled on the same PNG.
        let identified = match chart::detect(&chart::Mosaic::of(&raw, black)) {
            Ok(corners) => {
                let map = chart::ChartMap::from_corners(&corners).unwrap();
                (0..24)
                    .filter(|&i| {
                        let got = at(&encoded, map.patch_centre(i));
                        let d = |t: &[f64; 3]| (0..3).map(|c| (got[c] - t[c]).powi(2)).sum::<f64>();
                        (0..24).all(|j| j == i || d(&truth[i]) < d(&truth[j]))
                    })
                    .count()
            }
            Err(_) => 0,
        };
        ours.push(identified);
        frames.push(serde_json::json!({"png": png, "truth": truth}));
    }
    let request = serde_json::json!({ "frames": frames });
    let output = std::process::Command::new(&python)
        .arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/peers/ccd_detect.py"))
        .arg(request.to_string())
        .output()
        .unwrap();
    assert!(
        output.status.success(),
        "colour-checker-detection: {}",
        String::from_utf8_lossy(&output.stderr)
    );
    let reply: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
    println!(
        "chart detection, patches identified of 24 (camsim / colour-checker-detection {}):",
        reply["versions"]["colour-checker-detection"]
    );
    let mut theirs_total = 0;
    for (k, (placement, mine)) in placements.iter().zip(&ours).enumerate() {
        let theirs = &reply["frames"][k];
        let identified = theirs["identified"].as_u64().unwrap() as usize;
        theirs_total += identified;
        println!(
            "  centre {:?}, width {}, {} degrees, border {}: camsim {mine}, colour-checker-detection {identified} ({} checkers{})",
            placement.0,
            placement.1,
            placement.2,
            placement.3,
            theirs["checkers"],
            theirs["error"].as_str().map(|e| format!("; {e}")).unwrap_or_default()
        );
        assert_eq!(*mine, 24, "camsim identified {mine} patches in frame {k}");
    }
    let ours_total: usize = ours.iter().sum();
    assert!(
        ours_total >= theirs_total,
        "camsim {ours_total}, colour-checker-detection {theirs_total}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// `camsim demo --tuning` and `camsim dataset --tuning` develop with a tuning and write DNGs
/// that carry it: read back, their black level, noise profile, defect map (FixBadPixelsList)
/// and shading (GainMaps) are the tuning's; a dataset folder keeps one tuning; a tuning of
/// another camera mode is refused before anything renders.
#[test]
fn demo_and_dataset_write_dngs_carrying_the_tuning() {
    let dir = scratch("carry");
    let mut spec = small_set(240, 180);
    spec.ptc_isos = vec![100.0];
    spec.ptc_levels = vec![0.05, 0.2, 0.45, 0.75];
    spec.darks = 2;
    let captures = dir.join("captures");
    simulate::write_capture_set(&spec, &captures, &mut |_| {}).unwrap();
    let tuned = tune::tune(&TuneSettings::new(&captures), &mut |_| {}).expect("the set tunes");
    let tuning = dir.join("tuning.toml");
    tune::write_atomically(&tuning, &tuned.tuning.to_toml().unwrap()).unwrap();
    let t = &tuned.tuning;
    let planted = t.defects.hot.len() + t.defects.dead.len() + t.defects.stuck.len();
    assert!(planted > 0, "the set has defects to carry");
    let check_dng = |path: &Path| {
        let dng = raw_formats::dng::Dng::read(path).unwrap();
        let black = t.black_dn();
        assert_eq!(dng.image.black_level, black, "{}", path.display());
        let noise = dng.processing.noise_profile.expect("a NoiseProfile");
        assert!(
            (f64::from(noise.scale()[1]) - t.noise[0].scale[1]).abs()
                < 1e-6 * t.noise[0].scale[1].abs() + 1e-12,
            "{}: noise {:?} against {:?}",
            path.display(),
            noise,
            t.noise[0]
        );
        assert_eq!(
            dng.processing.bad_pixels.len(),
            planted,
            "{}",
            path.display()
        );
        let gain_maps = dng.processing.opcode_lists[1]
            .iter()
            .filter(|op| matches!(op, raw_formats::dng::opcodes::Opcode::GainMap(_)))
            .count();
        assert_eq!(gain_maps, 4, "{}", path.display());
        assert_eq!(dng.colour.calibrations.len(), 2);
        assert!(dng.processing.iso.is_some() && dng.processing.exposure_time_s.is_some());
    };

    let demo_out = dir.join("demo");
    let (ok, stdout, stderr) = common::camsim(&[
        "demo",
        "--scene",
        "demo",
        "--width",
        "240",
        "--height",
        "180",
        "--spp",
        "2",
        "--output",
        demo_out.to_str().unwrap(),
        "--tuning",
        tuning.to_str().unwrap(),
    ]);
    assert!(ok, "camsim demo --tuning: {stderr}");
    assert!(stdout.contains("tuning:"), "{stdout}");
    check_dng(&demo_out.join("raw.dng"));
    // Another camera mode is refused, naming the tuning.
    let (ok, _, stderr) = common::camsim(&[
        "demo",
        "--width",
        "200",
        "--height",
        "150",
        "--spp",
        "1",
        "--output",
        demo_out.to_str().unwrap(),
        "--tuning",
        tuning.to_str().unwrap(),
    ]);
    assert!(!ok && stderr.contains("tuning.toml"), "{stderr}");

    let spec_path = dir.join("spec.toml");
    std::fs::write(
        &spec_path,
        "[dataset]\nseed = 3\ncount = 1\nwidth = 240\nheight = 180\nspp = 1\nisp = true\n\n\
         [scene]\ngenerators = [\"colorchecker\"]\n\n[sensor]\ncamera = \"nikon-5100\"\n",
    )
    .unwrap();
    let out = dir.join("dataset");
    let (ok, _, stderr) = common::camsim(&[
        "dataset",
        "--spec",
        spec_path.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--tuning",
        tuning.to_str().unwrap(),
    ]);
    assert!(ok, "camsim dataset --tuning: {stderr}");
    check_dng(&out.join("000000/raw.dng"));
    assert!(out.join("tuning.toml").is_file());
    let record = std::fs::read_to_string(out.join("000000/record.json")).unwrap();
    assert!(record.contains("\"tuning\""), "{record}");
    // The same folder without the tuning is another dataset: refused.
    let (ok, _, stderr) = common::camsim(&[
        "dataset",
        "--spec",
        spec_path.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(!ok && stderr.contains("tuning"), "{stderr}");
    // A spec whose samples are of another size than the tuning's: refused at once.
    let small = dir.join("small.toml");
    std::fs::write(
        &small,
        std::fs::read_to_string(&spec_path)
            .unwrap()
            .replace("width = 240", "width = 200"),
    )
    .unwrap();
    let (ok, _, stderr) = common::camsim(&[
        "dataset",
        "--spec",
        small.to_str().unwrap(),
        "--out",
        dir.join("other").to_str().unwrap(),
        "--tuning",
        tuning.to_str().unwrap(),
    ]);
    assert!(!ok && stderr.contains("240x180"), "{stderr}");
    let _ = std::fs::remove_dir_all(&dir);
}

//! `camsim demosaic` and `camsim bench demosaic` end to end, on files written here.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use camsim::demosaic::{mosaic_from_rgb, Demosaic as Method};
use isp_core::metrics::cpsnr;
use isp_core::CfaPattern;
use raw_formats::image::{self as imageio, Image};

fn camsim(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_camsim"))
        .args(args)
        .output()
        .expect("camsim runs")
}

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("camsim-test-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn mosaic_image(w: usize, h: usize, bits: u8) -> Image {
    let max = if bits == 8 { 255 } else { 65535 };
    let data = (0..w * h)
        .map(|i| ((i * 7919 + i / w * 31) % (max as usize + 1)) as u16)
        .collect();
    Image {
        width: w,
        height: h,
        channels: 1,
        bits,
        data,
    }
}

fn path_str(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// The command's output equals isp-core's, for PNG and PGM, 8 and 16 bit, every method.
#[test]
fn demosaic_command_matches_the_library() {
    let dir = temp_dir("demosaic");
    for (bits, ext_in, ext_out) in [
        (8, "png", "png"),
        (16, "png", "ppm"),
        (16, "pgm", "png"),
        (8, "pgm", "ppm"),
    ] {
        let input = mosaic_image(13, 9, bits);
        let in_path = dir.join(format!("in{bits}.{ext_in}"));
        imageio::write(&in_path, &input).unwrap();
        assert_eq!(
            imageio::read(&in_path).unwrap(),
            input,
            "{ext_in} round trip"
        );
        for method in Method::ALL {
            let out_path = dir.join(format!("out{bits}-{}.{ext_out}", method.name()));
            let out = camsim(&[
                "demosaic",
                "--method",
                method.name(),
                "--pattern",
                "GRBG",
                "--input",
                path_str(&in_path),
                "--output",
                path_str(&out_path),
            ]);
            assert!(
                out.status.success(),
                "{}",
                String::from_utf8_lossy(&out.stderr)
            );
            let got = imageio::read(&out_path).unwrap();
            assert_eq!(
                (got.width, got.height, got.channels, got.bits),
                (13, 9, 3, bits)
            );
            // 8-bit files go through the u8 path, whose clamp (MHC overshoot) is 255.
            let expected: Vec<u16> = if bits == 8 {
                let data: Vec<u8> = input.data.iter().map(|v| *v as u8).collect();
                let mut rgb = vec![0u8; 3 * 13 * 9];
                method
                    .run(&data, 13, 9, CfaPattern::Grbg, &mut rgb)
                    .unwrap();
                rgb.into_iter().map(u16::from).collect()
            } else {
                let mut rgb = vec![0u16; 3 * 13 * 9];
                method
                    .run(&input.data, 13, 9, CfaPattern::Grbg, &mut rgb)
                    .unwrap();
                rgb
            };
            assert_eq!(got.data, expected, "{} {bits}-bit", method.name());
        }
    }
}

#[test]
fn demosaic_command_errors_are_one_line() {
    let dir = temp_dir("demosaic-errors");
    let rgb = Image {
        width: 4,
        height: 4,
        channels: 3,
        bits: 8,
        data: vec![0; 48],
    };
    let rgb_path = dir.join("rgb.png");
    imageio::write(&rgb_path, &rgb).unwrap();
    let grey_path = dir.join("grey.pgm");
    imageio::write(&grey_path, &mosaic_image(4, 4, 8)).unwrap();
    let out_path = dir.join("out.png");
    let missing = dir.join("missing.png");
    let truncated = dir.join("short.pgm");
    std::fs::write(&truncated, b"P5\n4 4\n255\nabc").unwrap();
    let cases: [(&[&str], &str); 7] = [
        (
            &[
                "--input",
                path_str(&grey_path),
                "--border",
                "opencv",
                "--method",
                "mhc",
            ],
            "--border opencv applies to bilinear only",
        ),
        (
            &["--input", path_str(&grey_path), "--border", "wrap"],
            "--border must be reflect101 or opencv",
        ),
        (&["--input", path_str(&rgb_path)], "single-channel"),
        (
            &["--input", path_str(&grey_path), "--method", "vng"],
            "--method must be one of",
        ),
        (
            &["--input", path_str(&grey_path), "--pattern", "RGBG"],
            "--pattern must be one of",
        ),
        (&["--input", path_str(&truncated)], "truncated"),
        (&["--input", path_str(&missing)], "missing.png"),
    ];
    for (extra, expected) in cases {
        let mut args = vec!["demosaic", "--output", path_str(&out_path)];
        args.extend(extra);
        let out = camsim(&args);
        assert!(!out.status.success());
        let err = String::from_utf8(out.stderr).unwrap();
        assert_eq!(err.lines().count(), 1, "{err}");
        assert!(err.contains(expected), "{err}");
    }
}

/// `--border opencv` with bilinear is the OpenCV-exact method; the default border is reflect-101.
#[test]
fn border_flag_selects_opencv_rule() {
    let dir = temp_dir("demosaic-border");
    let input = dir.join("in.png");
    imageio::write(&input, &mosaic_image(11, 7, 16)).unwrap();
    let run = |extra: &[&str], name: &str| {
        let out_path = dir.join(name);
        let mut args = vec![
            "demosaic",
            "--input",
            path_str(&input),
            "--output",
            path_str(&out_path),
        ];
        args.extend(extra);
        let out = camsim(&args);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        imageio::read(&out_path).unwrap()
    };
    let flag = run(&["--method", "bilinear", "--border", "opencv"], "flag.png");
    let named = run(&["--method", "bilinear-opencv"], "named.png");
    let reflect = run(&["--method", "bilinear"], "reflect.png");
    assert_eq!(flag, named);
    assert_ne!(flag, reflect);
}

/// CPSNR against an independent computation, and the bench's JSON on a small dataset.
#[test]
fn bench_reports_cpsnr_and_speed() {
    let dir = temp_dir("bench");
    let (w, h) = (40, 30);
    let rgb = Image {
        width: w,
        height: h,
        channels: 3,
        bits: 8,
        data: (0..3 * w * h)
            .map(|i| ((i / 3 % w) * 5 + (i / 3 / w) * 3 + (i % 3) * 40) as u16 % 256)
            .collect(),
    };
    imageio::write(&dir.join("a.png"), &rgb).unwrap();
    imageio::write(
        &dir.join("b.png"),
        &Image {
            data: rgb.data.iter().rev().copied().collect(),
            ..rgb.clone()
        },
    )
    .unwrap();

    // Independent CPSNR of bilinear on image a.
    let mosaic = mosaic_from_rgb(&rgb, CfaPattern::Rggb, 1);
    let mut out = vec![0u16; 3 * w * h];
    Method::BILINEAR
        .run(&mosaic, w, h, CfaPattern::Rggb, &mut out)
        .unwrap();
    let (mut se, mut n) = (0.0, 0.0);
    for y in 10..h - 10 {
        for x in 10..w - 10 {
            for c in 0..3 {
                let i = 3 * (y * w + x) + c;
                se += (out[i] as f64 - rgb.data[i] as f64).powi(2);
                n += 1.0;
            }
        }
    }
    let expected = 10.0 * (255.0f64 * 255.0 / (se / n)).log10();
    assert!((cpsnr(&out, &rgb.data, w, h, 10, 255.0) - expected).abs() < 1e-12);

    let out = camsim(&[
        "bench",
        "demosaic",
        "--dataset",
        path_str(&dir),
        "--bits",
        "8",
        "--json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let rows: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let rows = rows.as_array().unwrap();
    assert_eq!(rows.len(), Method::ALL.len());
    for (row, method) in rows.iter().zip(Method::ALL) {
        assert_eq!(row["method"], method.name());
        assert_eq!(row["bits"], 8);
        assert!(row["cpsnr_db"].as_f64().unwrap() > 10.0);
        assert!(row["mpix_per_s"].as_f64().unwrap() > 0.0);
    }
    // Progress went to stderr, one line per method and image.
    assert!(String::from_utf8_lossy(&out.stderr).lines().count() >= 2 * Method::ALL.len());
    let bad = camsim(&[
        "bench",
        "demosaic",
        "--dataset",
        path_str(&dir),
        "--threads",
        "2",
    ]);
    assert!(!bad.status.success() && String::from_utf8_lossy(&bad.stderr).contains("--threads"));

    // `--method` picks methods, in the order given, with the same figures as the full run.
    let picked = camsim(&[
        "bench",
        "demosaic",
        "--dataset",
        path_str(&dir),
        "--bits",
        "8",
        "--method",
        "mhc",
        "--method",
        "nearest",
        "--json",
    ]);
    assert!(picked.status.success());
    let picked: serde_json::Value = serde_json::from_slice(&picked.stdout).unwrap();
    let names: Vec<_> = picked
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r["method"].clone())
        .collect();
    assert_eq!(names, ["mhc", "nearest"]);
    let mhc = rows.iter().find(|r| r["method"] == "mhc").unwrap();
    assert_eq!(picked[0]["cpsnr_db"], mhc["cpsnr_db"]);
    let unknown = camsim(&[
        "bench",
        "demosaic",
        "--dataset",
        path_str(&dir),
        "--method",
        "ahd",
    ]);
    let stderr = String::from_utf8_lossy(&unknown.stderr);
    assert!(!unknown.status.success() && stderr.contains("ahd") && stderr.contains("directional"));
}

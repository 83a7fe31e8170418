//! `camsim isp` as a user runs it: files in and out, the printed report, clear errors.

use std::process::Command;

use host_tracer::imageio::{self, Image};

fn camsim(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_camsim"))
        .args(args)
        .output()
        .unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn isp_writes_an_srgb_image_and_reports_stages_and_times() {
    let dir = std::env::temp_dir().join(format!("camsim-isp-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let input = dir.join("grey.pgm");
    // A flat 12-bit grey at half scale: (2080 - 64) / (4095 - 64) = 0.5 linear -> sRGB 188.
    let mosaic = Image {
        width: 10,
        height: 6,
        channels: 1,
        bits: 16,
        data: vec![2080; 60],
    };
    imageio::write(&input, &mosaic).unwrap();
    for path in ["float", "fixed"] {
        let output = dir.join(format!("out-{path}.png"));
        let (ok, stdout, stderr) = camsim(&[
            "isp",
            "--input",
            input.to_str().unwrap(),
            "--output",
            output.to_str().unwrap(),
            "--bits",
            "12",
            "--black-level",
            "64",
            "--white-level",
            "4095",
            "--awb",
            "grey-world",
            "--path",
            path,
        ]);
        assert!(ok, "{stderr}");
        assert!(
            stdout.contains("stages: black level -> white balance -> bilinear -> sRGB encode")
                || stdout.contains("stages: black level -> bilinear -> sRGB encode"),
            "{stdout}"
        );
        assert!(
            stdout.contains("awb: gains R 1.0000 G 1.0000 B 1.0000"),
            "{stdout}"
        );
        assert!(stdout.contains("pipeline total"), "{stdout}");
        let rgb = imageio::read(&output).unwrap();
        assert_eq!(
            (rgb.width, rgb.height, rgb.channels, rgb.bits),
            (10, 6, 3, 8)
        );
        assert!(
            rgb.data.iter().all(|v| *v == 188),
            "{path}: {:?}",
            &rgb.data[..6]
        );
    }
    // 16-bit output.
    let output = dir.join("out16.png");
    let (ok, _, stderr) = camsim(&[
        "isp",
        "--input",
        input.to_str().unwrap(),
        "--output",
        output.to_str().unwrap(),
        "--bits",
        "12",
        "--black-level",
        "64",
        "--out-bits",
        "16",
        "--path",
        "fixed",
    ]);
    assert!(ok, "{stderr}");
    let rgb = imageio::read(&output).unwrap();
    assert_eq!(rgb.bits, 16);
    let x: f64 = 2016.0 / 4031.0;
    let expected = ((1.055 * x.powf(1.0 / 2.4) - 0.055) * 65535.0).round() as u16;
    assert!(
        rgb.data.iter().all(|v| v.abs_diff(expected) <= 1),
        "{:?} vs {expected}",
        &rgb.data[..3]
    );

    // Errors say what is wrong and what is allowed.
    let inp = input.to_str().unwrap();
    let out = output.to_str().unwrap();
    for (args, needle) in [
        (vec!["--pattern", "RGBG"], "--pattern must be one of"),
        (vec!["--bits", "4"], "--bits must be 8..=16"),
        (vec!["--bits", "8"], "exceeds 8-bit range"),
        (
            vec!["--wb", "1,2"],
            "--wb must be 3 comma-separated numbers",
        ),
        (vec!["--ccm", "1,0,0"], "--ccm must be 9"),
        (vec!["--demosaic", "magic"], "--demosaic must be one of"),
        (vec!["--path", "double"], "--path must be float or fixed"),
        (vec!["--gain", "100"], "invalid gain"),
        (vec!["--black-level", "5000"], "raw frame"),
        (vec!["--awb", "magic"], "--awb"),
    ] {
        let mut full = vec!["isp", "--input", inp, "--output", out];
        if !args.contains(&"--bits") {
            full.extend(["--bits", "12"]);
        }
        full.extend(args.iter().copied());
        let (ok, _, stderr) = camsim(&full);
        assert!(!ok && stderr.contains(needle), "{args:?}: {stderr}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

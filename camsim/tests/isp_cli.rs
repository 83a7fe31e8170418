//! `camsim isp` as a user runs it: files in and out, the printed report, clear errors.

mod common;
use common::camsim;

use raw_formats::image::{self as imageio, Image};

/// `--threads` splits the frame into bands run in parallel: the output is the same file for
/// every count, on both paths, with defect correction, MHC and the highlight stage (whose
/// windows cross the bands' edges); `--stage-times` adds the ablation table.
#[test]
fn isp_output_is_identical_for_every_thread_count() {
    let dir = std::env::temp_dir().join(format!("camsim-isp-threads-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let input = dir.join("scene.pgm");
    let (w, h) = (61usize, 37usize);
    let mut state = 7u32;
    let data = (0..w * h)
        .map(|i| {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            let spike = if state >> 28 == 0 { 3000 } else { 0 };
            (100 + (i % w) * 40 + (i / w) * 25 + (state >> 24) as usize + spike).min(4095) as u16
        })
        .collect();
    let mosaic = Image {
        width: w,
        height: h,
        channels: 1,
        bits: 16,
        data,
    };
    imageio::write(&input, &mosaic).unwrap();
    for (path, method) in ["float", "fixed"]
        .into_iter()
        .flat_map(|p| ["mhc", "directional"].map(|m| (p, m)))
    {
        let mut outputs = Vec::new();
        for threads in ["1", "2", "5", "37"] {
            let output = dir.join(format!("out-{path}-{method}-{threads}.png"));
            let mut args = vec![
                "isp",
                "--input",
                input.to_str().unwrap(),
                "--output",
                output.to_str().unwrap(),
                "--bits",
                "12",
                "--black-level",
                "64",
                "--demosaic",
                method,
                "--dpc-threshold",
                "300",
                "--wb",
                "1.8,1,1.5",
                "--ccm",
                "1.5,-0.3,-0.2,-0.2,1.4,-0.2,0,-0.4,1.4",
                "--highlight-knee",
                "0.8",
                "--path",
                path,
                "--threads",
                threads,
            ];
            if threads == "2" {
                args.push("--stage-times");
            }
            let (ok, stdout, stderr) = camsim(&args);
            assert!(ok, "{stderr}");
            assert!(stdout.contains(&format!("{threads} thread")), "{stdout}");
            assert_eq!(
                stdout.contains("time per stage"),
                threads == "2",
                "{stdout}"
            );
            outputs.push(imageio::read(&output).unwrap().data);
        }
        assert!(outputs.iter().all(|o| *o == outputs[0]), "{path} {method}");
    }
    let (ok, _, stderr) = camsim(&[
        "isp",
        "--input",
        input.to_str().unwrap(),
        "--output",
        dir.join("x.png").to_str().unwrap(),
        "--threads",
        "0",
    ]);
    assert!(!ok && stderr.contains("--threads"), "{stderr}");
    std::fs::remove_dir_all(&dir).ok();
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
            stdout.contains(
                "stages: black level -> white balance -> directional -> highlights -> sRGB encode"
            ) || stdout.contains("stages: black level -> directional -> highlights -> sRGB encode"),
            "{stdout}"
        );
        assert!(
            stdout.contains("awb: gains R 1.0000 G 1.0000 B 1.0000"),
            "{stdout}"
        );
        // One pass by default: the total, no stage times.
        assert!(stdout.contains("pipeline: "), "{stdout}");
        assert!(!stdout.contains("time per stage"), "{stdout}");
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
        (vec!["--wb", "1,2"], "--wb must be 3 finite numbers"),
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

/// A gradient mosaic big enough for a lens to move things.
fn ramp_mosaic(dir: &std::path::Path) -> std::path::PathBuf {
    let (w, h) = (40, 30);
    let data = (0..w * h)
        .map(|i| 64 + ((i % w) * 80 + (i / w) * 15) as u16)
        .collect();
    let input = dir.join("ramp.pgm");
    imageio::write(
        &input,
        &Image {
            width: w,
            height: h,
            channels: 1,
            bits: 16,
            data,
        },
    )
    .unwrap();
    input
}

/// Options from a TOML file give the same image as the same options as flags; a flag wins
/// over the file; distortion correction, lens shading and static defects are reported.
#[test]
fn isp_config_file_matches_flags_and_flags_win() {
    let dir = std::env::temp_dir().join(format!("camsim-isp-config-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let input = ramp_mosaic(&dir);
    let inp = input.to_str().unwrap();
    let config = dir.join("isp.toml");
    std::fs::write(
        &config,
        r#"# every processing option
pattern = "GRBG"
bits = 12
black-level = [64, 64, 64, 64]
white-level = 4095
gain = 1.25
wb = [1.8, 1.0, 1.4]
ccm = [[1.5, -0.3, -0.2], [-0.2, 1.4, -0.2], [0.0, -0.4, 1.4]]
demosaic = "mhc"
denoise = 1.5
noise-profile = [0.004, 2e-5]
dpc-threshold = 500
look = "vivid"
path = "fixed"
out-bits = 8
distortion = [-0.3, 0.05, 0.001, -0.002]
camera-matrix = [36.0, 36.0, 19.5, 14.5]
"#,
    )
    .unwrap();
    let from_file = dir.join("file.png");
    let (ok, stdout, stderr) = camsim(&[
        "isp",
        "--input",
        inp,
        "--output",
        from_file.to_str().unwrap(),
        "--config",
        config.to_str().unwrap(),
    ]);
    assert!(ok, "{stderr}");
    assert!(
        stdout.contains("stages: black level -> defective pixels -> denoise -> gain -> white balance -> mhc -> highlights -> distortion correction -> colour matrix -> tone -> sRGB encode"),
        "{stdout}"
    );
    assert!(stdout.contains("path: fixed"), "{stdout}");
    assert!(stdout.contains("distortion: k1 -0.3 k2 0.05 p1 0.001 p2 -0.002 k3 0, camera fx 36 fy 36 cx 19.5 cy 14.5, window"), "{stdout}");
    let flags = dir.join("flags.png");
    let (ok, _, stderr) = camsim(&[
        "isp",
        "--input",
        inp,
        "--output",
        flags.to_str().unwrap(),
        "--pattern",
        "GRBG",
        "--bits",
        "12",
        "--black-level",
        "64,64,64,64",
        "--white-level",
        "4095",
        "--gain",
        "1.25",
        "--wb",
        "1.8,1,1.4",
        "--ccm",
        "1.5,-0.3,-0.2,-0.2,1.4,-0.2,0,-0.4,1.4",
        "--demosaic",
        "mhc",
        "--denoise",
        "1.5",
        "--noise-profile",
        "0.004,2e-5",
        "--dpc-threshold",
        "500",
        "--look",
        "vivid",
        "--path",
        "fixed",
        "--distortion",
        "-0.3,0.05,0.001,-0.002",
        "--camera-matrix",
        "36,36,19.5,14.5",
    ]);
    assert!(ok, "{stderr}");
    let a = imageio::read(&from_file).unwrap();
    assert_eq!(a.data, imageio::read(&flags).unwrap().data);
    // The lens really acted: without it the image differs.
    let plain = dir.join("plain.png");
    let (ok, _, stderr) = camsim(&[
        "isp",
        "--input",
        inp,
        "--output",
        plain.to_str().unwrap(),
        "--config",
        config.to_str().unwrap(),
        "--distortion",
        "0,0,0,0",
    ]);
    assert!(ok, "{stderr}");
    assert_ne!(a.data, imageio::read(&plain).unwrap().data);
    // A flag wins over the file.
    let float = dir.join("float.png");
    let (ok, stdout, stderr) = camsim(&[
        "isp",
        "--input",
        inp,
        "--output",
        float.to_str().unwrap(),
        "--config",
        config.to_str().unwrap(),
        "--path",
        "float",
        "--look",
        "neutral",
    ]);
    assert!(ok, "{stderr}");
    assert!(
        stdout.contains("path: float") && !stdout.contains("-> tone ->"),
        "{stdout}"
    );

    // Shading grid and static defects, only in the file.
    std::fs::write(
        &config,
        r#"bits = 12
black-level = 64
defects = [[3, 4], [10, 10]]

[lsc]
grid-width = 2
grid-height = 2
gains = [[1.5, 1.5, 1.5, 1.5], [1.0, 1.0, 1.0, 1.0], [1.0, 1.0, 1.0, 1.0], [1.5, 1.5, 1.5, 1.5]]
"#,
    )
    .unwrap();
    let (ok, stdout, stderr) = camsim(&[
        "isp",
        "--input",
        inp,
        "--output",
        plain.to_str().unwrap(),
        "--config",
        config.to_str().unwrap(),
    ]);
    assert!(ok, "{stderr}");
    assert!(
        stdout.contains(
            "stages: black level -> defective pixels -> lens shading -> directional -> highlights -> sRGB encode"
        ),
        "{stdout}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// Mistakes in a config file name the file, the line and the key, and say what is allowed.
#[test]
fn isp_config_errors_name_file_line_and_key() {
    let dir = std::env::temp_dir().join(format!("camsim-isp-config-err-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let input = ramp_mosaic(&dir);
    let config = dir.join("bad.toml");
    for (text, needle) in [
        (
            "bits = 12\ngian = 2\n",
            "bad.toml:2: gian: unknown key \"gian\"; known keys: pattern",
        ),
        (
            "bits = 12\n\nwb = [1, 2]\n",
            "bad.toml:3: wb: must be 3 finite numbers (got 2)",
        ),
        (
            "pattern = \"RGBG\"\n",
            "bad.toml:1: pattern: must be one of RGGB, BGGR, GRBG, GBRG",
        ),
        (
            "bits = 12\nout-bits = 10\n",
            "bad.toml:2: out-bits: must be 8 or 16 (got 10)",
        ),
        (
            "wb = [1, 1, 1]\nawb = \"grey-world\"\n",
            "awb: give wb or awb, not both",
        ),
        (
            "distortion = [0.1, \"x\", 0, 0]\n",
            "bad.toml:1: distortion: expected numbers",
        ),
        (
            "defects = [[1, 2], [3]]\n",
            "defects: entry 1: expected an [x, y] pair",
        ),
        (
            "[lsc]\ngrid-width = 2\ngrid-height = 2\ngains = [[1, 1, 1, 1]]\n",
            "lsc: gains: expected 2 x 2 = 4 nodes (got 1)",
        ),
        ("bits = \n", "bad.toml"),
        (
            "bits = 12\ncamera-matrix = [10, 10, 5, 5]\n",
            "--camera-matrix needs --distortion",
        ),
        (
            "bits = 12\ndistortion = [0.1, 0, 0, 0]\ncamera-matrix = [0, 10, 5, 5]\n",
            "focal length",
        ),
    ] {
        std::fs::write(&config, text).unwrap();
        let (ok, _, stderr) = camsim(&[
            "isp",
            "--input",
            input.to_str().unwrap(),
            "--output",
            dir.join("out.png").to_str().unwrap(),
            "--config",
            config.to_str().unwrap(),
        ]);
        assert!(!ok && stderr.contains(needle), "{text:?}: {stderr}");
    }
    let (ok, _, stderr) = camsim(&[
        "isp",
        "--input",
        input.to_str().unwrap(),
        "--output",
        "x.png",
        "--config",
        dir.join("missing.toml").to_str().unwrap(),
    ]);
    assert!(!ok && stderr.contains("missing.toml"), "{stderr}");
    std::fs::remove_dir_all(&dir).ok();
}

/// A real camera DNG (14-bit packed samples, masked borders, a colour matrix without a
/// calibration illuminant) develops: the image is the active area, not black at the borders.
#[test]
fn isp_develops_a_real_packed_dng() {
    let input = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../data/real-dng/canon-550d-colorchart-14bit.dng");
    let dir = std::env::temp_dir().join(format!("camsim-isp-real-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let output = dir.join("canon.png");
    let (ok, stdout, stderr) = camsim(&[
        "isp",
        "--input",
        input.to_str().unwrap(),
        "--output",
        output.to_str().unwrap(),
    ]);
    assert!(ok, "{stderr}");
    assert!(stdout.contains("colour matrix"), "{stdout}");
    let rgb = imageio::read(&output).unwrap();
    assert_eq!((rgb.width, rgb.height), (1734, 1156));
    // The masked borders (black) were cropped: the first and last columns see the scene.
    let column_mean = |x: usize| {
        (0..rgb.height)
            .map(|y| rgb.data[3 * (y * rgb.width + x) + 1] as f64)
            .sum::<f64>()
            / rgb.height as f64
    };
    assert!(column_mean(0) > 5.0 && column_mean(rgb.width - 1) > 5.0);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn isp_develops_a_lossless_jpeg_cinema_dng_at_its_default_crop_or_the_active_area() {
    let input = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../data/real-dng/blackmagic-pocket-gbrg-lj92.dng");
    let dir = std::env::temp_dir().join(format!("camsim-isp-lj92-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for (crop, size, says_crop) in [
        (None, (1920, 1080), true),
        (Some("active"), (1952, 1112), false),
    ] {
        let output = dir.join("bmpcc.png");
        let mut args = vec![
            "isp",
            "--input",
            input.to_str().unwrap(),
            "--output",
            output.to_str().unwrap(),
        ];
        if let Some(c) = crop {
            args.extend(["--crop", c]);
        }
        let (ok, stdout, stderr) = camsim(&args);
        assert!(ok, "{stderr}");
        assert_eq!(
            stdout.contains("default crop, 1920x1080 at (16, 16)"),
            says_crop,
            "{stdout}"
        );
        let rgb = imageio::read(&output).unwrap();
        assert_eq!((rgb.width, rgb.height), size);
    }
    let (ok, _, stderr) = camsim(&[
        "isp",
        "--input",
        input.to_str().unwrap(),
        "--output",
        dir.join("x.png").to_str().unwrap(),
        "--crop",
        "all",
    ]);
    assert!(!ok && stderr.contains("--crop"), "{stderr}");
    // BaselineExposure (+0.1 EV) brightens the image unless turned off.
    let mean = |extra: &[&str]| {
        let output = dir.join("exposure.png");
        let mut args = vec![
            "isp",
            "--input",
            input.to_str().unwrap(),
            "--output",
            output.to_str().unwrap(),
        ];
        args.extend(extra);
        let (ok, stdout, stderr) = camsim(&args);
        assert!(ok, "{stderr}");
        assert_eq!(
            stdout.contains("baseline exposure"),
            extra.is_empty(),
            "{stdout}"
        );
        let rgb = imageio::read(&output).unwrap();
        rgb.data.iter().map(|v| f64::from(*v)).sum::<f64>() / rgb.data.len() as f64
    };
    assert!(mean(&[]) > mean(&["--no-baseline-exposure"]) + 0.5);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn bench_dng_reports_its_decode_time_as_json() {
    let input = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../data/real-dng/blackmagic-pocket-gbrg-lj92.dng");
    let (ok, stdout, stderr) = camsim(&[
        "bench",
        "dng",
        "--input",
        input.to_str().unwrap(),
        "--repeats",
        "2",
        "--json",
    ]);
    assert!(ok, "{stderr}");
    let figures: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(figures["width"], 1952);
    assert_eq!(figures["height"], 1112);
    assert!(figures["ms"].as_f64().unwrap() > 0.0);
    assert!(figures["mpix_per_s"].as_f64().unwrap() > 0.0);
    let (ok, _, stderr) = camsim(&[
        "bench",
        "dng",
        "--input",
        input.to_str().unwrap(),
        "--repeats",
        "0",
    ]);
    assert!(!ok && stderr.contains("--repeats"), "{stderr}");
}

/// What `camsim isp` made of a DNG with opcode lists.
struct Developed {
    ok: bool,
    /// The output's samples (empty if the run failed).
    rgb: Vec<u16>,
    stdout: String,
    stderr: String,
}

/// Writes `image` with opcode `lists` as `dir/NAME.dng` and develops it to `dir/NAME.png`
/// with `extra` flags.
fn develop_with_opcodes(
    dir: &std::path::Path,
    image: &raw_formats::RawImage,
    lists: [Vec<raw_formats::dng::opcodes::Opcode>; 3],
    name: &str,
    extra: &[&str],
) -> Developed {
    use raw_formats::dng::{Dng, DngColour, Processing};
    let dng = Dng {
        image: image.clone(),
        camera_model: "opcode test".into(),
        colour: DngColour::default(),
        framing: Default::default(),
        processing: Processing {
            opcode_lists: lists,
            ..Processing::default()
        },
    };
    let input = dir.join(format!("{name}.dng"));
    dng.write(&input).unwrap();
    let output = dir.join(format!("{name}.png"));
    let mut args = vec![
        "isp",
        "--input",
        input.to_str().unwrap(),
        "--output",
        output.to_str().unwrap(),
    ];
    args.extend(extra);
    let (ok, stdout, stderr) = camsim(&args);
    let rgb = if ok {
        imageio::read(&output).unwrap().data
    } else {
        Vec::new()
    };
    Developed {
        ok,
        rgb,
        stdout,
        stderr,
    }
}

/// A DNG's FixBadPixelsList becomes the defect map (the listed hot pixel is corrected), and an
/// opcode the pipeline does not apply yet is named on stderr, not dropped silently.
#[test]
fn isp_corrects_the_bad_pixels_a_dng_lists_and_notes_opcodes_it_leaves_out() {
    use raw_formats::dng::opcodes::Opcode;
    let dir = std::env::temp_dir().join(format!("camsim-isp-opcodes-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (w, h) = (32, 24);
    let mut samples = vec![1000u16; w * h];
    samples[10 * w + 12] = 4095; // a hot red pixel (RGGB: even row, even column)
    let image =
        raw_formats::RawImage::new(w, h, isp_core::CfaPattern::Rggb, 12, [0; 4], 4095, samples)
            .unwrap();
    let listed = Opcode::FixBadPixelsList {
        bayer_phase: 0,
        points: vec![[10, 12]],
        rects: vec![],
    };
    let other = Opcode::Other {
        id: 10,
        optional: true,
    };
    let plain = develop_with_opcodes(&dir, &image, Default::default(), "plain", &[]);
    let listed = develop_with_opcodes(
        &dir,
        &image,
        [vec![listed], vec![other], vec![]],
        "listed",
        &[],
    );
    assert!(plain.ok && listed.ok, "{}{}", plain.stderr, listed.stderr);
    let (hot, fixed) = (plain.rgb[(10 * w + 12) * 3], listed.rgb[(10 * w + 12) * 3]);
    assert!(hot > 200 && fixed < 150, "hot {hot}, corrected {fixed}");
    assert!(
        listed.stdout.contains("defective pixels"),
        "{}",
        listed.stdout
    );
    assert!(
        listed
            .stderr
            .contains("DeltaPerRow opcode (optional) is not applied"),
        "{}",
        listed.stderr
    );
    // The same opcode not marked optional is refused by name.
    let required = Opcode::Other {
        id: 10,
        optional: false,
    };
    let refused = develop_with_opcodes(
        &dir,
        &image,
        [vec![], vec![required], vec![]],
        "required",
        &[],
    );
    assert!(!refused.ok, "an opcode that may not be skipped was skipped");
    assert!(
        refused.stderr.contains("DeltaPerRow (id 10)"),
        "{}",
        refused.stderr
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// A DNG's GainMaps (OpcodeList2, one per CFA position, as phones write them) drive the
/// lens-shading stage: a flat field darkened towards the corners by the inverse of the map
/// develops flat, and without the map it does not.
#[test]
fn isp_applies_a_dngs_gain_maps_as_lens_shading() {
    use raw_formats::dng::opcodes::{GainMap, Opcode};
    let dir = std::env::temp_dir().join(format!("camsim-isp-gainmap-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (w, h) = (96, 64);
    // Gain 1 at the centre rising to 2 at the corners, on a 5 x 7 map over the image.
    let (rows, cols) = (5u32, 7u32);
    let vignette = |u: f64, v: f64| 1.0 + ((u - 0.5).powi(2) + (v - 0.5).powi(2)) * 2.0;
    let gains: Vec<f32> = (0..rows * cols)
        .map(|i| {
            let (r, c) = (f64::from(i / cols), f64::from(i % cols));
            vignette(c / f64::from(cols - 1), r / f64::from(rows - 1)) as f32
        })
        .collect();
    let map = |top: u32, left: u32| {
        Opcode::GainMap(GainMap {
            area: [top, left, h as u32, w as u32],
            plane: 0,
            planes: 1,
            row_pitch: 2,
            col_pitch: 2,
            points: [rows, cols],
            spacing: [1.0 / f64::from(rows - 1), 1.0 / f64::from(cols - 1)],
            origin: [0.0, 0.0],
            map_planes: 1,
            gains: gains.clone(),
        })
    };
    let maps = vec![map(0, 0), map(0, 1), map(1, 0), map(1, 1)];
    let samples: Vec<u16> = (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            // The map of this pixel's CFA position, evaluated at the pixel.
            let Opcode::GainMap(own) = &maps[(y % 2) * 2 + x % 2] else {
                unreachable!()
            };
            let g = own.gain_at(x, y, w, h).unwrap();
            (2000.0 / g).round() as u16
        })
        .collect();
    let image =
        raw_formats::RawImage::new(w, h, isp_core::CfaPattern::Rggb, 12, [0; 4], 4095, samples)
            .unwrap();
    let spread = |lists: [Vec<Opcode>; 3], name: &str| {
        let run = develop_with_opcodes(&dir, &image, lists, name, &[]);
        assert!(run.ok, "{}", run.stderr);
        assert!(!run.stderr.contains("GainMap"), "{}", run.stderr);
        // Green, two pixels in from every edge (demosaicing borders aside).
        let mut greens: Vec<f64> = (2..h - 2)
            .flat_map(|y| (2..w - 2).map(move |x| (x, y)))
            .map(|(x, y)| f64::from(run.rgb[(y * w + x) * 3 + 1]))
            .collect();
        // The 1st to 99th percentile: the grid's bilinear nodes meet the map's own bilinear
        // patches at a few pixels that land one or two codes further out.
        greens.sort_by(f64::total_cmp);
        let n = greens.len();
        (greens[n * 99 / 100] - greens[n / 100], run.stdout)
    };
    let (shaded, _) = spread(Default::default(), "shaded");
    let (corrected, stdout) = spread([vec![], maps, vec![]], "corrected");
    assert!(stdout.contains("lens shading"), "{stdout}");
    assert!(
        shaded > 40.0,
        "the uncorrected vignette spans {shaded} codes"
    );
    assert!(
        corrected <= 3.0,
        "the corrected image still spans {corrected} codes (1st to 99th percentile)"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// OpcodeList3's WarpRectilinear drives the distortion-correction stage: developing a DNG that
/// carries it gives exactly the image the same DNG without it gives with the equivalent
/// `--distortion` and `--camera-matrix` (OpenCV's model, f the centre-to-corner distance).
#[test]
fn isp_corrects_the_distortion_a_dngs_warp_rectilinear_states() {
    use raw_formats::dng::opcodes::{warp_as_opencv, Opcode};
    let dir = std::env::temp_dir().join(format!("camsim-isp-warp-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (w, h) = (64, 48);
    // A grid of bright lines, so a warp moves edges.
    let samples: Vec<u16> = (0..w * h)
        .map(|i| {
            if (i % w) % 8 < 2 || (i / w) % 8 < 2 {
                3500
            } else {
                300
            }
        })
        .collect();
    let image =
        raw_formats::RawImage::new(w, h, isp_core::CfaPattern::Rggb, 12, [0; 4], 4095, samples)
            .unwrap();
    let warp = Opcode::WarpRectilinear {
        planes: vec![[1.0, -0.12, 0.03, 0.0, 0.001, -0.002]],
        centre: [0.5, 0.5],
    };
    let ([k1, k2, p1, p2, k3], [fx, fy, cx, cy]) = warp_as_opencv(&warp, w, h).unwrap();
    let plain = develop_with_opcodes(&dir, &image, Default::default(), "plain", &[]);
    let from_opcode =
        develop_with_opcodes(&dir, &image, [vec![], vec![], vec![warp]], "opcode", &[]);
    let (coefficients, camera) = (
        format!("{k1},{k2},{p1},{p2},{k3}"),
        format!("{fx},{fy},{cx},{cy}"),
    );
    let flags = ["--distortion", &coefficients, "--camera-matrix", &camera];
    let from_flags = develop_with_opcodes(&dir, &image, Default::default(), "flags", &flags);
    for run in [&plain, &from_opcode, &from_flags] {
        assert!(run.ok, "{}", run.stderr);
        assert!(!run.stderr.contains("WarpRectilinear"), "{}", run.stderr);
    }
    assert!(
        from_opcode.stdout.contains("distortion: k1 -0.12"),
        "{}",
        from_opcode.stdout
    );
    assert_eq!(from_opcode.rgb, from_flags.rgb);
    assert_ne!(from_opcode.rgb, plain.rgb);
    std::fs::remove_dir_all(&dir).ok();
}

/// A LinearRaw DNG (already demosaiced), stored uncompressed and as lossy JPEG whose 8-bit
/// codes OpcodeList2's MapPolynomials map back to linear (as Adobe's lossy DNGs do), develops
/// without demosaicing in both paths to the colour it holds; defect correction, which needs a
/// mosaic, is refused by name.
#[test]
fn isp_develops_linear_raw_dngs_uncompressed_and_lossy() {
    use raw_formats::dng::opcodes::{Opcode, Region};
    use raw_formats::dng::{Dng, DngColour, EncodeOptions, Storage};
    let dir = std::env::temp_dir().join(format!("camsim-isp-linear-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (w, h) = (48, 32);
    let linear = [0.4f64, 0.5, 0.3];
    // sRGB codes of those linear values.
    let expected = [170u16, 188, 149];
    let cases = [
        ("u16", 16u8, Storage::Uncompressed { bits: 16 }),
        ("lossy", 8, Storage::LossyJpeg { quality: 95 }),
    ];
    for (name, bits, storage) in cases {
        let lossy = bits == 8;
        let max = f64::from((1u32 << bits) - 1);
        let samples = (0..w * h * 3)
            .map(|i| {
                let v = linear[i % 3];
                ((if lossy { v.sqrt() } else { v }) * max).round() as u16
            })
            .collect();
        let image =
            raw_formats::RawImage::linear_rgb(w, h, bits, [0; 3], max as u16, samples).unwrap();
        let mut dng = Dng {
            image,
            camera_model: "linear test".into(),
            colour: DngColour::default(),
            framing: Default::default(),
            processing: Default::default(),
        };
        if lossy {
            dng.processing.opcode_lists[1] = (0..3)
                .map(|plane| Opcode::MapPolynomial {
                    region: Region {
                        area: [0, 0, h as u32, w as u32],
                        plane,
                        planes: 1,
                        row_pitch: 1,
                        col_pitch: 1,
                    },
                    coefficients: vec![0.0, 0.0, 1.0],
                })
                .collect();
        }
        let options = EncodeOptions {
            storage,
            tile: Some((32, 32)),
            little_endian: true,
        };
        let input = dir.join(format!("{name}.dng"));
        std::fs::write(&input, dng.encode_with(&options).unwrap()).unwrap();
        for path in ["float", "fixed"] {
            let output = dir.join(format!("{name}-{path}.png"));
            let mut args = vec![
                "isp",
                "--input",
                input.to_str().unwrap(),
                "--output",
                output.to_str().unwrap(),
            ];
            args.extend(["--path", path]);
            let (ok, stdout, stderr) = camsim(&args);
            assert!(ok, "{name} {path}: {stderr}");
            assert!(stdout.contains("no demosaicing"), "{stdout}");
            let rgb = imageio::read(&output).unwrap();
            assert_eq!((rgb.width, rgb.height), (w, h));
            for (i, v) in rgb.data.iter().enumerate() {
                let want = expected[i % 3];
                assert!(
                    v.abs_diff(want) <= if lossy { 2 } else { 1 },
                    "{name} {path} sample {i}: {v}, expected {want}"
                );
            }
        }
        let (ok, _, stderr) = camsim(&[
            "isp",
            "--input",
            input.to_str().unwrap(),
            "--output",
            dir.join("dpc.png").to_str().unwrap(),
            "--dpc-threshold",
            "100",
        ]);
        assert!(
            !ok && stderr.contains("linear (already demosaiced)"),
            "{stderr}"
        );
        // A black level per channel is taken; one per CFA position is not.
        let out = dir.join("black.png");
        let black = |values: &str| {
            camsim(&[
                "isp",
                "--input",
                input.to_str().unwrap(),
                "--output",
                out.to_str().unwrap(),
                "--black-level",
                values,
            ])
        };
        let (ok, _, stderr) = black("0,0,0");
        assert!(ok, "{stderr}");
        let (ok, _, stderr) = black("0,0,0,0");
        assert!(!ok && stderr.contains("three (R, G, B)"), "{stderr}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// `camsim bench isp` times the pipeline on its synthesised 2592 x 1968 frame and reports it
/// beside a plain copy and, through the oracle environment, the OpenCV pipeline; without that
/// environment it still times the pipeline and says on stderr that the peer was skipped.
#[test]
fn bench_isp_reports_the_pipeline_beside_its_peers() {
    let args = [
        "bench",
        "isp",
        "--json",
        "--repeats",
        "1",
        "--threads",
        "1",
        "--path",
        "fixed",
        "--demosaic",
        "mhc",
        "--dpc-threshold",
        "64",
        "--wb",
        "1.9,1,1.6",
    ];
    let run = |python: Option<&str>| {
        let mut command = std::process::Command::new(env!("CARGO_BIN_EXE_camsim"));
        command.args(args);
        if let Some(p) = python {
            command.env("CAMSIM_ORACLE_PYTHON", p);
        }
        let out = command.output().unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let figures: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        (figures, String::from_utf8_lossy(&out.stderr).into_owned())
    };
    let check = |f: &serde_json::Value| {
        assert_eq!(
            (f["width"].as_u64(), f["height"].as_u64()),
            (Some(2592), Some(1968))
        );
        assert_eq!(f["threads"], 1);
        assert_eq!(f["path"], "fixed");
        let ms = f["ms_per_frame"].as_f64().unwrap();
        let mpix = f["mpix_per_s"].as_f64().unwrap();
        assert!(
            ms > 0.0 && (mpix * ms * 1e3 - 2592.0 * 1968.0).abs() < 1.0,
            "{f}"
        );
        assert!(f["copy"]["ms_per_frame"].as_f64().unwrap() > 0.0, "{f}");
        assert!(f["develop_ms"].as_f64().is_some_and(|v| v > 0.0), "{f}");
        assert!(f["stages"]
            .as_array()
            .unwrap()
            .iter()
            .any(|s| s == "defective pixels"));
    };
    // With the oracle environment (required in CI), the OpenCV peer runs.
    let (figures, stderr) = run(None);
    check(&figures);
    if std::env::var_os("CAMSIM_REQUIRE_ORACLE").is_some() {
        let opencv = &figures["opencv"];
        assert!(
            opencv["ms_per_frame"].as_f64().is_some_and(|v| v > 0.0),
            "{figures} {stderr}"
        );
        assert!(
            opencv["time_ratio"].as_f64().is_some_and(|v| v > 0.0),
            "{figures}"
        );
    }
    // Without it, the pipeline alone, and a note.
    let (figures, stderr) = run(Some("/nonexistent/python"));
    check(&figures);
    assert!(figures["opencv"].is_null(), "{figures}");
    assert!(stderr.contains("OpenCV peer was skipped"), "{stderr}");
}

/// The noise profile: `--noise-profile` wins over the file's NoiseProfile tag, which wins over
/// an estimate from the frame; the text report and `--json` name the source; a malformed
/// profile is refused naming the flag (or the config file's key).
#[test]
fn isp_resolves_and_reports_the_noise_profile() {
    use host_tracer::random::Rng;
    use host_tracer::sensor::pixel;
    use isp_core::noise::NoiseProfile;
    use raw_formats::dng::{Dng, Processing};
    let dir = common::temp_dir("isp-noise");
    let (w, h) = (320usize, 256usize);
    let (scale, offset) = (0.004, 2e-5);
    let mut rng = Rng::new(5, 1);
    let samples: Vec<u16> = (0..w * h)
        .map(|i| {
            let truth = 0.05 + 0.8 * (i % w) as f64 / w as f64;
            let noisy = truth + (scale * truth + offset).sqrt() * pixel::normal(&mut rng);
            (256.0 + noisy * 3839.0).round().clamp(0.0, 4095.0) as u16
        })
        .collect();
    let pgm = dir.join("noisy.pgm");
    let image = Image {
        width: w,
        height: h,
        channels: 1,
        bits: 16,
        data: samples.clone(),
    };
    imageio::write(&pgm, &image).unwrap();
    let raw = raw_formats::RawImage::new(
        w,
        h,
        isp_core::CfaPattern::Rggb,
        12,
        [256; 4],
        4095,
        samples,
    )
    .unwrap();
    let stated = NoiseProfile::uniform(0.0035, 1.5e-5).unwrap();
    let dng = dir.join("noisy.dng");
    Dng {
        image: raw,
        camera_model: "noise test".into(),
        colour: Default::default(),
        framing: Default::default(),
        processing: Processing {
            noise_profile: Some(stated),
            ..Processing::default()
        },
    }
    .write(&dng)
    .unwrap();
    let out = dir.join("out.png");
    // `camsim isp` on `input` with `extra` flags: success, stdout, stderr.
    let isp = |input: &std::path::Path, extra: &[&str]| {
        let mut args = vec![
            "isp",
            "--input",
            input.to_str().unwrap(),
            "--output",
            out.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        camsim(&args)
    };
    let json = |extra: &[&str], input: &std::path::Path| {
        let (ok, stdout, stderr) = isp(input, &[extra, &["--json"]].concat());
        assert!(ok, "{extra:?}: {stderr}");
        let v: serde_json::Value = serde_json::from_str(&stdout).unwrap();
        v["noise_profile"].clone()
    };
    // A plain mosaic: estimated, near the truth.
    let pgm_args = [
        "--bits",
        "12",
        "--black-level",
        "256",
        "--white-level",
        "4095",
    ];
    let estimated = json(&pgm_args, &pgm);
    assert_eq!(estimated["source"], "estimated");
    let s = estimated["scale"][1].as_f64().unwrap();
    assert!((s / scale - 1.0).abs() < 0.2, "estimated S {s}");
    // The DNG's tag, exactly.
    let file = json(&[], &dng);
    assert_eq!(file["source"], "file");
    assert_eq!(file["scale"][0].as_f64(), Some(0.0035));
    assert_eq!(file["offset"][2].as_f64(), Some(1.5e-5));
    // The flag wins, per colour.
    let flag = ["--noise-profile", "0.001,1e-6,0.002,2e-6,0.003,3e-6"];
    let given = json(&flag, &dng);
    assert_eq!(given["source"], "option");
    assert_eq!(given["scale"][2].as_f64(), Some(0.003));
    // The text report says the same.
    let (ok, text, _) = isp(&dng, &[]);
    assert!(
        ok && text.contains("from the file's NoiseProfile tag"),
        "{text}"
    );
    // From a config file, and refusals.
    let config = dir.join("noise.toml");
    std::fs::write(&config, "noise-profile = [0.002, 3e-6]\n").unwrap();
    let from_config = json(&["--config", config.to_str().unwrap()], &dng);
    assert_eq!(from_config["scale"][1].as_f64(), Some(0.002));
    for bad in ["0.001", "-0.1,0", "0.001,nan", "0,0"] {
        let (ok, _, stderr) = isp(&dng, &["--noise-profile", bad]);
        assert!(!ok && stderr.contains("--noise-profile"), "{bad}: {stderr}");
    }
    std::fs::write(&config, "noise-profile = [0.002]\n").unwrap();
    let (ok, _, stderr) = isp(&dng, &["--config", config.to_str().unwrap()]);
    assert!(!ok && stderr.contains("noise-profile"), "{stderr}");
    std::fs::remove_dir_all(&dir).ok();
}

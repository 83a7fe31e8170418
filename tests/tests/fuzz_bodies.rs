//! The fuzz targets' bodies on random bytes (the deep runs are `cargo +nightly fuzz run`).

use camsim_tests::fuzz_bodies::*;
use proptest::prelude::*;

proptest! {
    #![proptest_config(ProptestConfig::with_cases(4000))]

    #[test]
    fn scalar(data in proptest::collection::vec(any::<u8>(), 0..48)) { optics_scalar(&data); }

    #[test]
    fn fixed(data in proptest::collection::vec(any::<u8>(), 0..40)) { optics_fixed(&data); }

    #[test]
    fn bitmap(data in proptest::collection::vec(any::<u8>(), 0..1700)) { bitmap_aperture(&data); }

    #[test]
    fn distortion(data in proptest::collection::vec(any::<u8>(), 0..64)) { distortion_inverse(&data); }

    #[test]
    fn prescription(data in proptest::collection::vec(any::<u8>(), 0..400)) { lens_prescription(&data); }
}

/// Scene-like text: lines of `key = value` and table headers from the scene format's
/// vocabulary, so the parser's deeper checks are reached, not only its syntax errors.
fn scene_text() -> impl Strategy<Value = String> {
    let key = prop::sample::select(vec![
        "position",
        "target",
        "up",
        "fov_deg",
        "f_number",
        "focus_distance",
        "aperture_radius_mm",
        "type",
        "center",
        "radius",
        "corners",
        "material",
        "emission",
        "motion",
        "min",
        "max",
        "to_world",
        "rgb",
        "colorchecker",
        "illuminant",
        "luminance",
        "width",
        "height",
        "spp",
        "max_depth",
        "shutter",
        "chromatic_aberration",
        "distortion",
        "sensor_width_mm",
    ]);
    let value = prop::sample::select(vec![
        "[0, 0, 5]",
        "[0, 0, 0]",
        "[0, 1, 0]",
        "40",
        "-1",
        "0",
        "1e30",
        "nan",
        "2.8",
        "\"sphere\"",
        "\"quad\"",
        "\"box\"",
        "\"m\"",
        "{ rgb = [1, 1, 1] }",
        "[[0,0,0],[1,0,0],[1,1,0],[0,1,0]]",
        "[1, 1]",
        "\"D65\"",
        "\"dark skin\"",
        "[0.1, 0.0, 0.0, 0.0]",
        "[[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]",
        "{ illuminant = \"A\", luminance = 1e38 }",
        "[-1, -1, -1]",
        "0.5",
    ]);
    let header = prop::sample::select(vec![
        "[camera]",
        "[[shape]]",
        "[materials]",
        "[film]",
        "[environment]",
    ]);
    let line = prop_oneof![
        (key, value).prop_map(|(k, v)| format!("{k} = {v}")),
        header.prop_map(str::to_string),
        Just("m = { rgb = [0.5, 0.5, 0.5] }".to_string()),
    ];
    proptest::collection::vec(line, 0..24).prop_map(|lines| {
        format!(
            "[camera]\nposition = [0, 0, 5]\ntarget = [0, 0, 0]\n{}",
            lines.join("\n")
        )
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(1000))]

    #[test]
    fn chart_frames(data in proptest::collection::vec(any::<u8>(), 6..300)) { chart_detection(&data); }

    #[test]
    fn scene_bytes(data in proptest::collection::vec(any::<u8>(), 0..200)) { scene_file(&data); }

    #[test]
    fn scene_texts(text in scene_text()) { scene_file(text.as_bytes()); }

    #[test]
    fn dng_bytes(data in proptest::collection::vec(any::<u8>(), 0..400)) { dng_decode(&data); }

    #[test]
    fn dng_damaged(flips in proptest::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..6)) {
        let mut bytes = valid_dng();
        for (i, v) in flips {
            let at = i.index(bytes.len());
            bytes[at] = v;
        }
        dng_decode(&bytes);
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(1000))]

    #[test]
    fn isp(data in proptest::collection::vec(any::<u8>(), 12..400)) { isp_pipeline(&data); }

    #[test]
    fn directional(data in proptest::collection::vec(any::<u8>(), 3..600)) { demosaic_directional(&data); }
}

/// Realistic values, which random bytes rarely produce: the bodies must accept them.
#[test]
fn bodies_accept_realistic_values() {
    let bytes = |xs: &[f64]| xs.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
    optics_scalar(&bytes(&[50.0, 2.8, 0.03, 3000.0, 2000.0]));
    distortion_inverse(&bytes(&[-0.2, 0.05, 0.0, 0.001, -0.001, 0.4, -0.3]));
    // A 12x10 RGGB 12-bit frame, gain 1.5, a barrel lens switched on.
    let mut isp = vec![11, 9, 1, 4, 0, 0xff, 0x0f, 4, 2, 3, 1, 1];
    isp.extend(bytes(&[
        1.5, 1.8, 0.05, 12.0, 12.0, 5.5, 4.5, -0.2, 0.02, 0.001, 0.0, 0.0,
    ]));
    isp.extend((0..200u32).map(|i| (i * 37 % 256) as u8));
    isp_pipeline(&isp);
    // A 33x21 16-bit GRBG mosaic, and a flat 8-bit one.
    let mut mosaic = vec![32, 20, 6];
    mosaic.extend((0..1400u32).map(|i| (i * 97 % 251) as u8));
    demosaic_directional(&mosaic);
    demosaic_directional(&[9, 9, 1, 77]);
    let mut mask = vec![8, 8, 100, 200, 255];
    mask.extend([255u8; 64]);
    bitmap_aperture(&mask);
    scene_file(host_tracer::tracer::scene_file::BUILT_IN[0].1.as_bytes());
    scene_file(host_tracer::tracer::scene_file::BUILT_IN[1].1.as_bytes());
}

/// Every input a fuzzer once crashed on, replayed through its target's body. Files in
/// `tests/fuzz-regressions/` are named `TARGET-what.bin`.
#[test]
fn fuzz_regressions_stay_fixed() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz-regressions");
    let mut replayed = 0;
    for entry in std::fs::read_dir(&dir).expect("tests/fuzz-regressions exists") {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_string_lossy().to_string();
        let data = std::fs::read(&path).unwrap();
        let body: fn(&[u8]) = match name.split('-').next().unwrap() {
            "optics_scalar" => optics_scalar,
            "optics_fixed" => optics_fixed,
            "bitmap_aperture" => bitmap_aperture,
            "distortion_inverse" => distortion_inverse,
            "lens_prescription" => lens_prescription,
            "isp_pipeline" => isp_pipeline,
            "demosaic_directional" => demosaic_directional,
            other => panic!("{name}: no fuzz target named {other}"),
        };
        body(&data);
        replayed += 1;
    }
    assert!(
        replayed >= 2,
        "expected the saved regressions, found {replayed}"
    );
}

fn valid_dng() -> Vec<u8> {
    use raw_formats::dng::{ColourCalibration, Dng, DngColour, Illuminant};
    Dng {
        image: raw_formats::RawImage::new(
            6,
            4,
            isp_core::CfaPattern::Grbg,
            10,
            [64, 65, 66, 67],
            1023,
            (0..24).map(|i| i * 40).collect(),
        )
        .unwrap(),
        camera_model: "fuzz".into(),
        colour: DngColour {
            calibrations: vec![ColourCalibration::new(
                Illuminant::D65,
                [[1.0, 0.1, 0.0], [0.0, 1.0, 0.1], [0.1, 0.0, 1.0]],
            )],
            as_shot_neutral: Some([0.5, 1.0, 0.7]),
            ..DngColour::default()
        },
        framing: Default::default(),
        processing: Default::default(),
    }
    .encode()
    .unwrap()
}

#[test]
fn dng_seed_decodes() {
    dng_decode(&valid_dng());
    assert!(raw_formats::dng::Dng::decode(&valid_dng()).is_ok());
}

/// The committed seed corpus (`fuzz/seeds/TARGET/`) is exactly what
/// `raw_formats::fuzzing::seed_corpus` makes, so it follows the writer; set
/// `CAMSIM_WRITE_FUZZ_SEEDS=1` to rewrite it after changing either.
#[test]
fn seed_corpus_is_committed_and_current() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz/seeds");
    let write = std::env::var_os("CAMSIM_WRITE_FUZZ_SEEDS").is_some();
    let seeds = raw_formats::fuzzing::seed_corpus();
    assert!(seeds.len() >= 40, "{} seeds", seeds.len());
    for (target, name, bytes) in &seeds {
        let path = root.join(target).join(name);
        if write {
            std::fs::create_dir_all(path.parent().unwrap()).unwrap();
            std::fs::write(&path, bytes).unwrap();
        }
        let committed = std::fs::read(&path).unwrap_or_else(|e| {
            panic!(
                "{}: {e} (CAMSIM_WRITE_FUZZ_SEEDS=1 makes it)",
                path.display()
            )
        });
        assert!(
            &committed == bytes,
            "{} differs from seed_corpus()",
            path.display()
        );
    }
}

/// Every committed corpus file (seeds, and what fuzz runs found and were added) replays
/// through its target's body; the DNG seeds all decode, so the fuzzer starts past the header
/// checks, and so do the lossless JPEG seeds.
#[test]
fn committed_corpus_replays_through_the_decoders() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz/seeds");
    let mut decoded = 0;
    for (target, body) in [
        ("dng_decode", dng_decode as fn(&[u8])),
        ("lossless_jpeg", lossless_jpeg_decode),
        ("opcode_list", opcode_list),
        ("dct_jpeg", dct_jpeg_decode),
    ] {
        for entry in std::fs::read_dir(root.join(target)).expect("fuzz/seeds/TARGET exists") {
            let data = std::fs::read(entry.unwrap().path()).unwrap();
            body(&data);
            let ok = match target {
                "dng_decode" => raw_formats::dng::Dng::decode(&data).is_ok(),
                "opcode_list" => raw_formats::dng::opcodes::parse(&data).is_ok(),
                "dct_jpeg" => raw_formats::dct_jpeg::frame(&data).is_ok_and(|f| {
                    raw_formats::dct_jpeg::decode(&data, &mut vec![0; f.sample_count()]).is_ok()
                }),
                _ => raw_formats::lossless_jpeg::frame(&data).is_ok_and(|f| {
                    raw_formats::lossless_jpeg::decode(&data, &mut vec![0; f.sample_count()])
                        .is_ok()
                }),
            };
            decoded += usize::from(ok);
        }
    }
    // The generated seeds, the DCT JPEGs libjpeg-turbo wrote (three) and the lossy CinemaDNG.
    let seeds = raw_formats::fuzzing::seed_corpus().len() + 4;
    assert!(decoded >= seeds, "{decoded} of the {seeds} seeds decode");
}

/// The committed DCT seeds: JPEGs and a lossy CinemaDNG that libjpeg-turbo wrote (through
/// `tests/oracle/oracle.py`'s `dct_dng_write`), which camsim has no encoder to generate.
fn written_dct_seeds() -> Vec<(&'static str, Vec<u8>)> {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz/seeds");
    let mut seeds: Vec<(&'static str, Vec<u8>)> = std::fs::read_dir(root.join("dct_jpeg"))
        .expect("fuzz/seeds/dct_jpeg")
        .map(|e| ("dct_jpeg", std::fs::read(e.unwrap().path()).unwrap()))
        .collect();
    seeds.push((
        "dng_decode",
        std::fs::read(root.join("dng_decode/lossy-dct-cinemadng.dng")).unwrap(),
    ));
    seeds
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    /// The DCT seeds with a few bytes changed, cut short, or with random bytes appended, never
    /// break the decoders' contracts (an image or an error; no panic, no hang).
    #[test]
    fn damaged_dct_seeds_never_break_the_decoders(
        pick in any::<prop::sample::Index>(),
        changes in proptest::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..6),
        cut in any::<prop::sample::Index>(),
        tail in proptest::collection::vec(any::<u8>(), 0..16),
    ) {
        let seeds = written_dct_seeds();
        let (target, bytes) = &seeds[pick.index(seeds.len())];
        let mut data = bytes.clone();
        for (at, value) in &changes {
            let i = at.index(data.len());
            data[i] = *value;
        }
        let body = if *target == "dct_jpeg" { dct_jpeg_decode as fn(&[u8]) } else { dng_decode };
        body(&data);
        let mut short = bytes[..cut.index(bytes.len())].to_vec();
        body(&short);
        short.extend_from_slice(&tail);
        body(&short);
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(3000))]

    /// Random bytes, and seeds with a few bytes changed, never break the decoders' contracts.
    #[test]
    fn damaged_seeds_never_break_the_decoders(
        pick in any::<prop::sample::Index>(),
        changes in proptest::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..6),
        noise in proptest::collection::vec(any::<u8>(), 0..64),
    ) {
        let seeds = raw_formats::fuzzing::seed_corpus();
        let (target, _, bytes) = &seeds[pick.index(seeds.len())];
        let mut data = bytes.clone();
        for (at, value) in &changes {
            let i = at.index(data.len());
            data[i] = *value;
        }
        match *target {
            "dng_decode" => dng_decode(&data),
            "opcode_list" => opcode_list(&data),
            _ => lossless_jpeg_decode(&data),
        }
        opcode_list(&noise);
        lossless_jpeg_decode(&noise);
        dng_decode(&noise);
    }
}

/// What the long fuzz runs found (`fuzz/found/TARGET.bin`, packed by
/// `scripts/pack-fuzz-corpus.py` after `cargo fuzz cmin`) replays through each body: thousands
/// of inputs that reach deep into the decoders, each a frame or an error, never a panic.
#[test]
fn inputs_the_fuzzers_found_replay_through_the_decoders() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz/found");
    for (target, body, least) in [
        ("dng_decode", dng_decode as fn(&[u8]), 1000),
        ("lossless_jpeg", lossless_jpeg_decode, 1000),
        ("opcode_list", opcode_list, 100),
    ] {
        let packed =
            std::fs::read(root.join(format!("{target}.bin"))).expect("fuzz/found/TARGET.bin");
        let mut rest = packed.as_slice();
        let mut replayed = 0;
        while !rest.is_empty() {
            let (len, tail) = rest.split_at(4);
            let len = u32::from_le_bytes(len.try_into().unwrap()) as usize;
            let (input, tail) = tail.split_at(len);
            body(input);
            replayed += 1;
            rest = tail;
        }
        assert!(replayed >= least, "{target}: {replayed} inputs");
    }
}

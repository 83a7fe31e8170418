//! Bodies of this crate's fuzz targets and their seed corpus. `fuzz/` runs the bodies under
//! libFuzzer (so these targets depend on this crate alone) and the test suite runs them on
//! random bytes and on the committed corpus; each panics only if a decoder broke its contract.
//!
//! [`seed_corpus`] makes the valid files each target starts from: DNGs of every layout the
//! reader supports (8- to 16-bit packed and lossless-JPEG samples, strips and padded tiles,
//! both byte orders, linearisation, black-level repeats and deltas, crops and orientations;
//! LinearRaw images uncompressed, lossless and lossy JPEG, with OpcodeList2 maps)
//! and lossless JPEG streams of every predictor, component count and restart spacing. Random
//! bytes rarely get past a TIFF header's checks, so a fuzzer started from nothing never
//! reaches the decoders behind them.

use isp_core::CfaPattern;

use crate::dct_jpeg;
use crate::dng::opcodes::{self, GainMap, Opcode, Region};
use crate::dng::write::{long, short, srational};
use crate::dng::{
    tags, ColourCalibration, Crop, Dng, DngColour, EncodeOptions, Framing, Illuminant, Orientation,
    Processing, Storage,
};
use crate::lossless_jpeg::{self, Frame};
use crate::raw_image::RawImage;

/// DNG files: any bytes are a frame or an error (never a panic or a huge allocation); a frame
/// that decodes is consistent (as many samples as pixels, black below white, the crop inside
/// the image) and encodes back to bytes that decode to the same frame.
pub fn dng_decode(data: &[u8]) {
    if let Ok(dng) = Dng::decode(data) {
        let image = &dng.image;
        assert_eq!(
            image.samples.len(),
            image.width * image.height * usize::from(image.samples_per_pixel)
        );
        assert!(image.black_level.iter().all(|b| *b < image.white_level));
        if let Some(crop) = dng.framing.default_crop {
            assert!(crop.check(image.width, image.height).is_ok());
        }
        // The writer refuses only what it cannot express (e.g. a neutral below 1e-6).
        if let Ok(bytes) = dng.encode() {
            let back = Dng::decode(&bytes).expect("the writer's output decodes");
            assert_eq!(back.image, dng.image);
        }
    }
}

/// Opcode lists: any bytes are a list or an error (never a panic or an allocation the bytes do
/// not justify); a list that parses encodes back to bytes that parse to the same list.
pub fn opcode_list(data: &[u8]) {
    if let Ok(list) = opcodes::parse(data) {
        let again = opcodes::parse(&opcodes::encode(&list)).expect("an encoded list parses");
        assert_eq!(again, list);
    }
}

/// Lossless JPEG streams: any bytes are samples or an error; samples that decode and fit the
/// frame's precision encode back (predictor 1) to a stream that decodes to the same samples.
pub fn lossless_jpeg_decode(data: &[u8]) {
    let Ok(frame) = lossless_jpeg::frame(data) else {
        return;
    };
    // The DNG reader's bound: each sample costs at least one bit of the stream.
    if frame.sample_count() > data.len().saturating_mul(8) {
        return;
    }
    let mut out = vec![0u16; frame.sample_count()];
    let Ok(decoded) = lossless_jpeg::decode(data, &mut out) else {
        return;
    };
    let max = (1u32 << decoded.precision) - 1;
    if decoded == frame && out.iter().all(|v| u32::from(*v) <= max) {
        let bytes = lossless_jpeg::encode(&out, frame, 1, 0, 0).expect("decoded samples encode");
        let mut back = vec![0u16; out.len()];
        lossless_jpeg::decode(&bytes, &mut back).expect("the encoder's output decodes");
        assert_eq!(back, out);
    }
}

/// DCT JPEG streams (Compression 7's lossy form): any bytes are samples within the frame's
/// precision or an error, never a panic or a hang; decoding twice gives the same samples.
pub fn dct_jpeg_decode(data: &[u8]) {
    let Ok(frame) = dct_jpeg::frame(data) else {
        return;
    };
    // The DNG reader's bound: each 8x8 block costs at least two bits of the stream.
    if frame.block_count() > data.len().saturating_mul(4) {
        return;
    }
    let mut out = vec![0u16; frame.sample_count()];
    let Ok(decoded) = dct_jpeg::decode(data, &mut out) else {
        return;
    };
    assert_eq!(decoded, frame);
    let max = (1u32 << decoded.precision) - 1;
    assert!(
        out.iter().all(|v| u32::from(*v) <= max),
        "a sample above the precision"
    );
    let mut again = vec![0u16; out.len()];
    dct_jpeg::decode(data, &mut again).expect("a stream that decoded decodes again");
    assert_eq!(again, out);
}

/// A 20 x 12 frame (tiles of 16 leave partial tiles on both edges) with a gradient, noise and
/// clipped highlights, `bits` deep.
fn seed_image(bits: u8, pattern: CfaPattern) -> RawImage {
    let (w, h) = (20usize, 12usize);
    let max = (1u32 << bits) - 1;
    let samples = (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let v = (x * 97 + y * 331 + (i * 2654435761) % 61) as u32 * max / 4000;
            if (x + y) % 17 == 0 {
                max as u16
            } else {
                v.min(max) as u16
            }
        })
        .collect();
    RawImage::new(
        w,
        h,
        pattern,
        bits,
        [max as u16 / 16; 4],
        max as u16,
        samples,
    )
    .expect("a valid seed image")
}

fn seed_dng(bits: u8, pattern: CfaPattern, framing: Framing) -> Dng {
    Dng {
        image: seed_image(bits, pattern),
        camera_model: "camsim seed".into(),
        colour: DngColour {
            calibrations: vec![
                ColourCalibration::new(
                    Illuminant::A,
                    [[0.9, -0.2, 0.1], [-0.3, 1.2, 0.05], [0.0, 0.1, 0.7]],
                ),
                ColourCalibration::new(
                    Illuminant::D65,
                    [[1.1, -0.4, 0.0], [-0.5, 1.3, 0.2], [-0.1, 0.2, 0.9]],
                ),
            ],
            as_shot_neutral: Some([0.5, 1.0, 0.7]),
            ..DngColour::default()
        },
        framing,
        processing: Default::default(),
    }
}

/// The seed corpus: (target, file name, bytes) for every kind of input the decoders take.
pub fn seed_corpus() -> Vec<(&'static str, String, Vec<u8>)> {
    let mut seeds = Vec::new();
    let framing = Framing {
        default_crop: Some(Crop {
            left: 2,
            top: 2,
            width: 16,
            height: 8,
        }),
        orientation: Orientation::Rotate90,
    };
    let storages = [
        ("u16", 16, Storage::Uncompressed { bits: 16 }),
        ("u8", 8, Storage::Uncompressed { bits: 8 }),
        ("packed10", 10, Storage::Uncompressed { bits: 10 }),
        ("packed12", 12, Storage::Uncompressed { bits: 12 }),
        ("packed14", 14, Storage::Uncompressed { bits: 14 }),
        (
            "lj92-1c",
            12,
            Storage::LosslessJpeg {
                components: 1,
                predictor: 1,
            },
        ),
        (
            "lj92-2c",
            14,
            Storage::LosslessJpeg {
                components: 2,
                predictor: 6,
            },
        ),
    ];
    for (name, bits, storage) in storages {
        for (layout, tile) in [("strip", None), ("tiles", Some((16, 16)))] {
            for (order, little_endian) in [("ii", true), ("mm", false)] {
                let dng = seed_dng(bits, CfaPattern::Rggb, framing);
                let options = EncodeOptions {
                    storage,
                    tile,
                    little_endian,
                };
                let bytes = dng.encode_with(&options).expect("seed DNGs encode");
                seeds.push(("dng_decode", format!("{name}-{layout}-{order}.dng"), bytes));
            }
        }
        // The raw in a SubIFD behind a preview, as Adobe's converter writes.
        if name == "lj92-2c" || name == "packed12" {
            let options = EncodeOptions {
                storage,
                tile: Some((16, 16)),
                little_endian: true,
            };
            let dng = seed_dng(bits, CfaPattern::Rggb, framing);
            let bytes = dng.encode_with_preview(&options).expect("seed DNGs encode");
            seeds.push(("dng_decode", format!("{name}-subifd.dng"), bytes));
        }
    }
    // Tags the writer does not write by itself: linearisation, black-level patterns, an
    // active area.
    let dng = seed_dng(12, CfaPattern::Gbrg, Framing::default());
    let options = EncodeOptions {
        storage: Storage::LosslessJpeg {
            components: 2,
            predictor: 1,
        },
        tile: Some((16, 16)),
        little_endian: true,
    };
    let table: Vec<u16> = (0..4096u32).map(|v| (v * v / 256) as u16).collect();
    let extras = [
        (
            "linearised",
            vec![
                short(tags::LINEARIZATION_TABLE, &table),
                long(tags::WHITE_LEVEL, &[65535]),
            ],
        ),
        (
            "black-deltas",
            vec![
                short(tags::BLACK_LEVEL_REPEAT_DIM, &[1, 3]),
                short(tags::BLACK_LEVEL, &[100, 110, 120]),
                srational(tags::BLACK_LEVEL_DELTA_H, &[1.5; 20]),
                srational(tags::BLACK_LEVEL_DELTA_V, &[-0.5; 12]),
            ],
        ),
        (
            "active-area",
            vec![long(tags::ACTIVE_AREA, &[2, 2, 10, 18])],
        ),
    ];
    for (name, entries) in extras {
        let bytes = dng
            .encode_with_entries(&options, entries)
            .expect("seed DNGs encode");
        seeds.push(("dng_decode", format!("{name}.dng"), bytes));
    }
    // LinearRaw (already demosaiced): each storage, and lossy JPEG mapped to linear by
    // OpcodeList2 polynomials and a table, as Adobe's lossy DNGs are.
    let linear = |bits: u8| {
        let mut dng = seed_dng(bits, CfaPattern::Rggb, framing);
        let cfa = dng.image;
        let samples = cfa
            .samples
            .iter()
            .enumerate()
            .flat_map(|(i, v)| [*v, cfa.samples[(i + 7) % cfa.samples.len()], v / 2])
            .collect();
        let black = cfa.black_level[0];
        dng.image = RawImage::linear_rgb(
            cfa.width,
            cfa.height,
            bits,
            [black; 3],
            cfa.white_level,
            samples,
        )
        .expect("a valid linear seed");
        dng
    };
    let linear_storages = [
        ("u16", 16, Storage::Uncompressed { bits: 16 }),
        ("packed12", 12, Storage::Uncompressed { bits: 12 }),
        (
            "lj92-3c",
            14,
            Storage::LosslessJpeg {
                components: 3,
                predictor: 4,
            },
        ),
        ("lossy", 8, Storage::LossyJpeg { quality: 90 }),
    ];
    for (name, bits, storage) in linear_storages {
        let mut dng = linear(bits);
        if name == "lossy" {
            let region = |plane| Region {
                area: [0, 0, 12, 20],
                plane,
                planes: 1,
                row_pitch: 1,
                col_pitch: 1,
            };
            dng.processing.opcode_lists[1] = vec![
                Opcode::MapPolynomial {
                    region: region(0),
                    coefficients: vec![0.0, 0.3, 0.7],
                },
                Opcode::MapPolynomial {
                    region: region(1),
                    coefficients: vec![0.0, 0.0, 1.0],
                },
                Opcode::MapTable {
                    region: region(2),
                    table: (0..256u32).map(|v| (v * v) as u16).collect(),
                },
            ];
        }
        for (layout, tile) in [("strip", None), ("tiles", Some((16, 16)))] {
            let options = EncodeOptions {
                storage,
                tile,
                little_endian: layout == "strip",
            };
            let bytes = dng.encode_with(&options).expect("seed DNGs encode");
            seeds.push(("dng_decode", format!("linear-{name}-{layout}.dng"), bytes));
        }
    }
    let lists = seed_opcode_lists();
    let mut with_opcodes = seed_dng(12, CfaPattern::Bggr, Framing::default());
    with_opcodes.processing = Processing {
        baseline_exposure: Some(0.25),
        opcode_lists: lists.clone(),
        noise_profile: isp_core::noise::NoiseProfile::new([0.003, 0.0032, 0.0035], [1e-6; 3]).ok(),
        ..Processing::default()
    };
    let bytes = with_opcodes
        .encode_with(&EncodeOptions::default())
        .expect("seed DNGs encode");
    seeds.push(("dng_decode", "opcodes.dng".into(), bytes));
    for (i, list) in lists.iter().enumerate() {
        seeds.push((
            "opcode_list",
            format!("list{}.bin", i + 1),
            opcodes::encode(list),
        ));
    }
    for components in 1..=4u8 {
        for predictor in 1..=7u8 {
            let frame = Frame {
                precision: [8, 12, 14, 16][usize::from(components) - 1],
                lines: 6,
                samples_per_line: 8,
                components,
            };
            let image = seed_image(frame.precision.max(8), CfaPattern::Rggb);
            let samples = &image.samples[..frame.sample_count()];
            let restart = u16::from(predictor % 3);
            let bytes = lossless_jpeg::encode(samples, frame, predictor, 0, restart)
                .expect("seed streams encode");
            seeds.push((
                "lossless_jpeg",
                format!("p{predictor}-c{components}-r{restart}.ljpg"),
                bytes,
            ));
        }
    }
    seeds
}

/// One list per stage, every opcode kind the parser knows among them.
fn seed_opcode_lists() -> [Vec<Opcode>; 3] {
    let gain_map = |top: u32, left: u32| {
        Opcode::GainMap(GainMap {
            area: [top, left, 12, 20],
            plane: 0,
            planes: 1,
            row_pitch: 2,
            col_pitch: 2,
            points: [3, 4],
            spacing: [0.5, 1.0 / 3.0],
            origin: [0.0, 0.0],
            map_planes: 1,
            gains: (0..12).map(|i| 1.0 + i as f32 / 20.0).collect(),
        })
    };
    [
        vec![
            Opcode::FixBadPixelsConstant {
                constant: 0,
                bayer_phase: 0,
            },
            Opcode::Other {
                id: 11,
                optional: true,
            },
        ],
        vec![
            gain_map(0, 0),
            gain_map(0, 1),
            gain_map(1, 0),
            gain_map(1, 1),
            Opcode::FixBadPixelsList {
                bayer_phase: 0,
                points: vec![[3, 4], [7, 9]],
                rects: vec![[0, 0, 2, 2]],
            },
        ],
        vec![Opcode::WarpRectilinear {
            planes: vec![[1.0, -0.05, 0.01, 0.0, 0.001, -0.001]],
            centre: [0.5, 0.5],
        }],
    ]
}

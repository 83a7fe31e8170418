//! The C API from C: the committed header is what cbindgen generates from the source now, and
//! `examples/develop.c`, compiled by the system's C compiler against the static library,
//! develops the firmware cases' test frame byte for byte as the Rust pipeline does.

use std::path::PathBuf;
use std::process::Command;

use firmware_cases::{fill_mosaic, BIT_DEPTH, BLACK_LEVEL, PATTERN, WHITE_LEVEL};
use isp_core::demosaic::Method;
use isp_core::dpc::{Defect, DpcConfig};
use isp_core::frame::{RawFrame, RgbViewMut};
use isp_core::noise::NoiseProfile;
use isp_core::pipeline::{FixedPipeline, IspConfig};
use isp_core::tone::{Tone, ToneCurve};

/// isp-ffi, which holds the API's source, the header and the C example.
fn crate_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

#[test]
fn committed_header_is_current() {
    let dir = crate_dir();
    let config = cbindgen::Config::from_file(dir.join("cbindgen.toml")).unwrap();
    let mut generated = Vec::new();
    cbindgen::Builder::new()
        .with_crate(&dir)
        .with_config(config)
        .generate()
        .expect("cbindgen parses isp-ffi")
        .write(&mut generated);
    let header = dir.join("include/camsim_isp.h");
    if std::env::var_os("CAMSIM_BLESS").is_some() {
        std::fs::write(&header, &generated).unwrap();
    }
    let committed = std::fs::read(&header).unwrap_or_default();
    assert!(
        committed == generated,
        "include/camsim_isp.h is stale: run CAMSIM_BLESS=1 cargo test -p camsim-isp --test c_api \
         and commit it"
    );
}

/// The static library cargo built for this test: `cargo test` leaves it in the deps
/// directory beside the test (as `libcamsim_isp-<hash>.a`; `cargo build` would also copy it to
/// target/<profile>/libcamsim_isp.a), the newest if several builds left one.
fn static_library() -> PathBuf {
    let exe = std::env::current_exe().unwrap();
    let deps = exe.parent().unwrap();
    let newest = std::fs::read_dir(deps)
        .unwrap()
        .filter_map(Result::ok)
        .filter(|e| {
            let name = e.file_name().to_string_lossy().into_owned();
            name.starts_with("libcamsim_isp-") && name.ends_with(".a")
        })
        .max_by_key(|e| e.metadata().and_then(|m| m.modified()).ok());
    match newest {
        Some(entry) => entry.path(),
        None => panic!("cargo built no libcamsim_isp-*.a in {}", deps.display()),
    }
}

#[test]
fn c_example_develops_as_the_rust_pipeline() {
    let dir = crate_dir();
    let work = std::env::temp_dir().join(format!("camsim-c-api-{}", std::process::id()));
    std::fs::create_dir_all(&work).unwrap();
    let exe = work.join("develop");
    let cc = std::env::var("CC").unwrap_or_else(|_| "cc".into());
    let compiled = Command::new(&cc)
        .args(["-std=c11", "-Wall", "-Wextra", "-Werror", "-O2", "-I"])
        .arg(dir.join("include"))
        .arg(dir.join("examples/develop.c"))
        .arg(static_library())
        .args(["-lm", "-lpthread", "-ldl", "-o"])
        .arg(&exe)
        .output()
        .unwrap_or_else(|e| panic!("the C compiler `{cc}` did not start: {e}"));
    assert!(
        compiled.status.success(),
        "compiling examples/develop.c failed:\n{}",
        String::from_utf8_lossy(&compiled.stderr)
    );

    let (w, h) = (128, 96);
    let mut mosaic = vec![0u16; w * h];
    fill_mosaic(&mut mosaic, w, h).unwrap();
    let raw_path = work.join("frame.raw");
    let bytes: Vec<u8> = mosaic.iter().flat_map(|v| v.to_le_bytes()).collect();
    std::fs::write(&raw_path, bytes).unwrap();
    let out_path = work.join("frame.rgb");
    let output = Command::new(&exe)
        .arg(&raw_path)
        .args([w.to_string(), h.to_string()])
        .arg(&out_path)
        .output()
        .unwrap();
    assert!(
        output.status.success(),
        "develop failed: {}",
        String::from_utf8_lossy(&output.stderr)
    );
    let from_c = std::fs::read(&out_path).unwrap();

    // The same configuration in Rust, the whole frame in one call.
    let defects = [
        Defect { y: 3, x: 5 },
        Defect { y: 10, x: 40 },
        Defect { y: 17, x: 22 },
    ];
    let config = IspConfig {
        dpc: DpcConfig {
            static_defects: &defects,
            dynamic_threshold: Some(64),
        },
        wb_gains: [1.9, 1.0, 1.6],
        demosaic: Method::Mhc,
        denoise: 1.0,
        noise: Some(NoiseProfile::uniform(0.0008, 4.3295e-6).unwrap()),
        highlight_knee: 0.9,
        ccm: [[1.6, -0.4, -0.2], [-0.3, 1.5, -0.2], [0.0, -0.5, 1.5]],
        tone: Tone {
            saturation: 1.3,
            contrast: 1.15,
            curve: ToneCurve::IDENTITY,
        },
        chroma_denoise: 1.0,
        ..IspConfig::default()
    };
    let raw = RawFrame::new(
        &mosaic,
        w,
        h,
        w,
        BIT_DEPTH,
        PATTERN,
        [BLACK_LEVEL; 4],
        WHITE_LEVEL,
    )
    .unwrap();
    let pipeline = FixedPipeline::new(&config, 8).unwrap();
    let mut scratch = vec![0u16; config.scratch_len(w, h).unwrap()];
    let mut from_rust = vec![0u8; 3 * w * h];
    let mut view = RgbViewMut::new(&mut from_rust, w, h, 3 * w).unwrap();
    pipeline.run(&raw, 0..h, &mut scratch, &mut view).unwrap();
    assert_eq!(from_c.len(), from_rust.len());
    let differing = from_c
        .iter()
        .zip(&from_rust)
        .filter(|(a, b)| a != b)
        .count();
    assert_eq!(differing, 0, "{differing} bytes differ between C and Rust");
    std::fs::remove_dir_all(&work).ok();
}

#[test]
fn refusals_are_status_codes_with_the_command_lines_message() {
    use camsim_isp::*;
    let mut config = std::mem::MaybeUninit::<CamsimIspConfig>::uninit();
    // SAFETY: a writable config.
    let mut config = unsafe {
        camsim_isp_config_default(config.as_mut_ptr());
        config.assume_init()
    };
    config.demosaic = 9;
    let mut buf = [0 as std::ffi::c_char; 96];
    // SAFETY: valid config and buffer.
    let n = unsafe { camsim_isp_config_error(&config, buf.as_mut_ptr(), buf.len()) };
    // SAFETY: the function NUL-terminates within the buffer.
    let text = unsafe { std::ffi::CStr::from_ptr(buf.as_ptr()) }
        .to_str()
        .unwrap();
    assert_eq!(text, "invalid demosaic: must be one of CAMSIM_DEMOSAIC_*");
    assert_eq!(n, text.len());

    let mut storage = vec![0u64; camsim_isp_pipeline_size().div_ceil(8) + 2];
    let mut pipeline = std::ptr::null();
    let storage_ptr = storage.as_mut_ptr().cast::<u8>();
    let len = storage.len() * 8;
    // SAFETY: valid storage, config and out pointer.
    let status = unsafe { camsim_isp_pipeline_init(storage_ptr, len, &config, &mut pipeline) };
    assert_eq!(status, CamsimStatus::CAMSIM_STATUS_INVALID_PARAMETER);
    config.demosaic = CAMSIM_DEMOSAIC_MHC;
    // SAFETY: as above, with storage one byte short, then misaligned, then NULL.
    unsafe {
        assert_eq!(
            camsim_isp_pipeline_init(
                storage_ptr,
                camsim_isp_pipeline_size() - 1,
                &config,
                &mut pipeline
            ),
            CamsimStatus::CAMSIM_STATUS_BUFFER_TOO_SMALL
        );
        assert_eq!(
            camsim_isp_pipeline_init(storage_ptr.add(1), len - 8, &config, &mut pipeline),
            CamsimStatus::CAMSIM_STATUS_MISALIGNED
        );
        assert_eq!(
            camsim_isp_pipeline_init(std::ptr::null_mut(), len, &config, &mut pipeline),
            CamsimStatus::CAMSIM_STATUS_NULL_POINTER
        );
        assert_eq!(
            camsim_isp_pipeline_init(storage_ptr, len, &config, &mut pipeline),
            CamsimStatus::CAMSIM_STATUS_OK
        );
    }
    // A scratch one element short is refused, not overrun.
    let (w, h) = (32u32, 16u32);
    let mut need = 0;
    // SAFETY: a built pipeline and a writable length.
    assert_eq!(
        unsafe { camsim_isp_scratch_len(pipeline, w, h, &mut need) },
        CamsimStatus::CAMSIM_STATUS_OK
    );
    let data = vec![500u16; (w * h) as usize];
    let frame = CamsimRawFrame {
        data: data.as_ptr(),
        width: w,
        height: h,
        stride: w,
        bit_depth: 10,
        pattern: CAMSIM_CFA_RGGB,
        black_level: [64; 4],
        white_level: 1023,
    };
    let mut scratch = vec![0u16; need];
    let mut out = vec![0u8; (3 * w * h) as usize];
    let run = |scratch_len: usize, scratch: &mut [u16], out: &mut [u8]| {
        // SAFETY: every pointer valid for the lengths given.
        unsafe {
            camsim_isp_run_rows(
                pipeline,
                &frame,
                0,
                h,
                scratch.as_mut_ptr(),
                scratch_len,
                out.as_mut_ptr().cast(),
                out.len(),
                3 * w,
            )
        }
    };
    assert_eq!(
        run(need - 1, &mut scratch, &mut out),
        CamsimStatus::CAMSIM_STATUS_BUFFER_TOO_SMALL
    );
    assert_eq!(
        run(need, &mut scratch, &mut out),
        CamsimStatus::CAMSIM_STATUS_OK
    );
    assert!(
        out.iter().all(|v| *v > 0),
        "a flat grey frame develops to grey"
    );
}

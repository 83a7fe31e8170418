//! `camsim demosaic` and `camsim bench demosaic`: the isp-core demosaicing methods on files,
//! and their accuracy (CPSNR on a dataset) against their speed (Mpix/s, single thread).

//! `camsim demosaic` and `camsim bench demosaic`: isp-core's demosaicing methods on whole
//! files, and their accuracy (CPSNR on a dataset) against their speed (Mpix/s, single thread).
//! [`Demosaic`] names each way of running one of isp-core's [`Method`]s, and [`Demosaic::run`]
//! is the one place the AVX2 build of the directional method is chosen at run time.

use std::path::{Path, PathBuf};
use std::time::Instant;

use isp_core::demosaic::directional::{directional, directional_fixed, scratch_len};
use isp_core::demosaic::{bilinear, mhc, nearest, Border, Method};
use isp_core::frame::{IntSample, MosaicView, RgbViewMut, Sample};
use isp_core::metrics::cpsnr;
use isp_core::CfaPattern;
use raw_formats::Image;

use crate::error::Error;

/// A demosaic as the command line names it: one of isp-core's methods, with its border rule
/// and arithmetic (isp-core's [`Method`] is the one list of methods; this says how to run one
/// on a whole frame).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Demosaic {
    /// The method.
    pub method: Method,
    /// The border rule (bilinear offers OpenCV's).
    pub border: Border,
    /// The integer version (directional's `directional_fixed`); the others are integer on
    /// integer samples already.
    pub integer: bool,
}

impl Demosaic {
    const fn of(method: Method) -> Self {
        Self {
            method,
            border: Border::Reflect101,
            integer: false,
        }
    }

    /// 2x2 superpixel replication.
    pub const NEAREST: Self = Self::of(Method::Nearest);
    /// Bilinear with reflect-101 borders.
    pub const BILINEAR: Self = Self::of(Method::Bilinear);
    /// Bilinear with OpenCV's border rule (bit-exact to `cvtColor`).
    pub const BILINEAR_OPENCV: Self = Self {
        border: Border::OpenCv,
        ..Self::BILINEAR
    };
    /// Malvar-He-Cutler 2004.
    pub const MHC: Self = Self::of(Method::Mhc);
    /// The high-quality directional method (`f32` inside).
    pub const DIRECTIONAL: Self = Self::of(Method::Directional);
    /// The same in integer arithmetic, for cores without an FPU.
    pub const DIRECTIONAL_FIXED: Self = Self {
        integer: true,
        ..Self::DIRECTIONAL
    };

    /// Every variant, cheapest first.
    pub const ALL: [Demosaic; 6] = [
        Self::NEAREST,
        Self::BILINEAR,
        Self::BILINEAR_OPENCV,
        Self::MHC,
        Self::DIRECTIONAL,
        Self::DIRECTIONAL_FIXED,
    ];

    /// The name used on the command line and in reports.
    pub fn name(self) -> &'static str {
        match (self.method, self.border, self.integer) {
            (Method::Bilinear, Border::OpenCv, _) => "bilinear-opencv",
            (Method::Directional, _, true) => "directional-fixed",
            (method, _, _) => method.name(),
        }
    }

    /// Demosaics `data` (`w` x `h`, pattern `p`) into `out` (3 samples per pixel).
    pub fn run<T: IntSample>(
        self,
        data: &[T],
        w: usize,
        h: usize,
        p: CfaPattern,
        out: &mut [T],
    ) -> Result<(), Error> {
        let mosaic = MosaicView::new(data, w, h, w, p)?;
        let mut view = RgbViewMut::new(out, w, h, 3 * w)?;
        let scratch = || {
            scratch_len(w).ok_or(Error::Option {
                option: "width",
                value: w.to_string(),
                allowed: "a width whose scratch fits in memory".into(),
            })
        };
        match (self.method, self.integer) {
            (Method::Nearest, _) => nearest(&mosaic, &mut view)?,
            (Method::Bilinear, _) => bilinear_dispatch(&mosaic, self.border, &mut view)?,
            (Method::Mhc, _) => mhc_dispatch(&mosaic, &mut view)?,
            (Method::Directional, false) => {
                directional_dispatch(&mosaic, &mut view, &mut vec![0f32; scratch()?])?
            }
            (Method::Directional, true) => {
                directional_fixed_dispatch(&mosaic, &mut view, &mut vec![0i32; scratch()?])?
            }
        }
        Ok(())
    }
}

/// The directional method in the fastest build this CPU runs: the AVX2 build where the CPU has
/// it (bit-identical output), the baseline build otherwise. With `develop`'s `fixed_dispatch`,
/// the places camsim chooses.
pub fn directional_dispatch<T: Sample>(
    mosaic: &MosaicView<'_, T>,
    out: &mut RgbViewMut<'_, T>,
    scratch: &mut [f32],
) -> Result<(), isp_core::IspError> {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU has just been found to support AVX2, the one target feature
        // `directional_avx2` is compiled for.
        return unsafe { isp_core::demosaic::directional::directional_avx2(mosaic, out, scratch) };
    }
    directional(mosaic, out, scratch)
}

/// Whether the CPU has the AVX-512 features (F, BW, VL, DQ) isp-core's `_avx512` builds are
/// compiled for; the one check both this module and `develop` make.
#[cfg(target_arch = "x86_64")]
pub(crate) fn has_avx512() -> bool {
    std::arch::is_x86_feature_detected!("avx512f")
        && std::arch::is_x86_feature_detected!("avx512bw")
        && std::arch::is_x86_feature_detected!("avx512vl")
        && std::arch::is_x86_feature_detected!("avx512dq")
}

/// The integer directional method in the fastest build this CPU runs: the AVX-512 build
/// where the CPU has it, else the AVX2 build (both bit-identical), else the baseline build.
pub fn directional_fixed_dispatch<T: IntSample>(
    mosaic: &MosaicView<'_, T>,
    out: &mut RgbViewMut<'_, T>,
    scratch: &mut [i32],
) -> Result<(), isp_core::IspError> {
    #[cfg(target_arch = "x86_64")]
    if has_avx512() {
        // SAFETY: the CPU has just been found to support the four features
        // `directional_fixed_avx512` is compiled for.
        return unsafe {
            isp_core::demosaic::directional::directional_fixed_avx512(mosaic, out, scratch)
        };
    }
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU has just been found to support AVX2, the one target feature
        // `directional_fixed_avx2` is compiled for.
        return unsafe {
            isp_core::demosaic::directional::directional_fixed_avx2(mosaic, out, scratch)
        };
    }
    directional_fixed(mosaic, out, scratch)
}

/// Bilinear in the fastest build this CPU runs, as [`directional_dispatch`] chooses.
pub fn bilinear_dispatch<T: Sample>(
    mosaic: &MosaicView<'_, T>,
    border: Border,
    out: &mut RgbViewMut<'_, T>,
) -> Result<(), isp_core::IspError> {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU has just been found to support AVX2, the one target feature
        // `bilinear_avx2` is compiled for.
        return unsafe { isp_core::demosaic::bilinear_avx2(mosaic, border, out) };
    }
    bilinear(mosaic, border, out)
}

/// Malvar-He-Cutler in the fastest build this CPU runs, as [`directional_dispatch`] chooses.
pub fn mhc_dispatch<T: Sample>(
    mosaic: &MosaicView<'_, T>,
    out: &mut RgbViewMut<'_, T>,
) -> Result<(), isp_core::IspError> {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: as in `bilinear_dispatch`.
        return unsafe { isp_core::demosaic::demosaic_avx2(Method::Mhc, mosaic, out) };
    }
    mhc(mosaic, out)
}

/// Samples an RGB image into a mosaic of pattern `p`, each sample multiplied by `scale`.
pub fn mosaic_from_rgb(rgb: &Image, p: CfaPattern, scale: u16) -> Vec<u16> {
    (0..rgb.height)
        .flat_map(|y| (0..rgb.width).map(move |x| (x, y)))
        .map(|(x, y)| rgb.data[3 * (y * rgb.width + x) + p.colour_at(x, y).index()] * scale)
        .collect()
}

/// `camsim demosaic`: one mosaic file in, RGB of the same bit depth out.
pub fn demosaic_file(
    input: &Path,
    output: &Path,
    method: Demosaic,
    pattern: CfaPattern,
) -> Result<String, Error> {
    let image = raw_formats::image::read(input)?;
    if image.channels != 1 {
        return Err(Error::Format(
            raw_formats::FormatError::Unsupported {
                field: "channel count",
                value: image.channels.to_string(),
                supported: "expected a single-channel mosaic",
            }
            .in_file(input),
        ));
    }
    let (w, h) = (image.width, image.height);
    let mut out = vec![0u16; 3 * w * h];
    let start = Instant::now();
    if image.bits == 8 {
        let data: Vec<u8> = image.data.iter().map(|v| *v as u8).collect();
        let mut rgb = vec![0u8; 3 * w * h];
        method.run(&data, w, h, pattern, &mut rgb)?;
        out.iter_mut().zip(rgb).for_each(|(o, v)| *o = v as u16);
    } else {
        method.run(&image.data, w, h, pattern, &mut out)?;
    }
    let elapsed = start.elapsed();
    raw_formats::image::write(
        output,
        &Image {
            width: w,
            height: h,
            channels: 3,
            bits: image.bits,
            data: out,
        },
    )?;
    Ok(format!(
        "{} ({}x{}, {}-bit {}) -> {} with {} in {:.1} ms\n",
        input.display(),
        w,
        h,
        image.bits,
        pattern.name(),
        output.display(),
        method.name(),
        elapsed.as_secs_f64() * 1e3
    ))
}

/// One method's figures on one dataset (serialised as they are for `--json`).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct BenchRow {
    /// Method name.
    pub method: &'static str,
    /// Sample depth of the run.
    pub bits: u8,
    /// Mean CPSNR over the dataset, dB.
    pub cpsnr_db: f64,
    /// Single-thread throughput, megapixels per second.
    pub mpix_per_s: f64,
}

fn run_scaled(
    method: Demosaic,
    mosaic: &[u16],
    w: usize,
    h: usize,
    bits: u8,
    out: &mut [u16],
) -> Result<(), Error> {
    if bits == 8 {
        let data: Vec<u8> = mosaic.iter().map(|v| *v as u8).collect();
        let mut rgb = vec![0u8; out.len()];
        method.run(&data, w, h, CfaPattern::Rggb, &mut rgb)?;
        out.iter_mut().zip(rgb).for_each(|(o, v)| *o = v as u16);
        Ok(())
    } else {
        method.run(mosaic, w, h, CfaPattern::Rggb, out)
    }
}

/// How much of a dataset [`bench_limited`] measures, and how long it times each method.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BenchLimits {
    /// The first this many images (sorted by name); `None`: all.
    pub images: Option<usize>,
    /// Side of the square mosaic, tiled from the first image, whose demosaic is timed.
    pub tile: usize,
    /// Each method is timed for at least this long (and at least once); the best run counts.
    pub min_seconds: f64,
}

impl Default for BenchLimits {
    /// Every image; a 2048 x 2048 tile timed for half a second (`camsim bench demosaic`).
    fn default() -> Self {
        Self {
            images: None,
            tile: 2048,
            min_seconds: 0.5,
        }
    }
}

/// Runs `methods` over the PNG images in `dataset` at `bits` (8 or 16), reporting progress
/// on stderr through `progress`.
pub fn bench(
    dataset: &Path,
    bits: u8,
    methods: &[Demosaic],
    progress: &mut dyn FnMut(&str),
) -> Result<Vec<BenchRow>, Error> {
    bench_limited(dataset, bits, methods, BenchLimits::default(), progress)
}

/// The PNG images of an image set (`data/kodak`, `data/mcmaster`), sorted by name, the first
/// `limit` of them (at least one) if given; an error if the folder has none.
pub fn dataset_images(dataset: &Path, limit: Option<usize>) -> Result<Vec<PathBuf>, Error> {
    let mut paths: Vec<_> = std::fs::read_dir(dataset)
        .map_err(|e| raw_formats::FormatError::io(dataset, e))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e.eq_ignore_ascii_case("png")))
        .collect();
    paths.sort();
    if let Some(n) = limit {
        paths.truncate(n.max(1));
    }
    if paths.is_empty() {
        return Err(Error::Option {
            option: "--dataset",
            value: dataset.display().to_string(),
            allowed: "a folder with .png images".into(),
        });
    }
    Ok(paths)
}

/// [`bench()`] within `limits` (fewer images, a smaller tile, a shorter timing: `camsim bench
/// --quick`).
pub fn bench_limited(
    dataset: &Path,
    bits: u8,
    methods: &[Demosaic],
    limits: BenchLimits,
    progress: &mut dyn FnMut(&str),
) -> Result<Vec<BenchRow>, Error> {
    if limits.tile < 2 || limits.tile > 16384 || limits.min_seconds.is_nan() {
        return Err(Error::Option {
            option: "tile",
            value: limits.tile.to_string(),
            allowed: "2..=16384 pixels, and a timing that is a number".into(),
        });
    }
    let paths = dataset_images(dataset, limits.images)?;
    let scale: u16 = if bits == 8 { 1 } else { 257 };
    let peak = if bits == 8 { 255.0 } else { 65535.0 };
    let mut images = Vec::new();
    for path in &paths {
        let image = raw_formats::image::read(path)?;
        if image.channels != 3 || image.bits != 8 {
            return Err(Error::Format(
                raw_formats::FormatError::Unsupported {
                    field: "image",
                    value: format!("{} channels, {} bits", image.channels, image.bits),
                    supported: "8-bit RGB",
                }
                .in_file(path),
            ));
        }
        images.push(image);
    }
    let mut rows = Vec::new();
    for &method in methods {
        let mut total = 0.0;
        for (path, image) in paths.iter().zip(&images) {
            let (w, h) = (image.width, image.height);
            let mosaic = mosaic_from_rgb(image, CfaPattern::Rggb, scale);
            let mut out = vec![0u16; 3 * w * h];
            run_scaled(method, &mosaic, w, h, bits, &mut out)?;
            let truth: Vec<u16> = image.data.iter().map(|v| v * scale).collect();
            total += cpsnr(&out, &truth, w, h, 10, peak);
            progress(&format!(
                "{} {}-bit {}",
                method.name(),
                bits,
                path.file_name().unwrap_or_default().to_string_lossy()
            ));
        }
        let mpix_per_s = throughput(method, &images[0], bits, limits)?;
        rows.push(BenchRow {
            method: method.name(),
            bits,
            cpsnr_db: total / images.len() as f64,
            mpix_per_s,
        });
    }
    Ok(rows)
}

/// Single-thread Mpix/s on a square mosaic (`limits.tile` wide) tiled from `image`: the best
/// of repeated runs over at least `limits.min_seconds`, timing only the demosaic call on
/// buffers made beforehand.
fn throughput(
    method: Demosaic,
    image: &Image,
    bits: u8,
    limits: BenchLimits,
) -> Result<f64, Error> {
    let n = limits.tile;
    let base = mosaic_from_rgb(image, CfaPattern::Rggb, if bits == 8 { 1 } else { 257 });
    // Tile with even offsets so the CFA phase is kept.
    let (tw, th) = (image.width & !1, image.height & !1);
    let mosaic: Vec<u16> = (0..n * n)
        .map(|i| base[(i / n % th) * image.width + (i % n % tw)])
        .collect();
    if bits == 8 {
        let data: Vec<u8> = mosaic.iter().map(|v| *v as u8).collect();
        time_method(method, &data, n, limits.min_seconds)
    } else {
        time_method(method, &mosaic, n, limits.min_seconds)
    }
}

fn time_method<T: IntSample>(
    method: Demosaic,
    mosaic: &[T],
    n: usize,
    min_seconds: f64,
) -> Result<f64, Error> {
    let mut out = vec![T::default(); 3 * n * n];
    let mut best = f64::INFINITY;
    let started = Instant::now();
    while started.elapsed().as_secs_f64() < min_seconds || best.is_infinite() {
        let t = Instant::now();
        method.run(mosaic, n, n, CfaPattern::Rggb, &mut out)?;
        best = best.min(t.elapsed().as_secs_f64());
    }
    Ok((n * n) as f64 / best / 1e6)
}

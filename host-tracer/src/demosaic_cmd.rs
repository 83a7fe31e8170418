//! `camsim demosaic` and `camsim bench demosaic`: the isp-core demosaicing methods on files,
//! and their accuracy (CPSNR on a dataset) against their speed (Mpix/s, single thread).

use std::path::Path;
use std::time::Instant;

use isp_core::demosaic::directional::{directional, directional_fixed, scratch_len};
use isp_core::demosaic::{bilinear, mhc, nearest, Border};
use isp_core::frame::{IntSample, MosaicView, RgbViewMut};
use isp_core::CfaPattern;
use serde_json::{json, Value};

use crate::imageio::{self, Image};

/// A demosaicing method of isp-core.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Method {
    /// 2x2 superpixel replication.
    Nearest,
    /// Bilinear with reflect-101 borders.
    Bilinear,
    /// Bilinear with OpenCV's border rule (bit-exact to `cvtColor`).
    BilinearOpenCv,
    /// Malvar-He-Cutler 2004.
    Mhc,
    /// The high-quality directional method (`isp_core::demosaic::directional`).
    Directional,
    /// The same in integer arithmetic (`directional_fixed`), for cores without an FPU.
    DirectionalFixed,
}

impl Method {
    /// Every method, cheapest first.
    pub const ALL: [Method; 6] = [
        Method::Nearest,
        Method::Bilinear,
        Method::BilinearOpenCv,
        Method::Mhc,
        Method::Directional,
        Method::DirectionalFixed,
    ];

    /// The name used on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            Method::Nearest => "nearest",
            Method::Bilinear => "bilinear",
            Method::BilinearOpenCv => "bilinear-opencv",
            Method::Mhc => "mhc",
            Method::Directional => "directional",
            Method::DirectionalFixed => "directional-fixed",
        }
    }

    /// Parses a name; the error lists the choices.
    pub fn parse(s: &str) -> Result<Self, String> {
        Self::ALL
            .into_iter()
            .find(|m| m.name() == s)
            .ok_or_else(|| {
                let names: Vec<&str> = Self::ALL.iter().map(|m| m.name()).collect();
                format!("--method must be one of {} (got {s:?})", names.join(", "))
            })
    }

    /// Demosaics `data` (`w` x `h`, pattern `p`) into `out` (3 samples per pixel).
    pub fn run<T: IntSample>(
        self,
        data: &[T],
        w: usize,
        h: usize,
        p: CfaPattern,
        out: &mut [T],
    ) -> Result<(), String> {
        let mosaic = MosaicView::new(data, w, h, w, p).map_err(|e| e.to_string())?;
        let mut view = RgbViewMut::new(out, w, h, 3 * w).map_err(|e| e.to_string())?;
        match self {
            Method::Nearest => nearest(&mosaic, &mut view),
            Method::Bilinear => bilinear(&mosaic, Border::Reflect101, &mut view),
            Method::BilinearOpenCv => bilinear(&mosaic, Border::OpenCv, &mut view),
            Method::Mhc => mhc(&mosaic, &mut view),
            Method::Directional => {
                let len =
                    scratch_len(w).ok_or_else(|| format!("a {w}-pixel-wide frame is too wide"))?;
                let mut scratch = vec![0f32; len];
                #[cfg(target_arch = "x86_64")]
                if std::arch::is_x86_feature_detected!("avx2") {
                    // SAFETY: the CPU has just been found to support AVX2, the one target
                    // feature `directional_avx2` is compiled for.
                    return unsafe {
                        isp_core::demosaic::directional::directional_avx2(
                            &mosaic,
                            &mut view,
                            &mut scratch,
                        )
                    }
                    .map_err(|e| e.to_string());
                }
                directional(&mosaic, &mut view, &mut scratch)
            }
            Method::DirectionalFixed => {
                let len =
                    scratch_len(w).ok_or_else(|| format!("a {w}-pixel-wide frame is too wide"))?;
                directional_fixed(&mosaic, &mut view, &mut vec![0i32; len])
            }
        }
        .map_err(|e| e.to_string())
    }
}

/// Samples an RGB image into a mosaic of pattern `p`, each sample multiplied by `scale`.
pub fn mosaic_from_rgb(rgb: &Image, p: CfaPattern, scale: u16) -> Vec<u16> {
    (0..rgb.height)
        .flat_map(|y| (0..rgb.width).map(move |x| (x, y)))
        .map(|(x, y)| rgb.data[3 * (y * rgb.width + x) + p.colour_at(x, y).index()] * scale)
        .collect()
}

/// CPSNR in dB of `out` against `truth` (both RGB, same size, samples in `0..=peak`) over the
/// image minus a `border`-pixel frame: `10 log10(peak^2 / MSE)`, MSE over all three channels.
pub fn cpsnr(
    out: &[u16],
    truth: &[u16],
    width: usize,
    height: usize,
    border: usize,
    peak: f64,
) -> f64 {
    let mut se = 0.0;
    let mut n = 0usize;
    for y in border..height.saturating_sub(border) {
        for x in border..width.saturating_sub(border) {
            for c in 0..3 {
                let i = 3 * (y * width + x) + c;
                let d = out[i] as f64 - truth[i] as f64;
                se += d * d;
                n += 1;
            }
        }
    }
    10.0 * (peak * peak / (se / n as f64)).log10()
}

/// `camsim demosaic`: one mosaic file in, RGB of the same bit depth out.
pub fn demosaic_file(
    input: &Path,
    output: &Path,
    method: Method,
    pattern: CfaPattern,
) -> Result<String, String> {
    let image = imageio::read(input)?;
    if image.channels != 1 {
        return Err(format!(
            "{}: expected a single-channel mosaic, found {} channels",
            input.display(),
            image.channels
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
    imageio::write(
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

/// One method's figures on one dataset.
#[derive(Debug, Clone, PartialEq)]
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

impl BenchRow {
    /// The row as the JSON object of the command's documentation.
    pub fn to_json(&self) -> Value {
        json!({ "method": self.method, "bits": self.bits, "cpsnr_db": self.cpsnr_db, "mpix_per_s": self.mpix_per_s })
    }
}

fn run_scaled(
    method: Method,
    mosaic: &[u16],
    w: usize,
    h: usize,
    bits: u8,
    out: &mut [u16],
) -> Result<(), String> {
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

/// Runs `methods` over the PNG images in `dataset` at `bits` (8 or 16), reporting progress
/// on stderr through `progress`.
pub fn bench(
    dataset: &Path,
    bits: u8,
    methods: &[Method],
    progress: &mut dyn FnMut(&str),
) -> Result<Vec<BenchRow>, String> {
    let mut paths: Vec<_> = std::fs::read_dir(dataset)
        .map_err(|e| format!("{}: {e}", dataset.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e.eq_ignore_ascii_case("png")))
        .collect();
    paths.sort();
    if paths.is_empty() {
        return Err(format!("{}: no .png images", dataset.display()));
    }
    let scale: u16 = if bits == 8 { 1 } else { 257 };
    let peak = if bits == 8 { 255.0 } else { 65535.0 };
    let mut images = Vec::new();
    for path in &paths {
        let image = imageio::read(path)?;
        if image.channels != 3 || image.bits != 8 {
            return Err(format!("{}: expected 8-bit RGB", path.display()));
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
        let mpix_per_s = throughput(method, &images[0], bits)?;
        rows.push(BenchRow {
            method: method.name(),
            bits,
            cpsnr_db: total / images.len() as f64,
            mpix_per_s,
        });
    }
    Ok(rows)
}

/// Single-thread Mpix/s on a 2048x2048 mosaic tiled from `image`: the best of repeated runs
/// over at least half a second, timing only the demosaic call on buffers made beforehand.
fn throughput(method: Method, image: &Image, bits: u8) -> Result<f64, String> {
    let n = 2048;
    let base = mosaic_from_rgb(image, CfaPattern::Rggb, if bits == 8 { 1 } else { 257 });
    // Tile with even offsets so the CFA phase is kept.
    let (tw, th) = (image.width & !1, image.height & !1);
    let mosaic: Vec<u16> = (0..n * n)
        .map(|i| base[(i / n % th) * image.width + (i % n % tw)])
        .collect();
    if bits == 8 {
        let data: Vec<u8> = mosaic.iter().map(|v| *v as u8).collect();
        time_method(method, &data, n)
    } else {
        time_method(method, &mosaic, n)
    }
}

fn time_method<T: IntSample>(method: Method, mosaic: &[T], n: usize) -> Result<f64, String> {
    let mut out = vec![T::default(); 3 * n * n];
    let mut best = f64::INFINITY;
    let started = Instant::now();
    while started.elapsed().as_secs_f64() < 0.5 || best.is_infinite() {
        let t = Instant::now();
        method.run(mosaic, n, n, CfaPattern::Rggb, &mut out)?;
        best = best.min(t.elapsed().as_secs_f64());
    }
    Ok((n * n) as f64 / best / 1e6)
}

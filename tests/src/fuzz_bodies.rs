//! Fuzz target bodies: each takes arbitrary bytes, drives a public entry point that accepts
//! untrusted sizes or values, and panics only if that entry point broke its contract.

use optics_core::aperture::{ApertureShape, BitmapMask};
use optics_core::distortion::BrownConrady;
use optics_core::dof::{circle_of_confusion, depth_of_field};
use optics_core::fixed_point::{self, Dioptres, FNumber, Mm};
use optics_core::glam::Vec2;
use optics_core::lens::{image_distance, sensor_distance_for_focus};

fn f64s<const N: usize>(data: &[u8]) -> [f64; N] {
    let mut out = [0.0; N];
    for (i, chunk) in data.chunks(8).take(N).enumerate() {
        let mut b = [0u8; 8];
        b[..chunk.len()].copy_from_slice(chunk);
        out[i] = f64::from_le_bytes(b);
    }
    out
}

/// Float lens and depth-of-field equations: every answer is an error or finite.
pub fn optics_scalar(data: &[u8]) {
    let [f, n, c, s, d] = f64s::<5>(data);
    if let Ok(dof) = depth_of_field(f, n, c, s) {
        assert!(dof.near.is_finite());
        assert!(dof.far.finite().is_none_or(f64::is_finite));
    }
    if let Ok(x) = circle_of_confusion(f, n, s, d) {
        assert!(x.is_finite() && x >= 0.0);
    }
    if let Ok(i) = image_distance(f, s) {
        assert!(i.signed().is_none_or(f64::is_finite));
    }
    if let Ok(x) = sensor_distance_for_focus(f, s) {
        assert!(x.is_finite() && x > 0.0);
    }
}

/// Fixed-point focusing from raw bit patterns: errors, never a panic or a wrap (checked by
/// comparing with f64 where an answer is given).
pub fn optics_fixed(data: &[u8]) {
    let mut w = [0u64; 4];
    for (i, chunk) in data.chunks(8).take(4).enumerate() {
        let mut b = [0u8; 8];
        b[..chunk.len()].copy_from_slice(chunk);
        w[i] = u64::from_le_bytes(b);
    }
    let (f, n, c, v) = (
        Mm::from_bits(w[0]),
        FNumber::from_bits(w[1]),
        Mm::from_bits(w[2]),
        Dioptres::from_bits(w[3]),
    );
    if let Ok(s_i) = fixed_point::sensor_distance(f, v) {
        assert!(s_i >= f, "the sensor is never closer than f");
    }
    if let Ok(dof) = fixed_point::depth_of_field(f, n, c, v) {
        assert!(
            dof.far <= v && v <= dof.near,
            "far <= focus <= near in vergence"
        );
    }
    let _ = fixed_point::circle_of_confusion(f, n, v, Dioptres::from_bits(w[0]));
    let _ = fixed_point::distance(v);
}

/// Bitmap apertures of any size and content: built or refused, and every sample inside.
pub fn bitmap_aperture(data: &[u8]) {
    if data.len() < 6 {
        return;
    }
    let width = data[0] as usize % 40;
    let height = data[1] as usize % 40;
    let u = Vec2::new(data[2] as f32 / 255.0, data[3] as f32 / 256.0);
    let mask = &data[4..];
    let mut cdf = vec![0u32; (data[4] as usize * 7) % 1700];
    if let Ok(shape) = BitmapMask::new(mask, width, height, &mut cdf) {
        let p = shape.sample(u);
        assert!(shape.contains(p), "sample {p:?} outside the mask");
        assert!(shape.pdf(p) > 0.0);
    }
}

/// Distortion inverse: where it answers, the answer meets the documented bound.
pub fn distortion_inverse(data: &[u8]) {
    let [k1, k2, k3, p1, p2, x, y] = f64s::<7>(data);
    let Ok(model) = BrownConrady::new(k1, k2, k3, p1, p2) else {
        return;
    };
    if let Ok(u) = model.undistort([x, y]) {
        let d = model.distort(u).expect("an accepted inverse distorts back");
        let bound = 16.0 * f64::EPSILON * 1f64.max(x.abs()).max(y.abs());
        assert!((d[0] - x).abs() <= bound && (d[1] - y).abs() <= bound);
    }
}

/// The ISP pipeline on an arbitrary frame and configuration (sizes, levels, pattern, gains,
/// demosaic method, denoise, a lens with any coefficients and camera matrix, band height):
/// every constructor either refuses or the run succeeds with scratch of the size reported, in
/// both paths, without panicking.
pub fn isp_pipeline(data: &[u8]) {
    use isp_core::demosaic::Method;
    use isp_core::distortion::LensDistortion;
    use isp_core::frame::{RawFrame, RgbViewMut};
    use isp_core::pipeline::{FixedPipeline, FloatPipeline, IspConfig};
    use isp_core::CfaPattern;

    if data.len() < 12 {
        return;
    }
    let (head, rest) = data.split_at(12);
    let (w, h) = (1 + head[0] as usize % 16, 1 + head[1] as usize % 16);
    let stride = w + head[2] as usize % 3;
    let bits = 8 + head[3] % 9;
    let pattern = CfaPattern::ALL[head[4] as usize % 4];
    let max = (1u32 << bits) - 1;
    let white = (u32::from(u16::from_le_bytes([head[5], head[6]])) % (max + 1)) as u16;
    let black = [(head[7] as u16 * 16) % white.max(1); 4];
    let method = Method::ALL[head[8] as usize % Method::ALL.len()];
    let band = 1 + head[9] as usize % h;
    let mut v = f64s::<12>(rest);
    if head[11] & 1 == 0 {
        // Mostly sane values (raw bit patterns, odd half the time, rarely pass the checks):
        // gain and WB in [0, 4), denoise in [0, 4), a lens about the frame's size.
        let unit = |x: f64| (x.to_bits() % 4096) as f64 / 4096.0;
        let size = w.max(h) as f64;
        v = [
            4.0 * unit(v[0]),
            4.0 * unit(v[1]),
            4.0 * unit(v[2]),
            size * (0.2 + 2.0 * unit(v[3])),
            size * (0.2 + 2.0 * unit(v[4])),
            w as f64 * unit(v[5]),
            h as f64 * unit(v[6]),
            unit(v[7]) - 0.5,
            0.4 * unit(v[8]) - 0.2,
            0.02 * unit(v[9]) - 0.01,
            0.02 * unit(v[10]) - 0.01,
            0.2 * unit(v[11]) - 0.1,
        ];
    }
    let [gain, wb, denoise, fx, fy, cx, cy, k1, k2, p1, p2, k3] = v;
    let samples: Vec<u16> = rest
        .iter()
        .skip(96)
        .cycle()
        .take((h - 1) * stride + w)
        .map(|b| (*b as u16) << (bits - 8))
        .collect();
    if samples.len() < (h - 1) * stride + w {
        return;
    }
    let Ok(raw) = RawFrame::new(&samples, w, h, stride, bits, pattern, black, white) else {
        return;
    };
    let lens = BrownConrady::from_opencv([k1, k2, p1, p2, k3])
        .ok()
        .and_then(|m| LensDistortion::new(fx, fy, cx, cy, m).ok())
        .map(|lens| lens.fitted(w, h));
    let config = IspConfig {
        gain: gain as f32,
        wb_gains: [wb as f32, 1.0, 1.0],
        demosaic: method,
        // Noise reduction filters whole 2x2 blocks: on frames of even sides (a run refuses
        // odd ones, after the configuration validated).
        denoise: if w % 2 == 0 && h % 2 == 0 {
            denoise as f32
        } else {
            0.0
        },
        noise: isp_core::noise::NoiseProfile::uniform(0.004, 2e-5).ok(),
        // Every knee in [0, 1] in steps of 1/127, the top one off.
        highlight_knee: f32::from(head[11] >> 1) / 127.0,
        distortion: lens.filter(|_| head[10] & 1 == 1),
        // Chroma noise reduction's strength in [0, 4) in steps of 1/32, 0 off.
        chroma_denoise: f32::from(head[10] >> 1) / 32.0,
        ..IspConfig::default()
    };
    let Some(len) = config.scratch_len(w, h) else {
        return;
    };
    let mut out = vec![0u8; 3 * w * h];
    if let Ok(p) = FloatPipeline::new(&config) {
        let mut scratch = vec![0.0f32; len];
        for start in (0..h).step_by(band) {
            let rows = start..(start + band).min(h);
            let chunk = &mut out[3 * w * rows.start..3 * w * rows.end];
            let mut view = RgbViewMut::new(chunk, w, rows.len(), 3 * w).expect("a valid view");
            p.run(&raw, rows, &mut scratch, &mut view)
                .expect("a validated float pipeline runs with the scratch it reported");
        }
    }
    if let Ok(p) = FixedPipeline::new(&config, 8) {
        let mut scratch = vec![0u16; len];
        let mut view = RgbViewMut::new(&mut out, w, h, 3 * w).expect("a valid view");
        p.run(&raw, 0..h, &mut scratch, &mut view)
            .expect("a validated fixed pipeline runs with the scratch it reported");
        // Scratch one short is refused, never a panic.
        if len > 0 {
            let mut short = vec![0u16; len - 1];
            assert!(p.run(&raw, 0..h, &mut short, &mut view).is_err());
        }
    }
}

/// The directional demosaic, float and integer, on an arbitrary mosaic (size 1..40 x 1..40,
/// any pattern, 8 or 16 bits, samples from the bytes): each runs with `scratch_len` samples
/// and refuses one fewer, without panicking; a constant mosaic comes out exactly flat.
pub fn demosaic_directional(data: &[u8]) {
    use isp_core::demosaic::directional::{directional, directional_fixed, scratch_len};
    use isp_core::frame::{IntSample, MosaicView, RgbViewMut};
    use isp_core::CfaPattern;

    fn run<T: IntSample>(samples: &[T], w: usize, h: usize, pattern: CfaPattern) {
        let mosaic = MosaicView::new(samples, w, h, w, pattern).expect("a valid mosaic");
        let len = scratch_len(w).expect("a small frame's scratch");
        let flat = samples.iter().all(|v| *v == samples[0]);
        let mut float_rgb = vec![T::default(); 3 * w * h];
        let mut out = RgbViewMut::new(&mut float_rgb, w, h, 3 * w).expect("a valid view");
        let needs_scratch = w >= 2 && h >= 2;
        if needs_scratch {
            assert!(directional(&mosaic, &mut out, &mut vec![0.0; len - 1]).is_err());
        }
        directional(&mosaic, &mut out, &mut vec![0.0; len]).expect("runs with scratch_len");
        let mut fixed_rgb = vec![T::default(); 3 * w * h];
        let mut out = RgbViewMut::new(&mut fixed_rgb, w, h, 3 * w).expect("a valid view");
        if needs_scratch {
            assert!(directional_fixed(&mosaic, &mut out, &mut vec![0; len - 1]).is_err());
        }
        directional_fixed(&mosaic, &mut out, &mut vec![0; len]).expect("runs with scratch_len");
        if flat {
            assert!(float_rgb.iter().chain(&fixed_rgb).all(|v| *v == samples[0]));
        }
    }

    let [a, b, c, rest @ ..] = data else {
        return;
    };
    let (w, h) = (1 + *a as usize % 40, 1 + *b as usize % 40);
    let pattern = CfaPattern::ALL[*c as usize % 4];
    if rest.is_empty() {
        return;
    }
    if c & 4 == 0 {
        let samples: Vec<u8> = rest.iter().cycle().take(w * h).copied().collect();
        run(&samples, w, h, pattern);
    } else {
        let samples: Vec<u16> = rest
            .chunks(2)
            .map(|p| u16::from_le_bytes([p[0], *p.get(1).unwrap_or(&0)]))
            .cycle()
            .take(w * h)
            .collect();
        run(&samples, w, h, pattern);
    }
}

/// Scene files: any text is a scene or an error naming the file and line (never a panic), and
/// a scene that loads renders a tiny image of finite, non-negative radiance. Texts that name
/// files (`obj`, `png`) are left out: reading arbitrary paths is not what this checks.
pub fn scene_file(data: &[u8]) {
    use host_tracer::tracer::render::{render, RenderSettings};
    let text = String::from_utf8_lossy(data);
    if text.contains("obj") || text.contains("png") {
        return;
    }
    match host_tracer::tracer::scene_file::parse(&text, "fuzz.toml", std::path::Path::new(".")) {
        Err(e) => {
            assert!(
                matches!(&e, host_tracer::Error::Scene { file, .. } if file == "fuzz.toml"),
                "{e:?}"
            );
            assert!(e.to_string().starts_with("fuzz.toml"), "{e}");
        }
        Ok(scene) => {
            let mut s = RenderSettings::for_scene(&scene);
            (s.width, s.height, s.spp, s.threads) = (3, 2, 1, 1);
            s.path.max_depth = s.path.max_depth.min(4);
            let image = render(&scene, &s).expect("a loaded scene renders");
            assert!(image.rgb.iter().all(|v| v.is_finite()), "{:?}", image.rgb);
        }
    }
}

/// DNG files: the body lives with the decoder in raw-formats, so the `dng_decode` fuzz target
/// depends on that library alone; re-exported here for the replayed corpus and the suite.
pub use raw_formats::fuzzing::{dct_jpeg_decode, dng_decode, lossless_jpeg_decode, opcode_list};

/// ColorChecker detection on an arbitrary frame (`camsim tune`): a chart or a reason, never a
/// panic; found corners are finite and the patches they give can be sampled. Bytes 0 and 1
/// set the size (up to 200 x 200), byte 2 the pattern, bytes 3-4 the black level; the rest,
/// repeated, are the samples (blocks of a byte's value, so flat regions occur).
pub fn chart_detection(data: &[u8]) {
    use camsim::tune::chart::{detect, sample_patches, ChartMap, Mosaic};
    if data.len() < 6 {
        return;
    }
    let width = usize::from(data[0]) % 200 + 1;
    let height = usize::from(data[1]) % 200 + 1;
    let pattern = isp_core::CfaPattern::ALL[usize::from(data[2]) % 4];
    let black = f64::from(u16::from_le_bytes([data[3], data[4]]) % 4096);
    let body = &data[5..];
    let block = 1 + usize::from(body[0]) % 16;
    let samples: Vec<u16> = (0..width * height)
        .map(|i| {
            let (x, y) = (i % width / block, i / width / block);
            u16::from(body[(x * 7 + y * 13) % body.len()]) * 16
        })
        .collect();
    let mosaic = Mosaic {
        samples: &samples,
        width,
        height,
        pattern,
        black: [black; 4],
        white: 4095.0,
    };
    if let Ok(corners) = detect(&mosaic) {
        assert!(
            corners.iter().flatten().all(|v| v.is_finite()),
            "{corners:?}"
        );
        if let Some(map) = ChartMap::from_corners(&corners) {
            let patches = sample_patches(&mosaic, &map, 0.3);
            assert_eq!(patches.len(), 24);
        }
    }
}

/// A lens prescription from bytes (up to six surfaces, each shape, size, glass and stop drawn
/// from them, in sane ranges or, where the first byte says, as raw bit patterns), then every
/// analysis on it: errors or finite answers, never a panic.
pub fn lens_prescription(data: &[u8]) {
    use optics_core::prescription::glass::Medium;
    use optics_core::prescription::trace::{Ray, Traced};
    use optics_core::prescription::{Prescription, Shape, Surface, ASPHERE_TERMS};
    let raw = data.first().is_some_and(|b| b & 1 == 1);
    let mut at = 1usize;
    // The next value: a raw f64 (raw mode) or an i16 scaled to `scale`.
    let mut next = |scale: f64| -> f64 {
        if raw {
            let [v] = f64s::<1>(data.get(at..).unwrap_or(&[]));
            at += 8;
            v
        } else {
            let b = [
                data.get(at).copied().unwrap_or(0),
                data.get(at + 1).copied().unwrap_or(0),
            ];
            at += 2;
            f64::from(i16::from_le_bytes(b)) / 32768.0 * scale
        }
    };
    let count = data.get(1).map_or(1, |b| 1 + usize::from(b % 6));
    let mut surfaces = [Surface::new(Shape::Flat, 1.0, 1.0, Medium::Air); 6];
    for (i, s) in surfaces.iter_mut().take(count).enumerate() {
        let kind = next(3.0).abs() as u32;
        let curvature = next(0.08);
        s.shape = match kind {
            0 => Shape::Flat,
            1 => Shape::Sphere { curvature },
            _ => {
                let mut coefficients = [0.0; ASPHERE_TERMS];
                coefficients[0] = next(1e-4);
                coefficients[1] = next(1e-6);
                Shape::EvenAsphere {
                    curvature,
                    conic: next(3.0),
                    coefficients,
                }
            }
        };
        // Magnitudes in sane mode, so most drawn lenses pass the checks and reach the traces;
        // raw mode keeps the signs and NaNs.
        s.semi_diameter = if raw { next(30.0) } else { next(30.0).abs() };
        s.thickness = if raw { next(60.0) } else { next(60.0).abs() };
        let glass = next(4.0).abs() as u32;
        s.medium = match glass {
            0 => Medium::Air,
            1 => Medium::Constant {
                n: 1.0 + next(1.0).abs(),
            },
            2 => Medium::Model {
                nd: 1.0 + next(1.5).abs(),
                vd: 10.0 + next(110.0).abs(),
            },
            _ => Medium::Sellmeier {
                b: [next(2.0), next(0.5), next(2.0)],
                c_um2: [next(0.02), next(0.1), next(200.0)],
            },
        };
        s.is_stop = i == usize::from(data.get(2).copied().unwrap_or(0)) % count;
    }
    let wavelength = 300.0 + next(1100.0).abs();
    let Ok(lens) = Prescription::new(&surfaces[..count]) else {
        return;
    };
    if let Ok(p) = lens.paraxial(wavelength) {
        assert!(p.efl.is_finite() && p.bfl.is_finite() && p.f_number.is_finite());
    }
    if let Ok(c) = lens.conjugate(1000.0 + next(1e4).abs(), wavelength) {
        assert!(c.image_distance.is_finite() && c.magnification.is_finite());
    }
    let ray = Ray {
        origin: [next(20.0), next(20.0), -1.0 - next(10.0).abs()],
        direction: [next(1.0), next(1.0), next(1.0)],
        wavelength_nm: wavelength,
    };
    if let Ok(Traced::Image { point, direction }) = lens.trace(&ray) {
        assert!(point.iter().chain(direction.iter()).all(|v| v.is_finite()));
    }
    let field = next(1.0).abs();
    for v in [
        lens.distortion_percent(field, wavelength).ok().flatten(),
        lens.rms_spot(field, wavelength, 3).ok().flatten(),
        lens.relative_illumination(field, wavelength, 3)
            .ok()
            .flatten(),
        lens.lateral_colour(field, 486.1, 656.3, wavelength)
            .ok()
            .flatten(),
        lens.chromatic_focal_shift(486.1, wavelength).ok(),
    ]
    .into_iter()
    .flatten()
    {
        assert!(v.is_finite(), "an analysis answered {v}");
    }
    // The ISP corrections derived from the prescription: errors or finite answers too.
    let max_field = next(1.6).abs();
    if let Ok(k) = lens.fit_brown_conrady(max_field, wavelength) {
        assert!(k.iter().all(|v| v.is_finite()), "a fit answered {k:?}");
    }
    let height = next(30.0).abs();
    for v in [
        lens.field_at_height(height, wavelength, wavelength, max_field)
            .ok()
            .flatten(),
        lens.lateral_colour_scale(height, 486.1, wavelength, wavelength, max_field)
            .ok()
            .flatten(),
    ]
    .into_iter()
    .flatten()
    {
        assert!(v.is_finite(), "a correction answered {v}");
    }
    let mut scratch = [Surface::new(Shape::Flat, 1.0, 1.0, Medium::Air); 6];
    if let Ok(Some(v)) =
        lens.illumination_at_height(height, next(200.0).abs(), wavelength, 3, &mut scratch)
    {
        assert!(v.is_finite(), "the illumination answered {v}");
    }
    // isp-core's derivation over the same lens, on a small random sensor: an error or
    // stages that hold.
    use isp_core::lens_correction::{
        DistortionFit, IlluminationTable, LensCorrections, SensorFraming,
    };
    let size = |i: usize| usize::from(data.get(i).copied().unwrap_or(8) % 40) + 1;
    let Ok(framing) = SensorFraming::new(size(3), size(4), next(0.1), next(200.0)) else {
        return;
    };
    if let Ok(fix) = LensCorrections::derive(&lens, &framing, max_field, DistortionFit::ChiefRays) {
        assert!(fix.focal_length_mm.is_finite() && fix.k.iter().all(|v| v.is_finite()));
    }
    if let Ok(table) = IlluminationTable::<3>::derive(&lens, &framing, 2, &mut scratch) {
        let mut gains = [0u16; 2 * 2 * 4];
        let block = isp_core::CfaPattern::Rggb.block();
        if table.fill_grid(&framing, block, &mut gains, 2, 2).is_ok() {
            assert!(
                isp_core::lsc::LensShading::new(2, 2, &gains).is_ok(),
                "{gains:?}"
            );
        }
    }
}

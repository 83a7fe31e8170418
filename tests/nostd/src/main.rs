//! Links optics-core and isp-core into a freestanding binary and calls into both, then exits
//! with status 0 if the answers are right (checked by running it).
#![no_std]
#![no_main]

use core::panic::PanicInfo;

use isp_core::{srgb, CfaColour, CfaPattern};
use optics_core::aperture::{ApertureShape, BitmapMask, Heart, RegularPolygon};
use optics_core::camera::ThinLensCamera;
use optics_core::distortion::BrownConrady;
use optics_core::dof::depth_of_field;
use optics_core::fixed_point::{self, Dioptres, FNumber, Mm};
use optics_core::lens::sensor_distance_for_focus;

#[panic_handler]
fn panic(_: &PanicInfo) -> ! {
    exit(101)
}

fn exit(code: i32) -> ! {
    // Linux x86_64 exit_group syscall: nothing else is available without libc's start files.
    #[allow(unsafe_code)]
    unsafe {
        core::arch::asm!("syscall", in("rax") 231, in("rdi") code, options(noreturn));
    }
}

fn checks() -> bool {
    let Ok(s_i) = sensor_distance_for_focus(50.0_f64, 100.0) else {
        return false;
    };
    let Ok(dof) = depth_of_field(50.0_f32, 2.8, 0.03, 3000.0) else {
        return false;
    };
    let Ok(fixed) = fixed_point::depth_of_field(
        Mm::from_num(50),
        FNumber::from_num(2.8),
        Mm::from_num(0.03),
        Dioptres::from_num(0.5),
    ) else {
        return false;
    };
    let Ok(poly) = RegularPolygon::new(6, 0.0) else {
        return false;
    };
    let heart = Heart::new();
    let mut cdf = [0u32; 4];
    let Ok(mask) = BitmapMask::new(&[0, 255, 255, 0], 2, 2, &mut cdf) else {
        return false;
    };
    let u = optics_core::glam::Vec2::new(0.25, 0.75);
    let Ok(camera) = ThinLensCamera::new(50.0, 36.0, 24.0)
        .and_then(|c| c.with_f_number(2.0))
        .and_then(|c| c.focused_at(2000.0))
    else {
        return false;
    };
    let ray = camera
        .generate_ray(optics_core::glam::Vec2::new(1.0, 2.0), u, 0.0)
        .ray;
    let Ok(lens) = BrownConrady::new(-0.1_f64, 0.01, 0.0, 0.001, 0.0) else {
        return false;
    };
    let Ok(undistorted) = lens.undistort([0.3, 0.2]) else {
        return false;
    };
    s_i == 100.0
        && dof.near > 2000.0
        && fixed.far < fixed.near
        && poly.contains(poly.sample(u))
        && heart.contains(heart.sample(u))
        && mask.contains(mask.sample(u))
        && ray.direction.z < 0.0
        && undistorted[0] > 0.3
        && CfaPattern::Rggb.colour_at(1, 1) == CfaColour::Blue
        && srgb::encode(1.0) > 0.999
        && pipeline_runs()
        && directional_runs()
        && prescription_runs()
        && lateral_colour_runs()
}

/// A biconvex N-BK7 singlet in a stack array: its paraxial focal length, and a real ray that
/// lands near the paraxial focus (a little short: spherical aberration).
fn prescription_runs() -> bool {
    use optics_core::prescription::glass::{catalogue_glass, Medium};
    use optics_core::prescription::trace::{Ray, Traced};
    use optics_core::prescription::{Prescription, Shape, Surface};
    let Ok(bk7) = catalogue_glass("N-BK7") else {
        return false;
    };
    let surfaces = [
        Surface::new(Shape::sphere_radius(50.0_f64), 10.0, 5.0, bk7.medium()).stop(),
        Surface::new(Shape::sphere_radius(-50.0), 10.0, 47.0, Medium::Air),
    ];
    let Ok(lens) = Prescription::new(&surfaces) else {
        return false;
    };
    let Ok(p) = lens.paraxial(587.5618) else {
        return false;
    };
    let ray = Ray {
        origin: [5.0, 0.0, -1.0],
        direction: [0.0, 0.0, 1.0],
        wavelength_nm: 587.5618,
    };
    let Ok(Traced::Image { point, direction }) = lens.trace(&ray) else {
        return false;
    };
    let crossing = point[2] - point[0] * direction[2] / direction[0] - 5.0;
    // The ISP's corrections derived from it: a little barrel distortion (k1 about -0.065)
    // and corners a little darker than the centre (about 0.98 at 5 mm).
    let Ok([k1, _, _]) = lens.fit_brown_conrady(0.2, 587.5618) else {
        return false;
    };
    let mut scratch = surfaces;
    let Ok(Some(ri)) = lens.illumination_at_height(5.0, p.bfl, 587.5618, 16, &mut scratch) else {
        return false;
    };
    p.efl > 48.0
        && p.efl < 50.0
        && crossing < p.bfl
        && crossing > p.bfl - 2.0
        && k1 < -0.01
        && k1 > -0.2
        && ri > 0.5
        && ri < 1.0
}

/// The lateral-colour stage on a flat 8x6 frame in stack buffers: a flat field stays flat.
fn lateral_colour_runs() -> bool {
    use isp_core::frame::{RgbView, RgbViewMut};
    use isp_core::lateral_colour::{LateralColour, NODES};
    let Ok(lca) = LateralColour::new(8, 6, [3.5, 2.5], None, &[1.01; NODES], &[0.99; NODES]) else {
        return false;
    };
    let src = [500u16; 8 * 6 * 3];
    let mut dst = [0u16; 8 * 6 * 3];
    let (Ok(view), Ok(mut out)) = (
        RgbView::new(&src, 8, 6, 24),
        RgbViewMut::new(&mut dst, 8, 6, 24),
    ) else {
        return false;
    };
    lca.correct(&view, &mut out).is_ok() && dst.iter().all(|&v| v == 500)
}

/// The directional demosaic, float and integer, on a flat 8x8 mosaic in stack buffers: the
/// field stays flat.
fn directional_runs() -> bool {
    use isp_core::demosaic::directional::{directional, directional_fixed, scratch_len};
    use isp_core::frame::{MosaicView, RgbViewMut};
    const SCRATCH: usize = match scratch_len(8) {
        Some(n) => n,
        None => 0,
    };
    let data = [1000u16; 64];
    let Ok(mosaic) = MosaicView::new(&data, 8, 8, 8, CfaPattern::Gbrg) else {
        return false;
    };
    let mut rgb = [0u16; 192];
    let Ok(mut out) = RgbViewMut::new(&mut rgb, 8, 8, 24) else {
        return false;
    };
    let mut scratch = [0f32; SCRATCH];
    if directional(&mosaic, &mut out, &mut scratch).is_err() || rgb.iter().any(|v| *v != 1000) {
        return false;
    }
    let mut rgb = [0u16; 192];
    let Ok(mut out) = RgbViewMut::new(&mut rgb, 8, 8, 24) else {
        return false;
    };
    let mut scratch = [0i32; SCRATCH];
    directional_fixed(&mosaic, &mut out, &mut scratch).is_ok() && rgb.iter().all(|v| *v == 1000)
}

/// The whole fixed-point ISP on a flat 8x4 frame in stack buffers, with MHC, with chroma noise
/// reduction and sharpening, with the directional method and with distortion correction: 0.5
/// linear is sRGB 188.
fn pipeline_runs() -> bool {
    use isp_core::frame::{RawFrame, RgbViewMut};
    use isp_core::pipeline::{FixedPipeline, IspConfig};
    let data = [2176u16; 32];
    let Ok(raw) = RawFrame::new(&data, 8, 4, 8, 12, CfaPattern::Rggb, [256; 4], 4095) else {
        return false;
    };
    let config = IspConfig {
        demosaic: isp_core::demosaic::Method::Mhc,
        denoise: 1.0,
        noise: match isp_core::noise::NoiseProfile::uniform(0.0032, 1.5e-5) {
            Ok(profile) => Some(profile),
            Err(_) => return false,
        },
        highlight_knee: 0.9,
        ..IspConfig::default()
    };
    // Each configuration runs in exactly the scratch `IspConfig::scratch_len` reports, carved
    // from one stack buffer.
    let mut buffer = [0u16; SCRATCH];
    let mut develops = |config: &IspConfig<'_>| -> bool {
        let Ok(pipeline) = FixedPipeline::new(config, 8) else {
            return false;
        };
        let Some(scratch) = config.scratch_len(8, 4).and_then(|n| buffer.get_mut(..n)) else {
            return false;
        };
        let mut rgb = [0u8; 96];
        let Ok(mut out) = RgbViewMut::new(&mut rgb, 8, 4, 24) else {
            return false;
        };
        pipeline.run(&raw, 0..4, scratch, &mut out).is_ok() && rgb.iter().all(|v| *v == 188)
    };
    if !develops(&config) {
        return false;
    }
    // Again with the directional method (its integer version).
    if !develops(&IspConfig {
        demosaic: isp_core::demosaic::Method::Directional,
        ..config
    }) {
        return false;
    }
    // Again with chroma noise reduction and sharpening after encoding.
    if !develops(&IspConfig {
        chroma_denoise: 1.0,
        sharpen: 0.5,
        ..config
    }) {
        return false;
    }
    // Again with barrel distortion corrected: the flat field stays flat (the lens samples
    // inside the frame everywhere), in a window sized at run time.
    use isp_core::distortion::{BrownConrady, LensDistortion};
    let Ok(model) = BrownConrady::from_opencv([-0.2, 0.0, 0.0, 0.0, 0.0]) else {
        return false;
    };
    let Ok(lens) = LensDistortion::new(8.0, 8.0, 3.5, 1.5, model) else {
        return false;
    };
    develops(&IspConfig {
        distortion: Some(lens.fitted(8, 4)),
        ..config
    })
}

/// The stack buffer every configuration's scratch is carved from (16 KiB).
const SCRATCH: usize = 8192;

/// The precompiled libcore carries unwind tables that name this symbol; with `panic = "abort"`
/// nothing ever calls it.
#[no_mangle]
pub extern "C" fn rust_eh_personality() {}

// The kernel enters `_start` with the stack 16-byte aligned, not as after a call: align it and
// call into Rust with the ABI it expects.
core::arch::global_asm!(
    ".globl _start",
    "_start:",
    "xor ebp, ebp",
    "and rsp, -16",
    "call {entry}",
    "ud2",
    entry = sym entry,
);

extern "C" fn entry() -> ! {
    exit(if checks() { 0 } else { 1 })
}

//! Renders through the shipped lenses (`camsim/lenses/`), each framed to the field it passes
//! (`image_height`): a uniform white sky seen through each falls off towards the corners as
//! optics-core's relative illumination derived from the prescription says, so isp-core's
//! shading grid made from it (`lens_correction::IlluminationTable`) flattens the render
//! (issue 58: at most 1 % left), and the falloff it removes is printed beside what is left. A
//! grid of glowing dots through each lens measures the distortion and the lateral colour
//! before and after the corrections derived from the prescription as rendered
//! (`lens_correction::LensCorrections`: a Brown-Conrady fit to where each field's light lands
//! on the film, with its focal length, and the lateral-colour scales, applied in isp-core's
//! one resampling), at 1024 samples a pixel (the singlet, whose defocused colours spread
//! wider, at 8192) so the dots' centroids are good to a few hundredths of a pixel.

use std::path::{Path, PathBuf};

use host_tracer::lens_file::{LensFile, DEFAULT_PBRT_ABBE};
use host_tracer::tracer::render::{render, RenderSettings};
use host_tracer::tracer::scene::SensorSize;
use host_tracer::tracer::scene_file;
use isp_core::lens_correction::{IlluminationTable, SensorFraming, RENDER_COLOURS_NM};
use isp_core::lsc::LensShading;
use isp_core::CfaColour;
use optics_core::prescription::glass::LAMBDA_D_NM;
use optics_core::prescription::Prescription;

/// The renderer's green (RGB scenes trace green at 540 nm): the corrections' reference.
const GREEN_NM: f64 = RENDER_COLOURS_NM[1];

fn lenses() -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../camsim/lenses");
    let mut out: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    out.sort();
    out
}

/// The film radius, mm, the lens's field reaches at the d line: where the chief ray of the
/// design's half field lands, or of the widest field whose chief ray the lens passes when
/// its clear apertures stop the design's (the wide angle's, as imported, pass its chief
/// ray to 35.8 of its 50 degrees: a frame at 50 reaches past its image circle).
fn image_height(file: &LensFile) -> f64 {
    let lens = file.prescription().unwrap();
    let half = file.field_deg.unwrap_or(20.0);
    (0..=1000)
        .map(|k| half * (1.0 - k as f64 / 1000.0))
        .find_map(|deg| {
            lens.chief_height(deg.to_radians(), LAMBDA_D_NM, LAMBDA_D_NM)
                .unwrap()
                .inspect(|_| println!("{}: framed to {deg:.2} degrees", file.name))
        })
        .unwrap()
}

#[test]
fn a_white_sky_through_each_lens_falls_off_as_its_derived_illumination() {
    const SKY: &str = "[film]\nwidth = 48\nheight = 32\nspp = 8192\n\n[camera]\n\
                       position = [0.0, 0.0, 0.0]\ntarget = [0.0, 0.0, -1.0]\n\n\
                       [environment]\nrgb = [1.0, 1.0, 1.0]\n";
    let files = lenses();
    assert!(files.len() >= 6, "{files:?}");
    for path in files {
        let file = LensFile::read(&path, DEFAULT_PBRT_ABBE).unwrap();
        let mut scene = scene_file::parse(SKY, "sky", Path::new(".")).unwrap();
        scene.camera.use_lens(file.clone()).unwrap();
        // Frame the design's field across the diagonal (its chief ray lands on the corner:
        // a barrel lens's field is smaller on the film than efl tan(field), and a frame
        // that size would reach past its image circle), the lens focused at infinity.
        let lens = file.prescription().unwrap();
        let (w, h) = (48u32, 32u32);
        let diagonal_mm = 2.0 * image_height(&file);
        let width_mm = diagonal_mm * f64::from(w) / f64::from(w).hypot(f64::from(h));
        scene.camera.sensor = SensorSize::WidthMm(width_mm as f32);
        scene.camera.focus_distance = Some(1e9);
        let mut settings = RenderSettings::for_scene(&scene);
        settings.threads = 0;
        let image = render(&scene, &settings).unwrap();

        // The derived illumination per channel (each at the wavelength the renderer traces
        // it at), on the film where the renderer puts it for a far focus: the d line's
        // paraxial focus. A 17 x 13 shading grid per channel made from it, in isp-core's
        // format, as a camera's shading table is made.
        let bfl = lens.paraxial(LAMBDA_D_NM).unwrap().bfl;
        let mut scratch = file.surfaces.clone();
        let pitch = width_mm / f64::from(w);
        let framing = SensorFraming::new(w as usize, h as usize, pitch, bfl).unwrap();
        let table: IlluminationTable =
            IlluminationTable::derive(&lens, &framing, 200, &mut scratch).unwrap();
        let ri = |c: usize, r: f64| table.at(c, r).unwrap_or(0.0);
        let (gw, gh) = (17, 13);
        let grids: Vec<Vec<u16>> = [CfaColour::Red, CfaColour::Green, CfaColour::Blue]
            .into_iter()
            .map(|colour| {
                let mut gains = vec![0u16; gw * gh * 4];
                table
                    .fill_grid(&framing, [colour; 4], &mut gains, gw, gh)
                    .unwrap();
                gains
            })
            .collect();
        let shading: Vec<LensShading> = grids
            .iter()
            .map(|g| LensShading::new(gw, gh, g).unwrap())
            .collect();
        // 8 x 8 blocks, every channel, so the sample noise averages down to about 0.15 %.
        // Shading is relative to the centre, per channel (the renderer scales every channel
        // by the d line's centre; a channel's own centre differs by a fraction of a percent,
        // which white balance takes), so both sides are taken relative to the middle blocks.
        let block = |bx: u32, by: u32| {
            let (mut got, mut want, mut fixed) = ([0.0f64; 3], [0.0f64; 3], [0.0f64; 3]);
            for y in by * 8..by * 8 + 8 {
                for x in bx * 8..bx * 8 + 8 {
                    let r = (f64::from(x) + 0.5 - f64::from(w) / 2.0)
                        .hypot(f64::from(y) + 0.5 - f64::from(h) / 2.0)
                        * pitch;
                    for c in 0..3 {
                        let v = f64::from(image.rgb[3 * (y * w + x) as usize + c]);
                        got[c] += v;
                        want[c] += ri(c, r);
                        let gain =
                            shading[c].gain_f32(x as usize, y as usize, w as usize, h as usize);
                        fixed[c] += v * f64::from(gain);
                    }
                }
            }
            (got, want, fixed)
        };
        let mut centre = ([0.0f64; 3], [0.0f64; 3], [0.0f64; 3]);
        for (bx, by) in [(2, 1), (3, 1), (2, 2), (3, 2)] {
            let (g, v, f) = block(bx, by);
            for c in 0..3 {
                centre.0[c] += g[c];
                centre.1[c] += v[c];
                centre.2[c] += f[c];
            }
        }
        let (mut worst_before, mut worst_after, mut worst_grid) = (0.0f64, 0.0f64, 0.0f64);
        for by in 0..h / 8 {
            for bx in 0..w / 8 {
                let (got, want, fixed) = block(bx, by);
                for c in 0..3 {
                    let shading = got[c] / centre.0[c] * 4.0;
                    let derived = want[c] / centre.1[c] * 4.0;
                    worst_before = worst_before.max((shading - 1.0).abs());
                    worst_after = worst_after.max((shading / derived - 1.0).abs());
                    let grid_error = (fixed[c] / centre.2[c] * 4.0 - 1.0).abs();
                    worst_grid = worst_grid.max(grid_error);
                }
            }
        }
        println!(
            "{}: sky falls off by up to {:.1} %; divided by the derived illumination, {:.2} % is \
             left; through isp-core's 17 x 13 shading grid made from it, {:.2} %",
            file.name,
            100.0 * worst_before,
            100.0 * worst_after,
            100.0 * worst_grid,
        );
        // Issue 58's bound, 1 %, on every lens framed to the field it passes.
        assert!(worst_after <= 0.01, "{}: {worst_after}", file.name);
        assert!(
            worst_grid <= 0.01,
            "{}: the grid leaves {worst_grid}",
            file.name
        );
    }
}

/// Intensity-weighted centroid of channel `c` within `radius` pixels of `around` (pixel
/// centres at whole numbers).
fn centroid(rgb: &[f32], w: u32, h: u32, c: usize, around: [f64; 2], radius: f64) -> [f64; 2] {
    let (mut sum, mut sx, mut sy) = (0.0f64, 0.0f64, 0.0f64);
    let (x0, x1) = (
        (around[0] - radius).floor().max(0.0) as u32,
        ((around[0] + radius).ceil() as u32).min(w - 1),
    );
    let (y0, y1) = (
        (around[1] - radius).floor().max(0.0) as u32,
        ((around[1] + radius).ceil() as u32).min(h - 1),
    );
    for y in y0..=y1 {
        for x in x0..=x1 {
            let v = f64::from(rgb[3 * (y * w + x) as usize + c]);
            sum += v;
            sx += v * f64::from(x);
            sy += v * f64::from(y);
        }
    }
    [sx / sum, sy / sum]
}

#[test]
fn dots_through_each_lens_land_where_the_derived_corrections_put_them_back() {
    use isp_core::frame::{RgbView, RgbViewMut};
    use isp_core::lens_correction::{DistortionFit, LensCorrections};

    let (w, h) = (240u32, 160u32);
    for path in lenses() {
        let file = LensFile::read(&path, DEFAULT_PBRT_ABBE).unwrap();
        let half = file.field_deg.unwrap_or(20.0).to_radians();
        let lens = file.prescription().unwrap();
        // The ideal image is green's: the renderer's green and the fit's wavelength.
        let efl = lens.paraxial(GREEN_NM).unwrap().efl;
        let diagonal_mm = 2.0 * image_height(&file);
        let pitch = diagonal_mm / f64::from(w).hypot(f64::from(h));
        let d = 1000.0; // scene units (m): far enough to be at infinity for these lenses
                        // A 7 x 5 grid of small glowing spheres spanning 90 % of the frame, at 1000 m.
        let (cx, cy) = (f64::from(w) / 2.0 - 0.5, f64::from(h) / 2.0 - 0.5);
        // Wide open, except the f/0.96 condenser, used at f/4 as a camera would use it (wide
        // open its dots are blurs many pixels across with a core near the chief ray and a
        // centroid pixels away: no one point is "where the dot is"). Even at f/4 the singlet's
        // longitudinal colour spreads its blue dot over ~6 pixels, so few of a pixel's samples
        // reach the dot and its centroid is noisy: at 1024 samples the four corners' blue
        // read 0.05-0.33 px apart where the prescription says 0.18 (measured at 16384: 0.13 to
        // 0.17); 8 times the samples bring that noise under the bound's scale.
        let singlet = file.name.contains("Aspheric singlet");
        let (f_number, spp) = if singlet { (4.0, 8192) } else { (0.0, 1024) };
        let mut text = format!(
            "[film]\nwidth = {w}\nheight = {h}\nspp = {spp}\n\n[camera]\nposition = [0.0, 0.0, 0.0]\n\
             target = [0.0, 0.0, -1.0]\nsensor_width_mm = {}\n\n",
            pitch * f64::from(w)
        );
        let mut dots = Vec::new();
        for j in 0..5 {
            for i in 0..7 {
                let u = (f64::from(i) / 6.0 - 0.5) * 0.9 * f64::from(w);
                let v = (f64::from(j) / 4.0 - 0.5) * 0.9 * f64::from(h);
                // The ideal (distortion-free) image: efl tan(angle), in pixels from the centre.
                let (tx, ty) = (u * pitch / efl, v * pitch / efl);
                dots.push([cx + u, cy + v]);
                let r = d * 1.2 * pitch / efl;
                text += &format!(
                    "[[shape]]\ntype = \"sphere\"\ncenter = [{}, {}, {}]\nradius = {r}\n\
                     emission = {{ rgb = [1.0, 1.0, 1.0] }}\n\n",
                    tx * d,
                    -ty * d,
                    -d
                );
            }
        }
        let mut scene = scene_file::parse(&text, "dots", Path::new(".")).unwrap();
        scene.camera.focal_length_mm = efl as f32;
        scene.camera.aperture_radius_mm = if f_number > 0.0 {
            (efl / (2.0 * f_number)) as f32
        } else {
            0.0
        };
        scene.camera.use_lens(file.clone()).unwrap();
        scene.camera.focus_distance = Some(d as f32);
        let settings = RenderSettings::for_scene(&scene);
        let image = render(&scene, &settings).unwrap();

        // The corrections, derived from the prescription as rendered (stopped down, the film
        // where the renderer focuses the d line: `lens_as_rendered`) through isp-core's
        // lens_correction: distortion and lateral colour in one resampling, as the pipeline
        // runs them. The fit is to where each field's light lands on the film, with its own
        // focal length.
        let max_field = (half * 1.4).min(1.4);
        let rendered = scene.camera.lens_as_rendered(w, h).unwrap().unwrap();
        let lens = Prescription::new(&rendered.surfaces).unwrap();
        let framing =
            SensorFraming::new(w as usize, h as usize, rendered.pitch_mm, rendered.film_mm)
                .unwrap();
        let fix = LensCorrections::derive(
            &lens,
            &framing,
            max_field,
            DistortionFit::Centroids { pupil_points: 33 },
        )
        .unwrap();
        // The corrected image's scale is the fit's: a rectilinear image at that focal length.
        let magnification = fix.focal_length_mm / efl;
        let undistort = fix.distortion;
        let (wu, hu) = (w as usize, h as usize);
        let mut corrected = vec![0.0f32; image.rgb.len()];
        undistort
            .correct(
                &RgbView::new(&image.rgb, wu, hu, 3 * wu).unwrap(),
                &mut RgbViewMut::new(&mut corrected, wu, hu, 3 * wu).unwrap(),
            )
            .unwrap();

        let (mut dist_before, mut dist_after) = (0.0f64, 0.0f64);
        let (mut lc_before, mut lc_after) = (0.0f64, 0.0f64);
        for (n, ideal) in dots.iter().enumerate() {
            // Where the lens put the dot: found near its ideal place (within 16 px: the wide
            // angle moves its corner dots by more than 10; the next dot is 36 px away), then
            // refined there.
            let mut raw = centroid(&image.rgb, w, h, 1, *ideal, 16.0);
            for radius in [8.0, 4.0, 4.0] {
                raw = centroid(&image.rgb, w, h, 1, raw, radius);
            }
            let rectilinear = [
                cx + (ideal[0] - cx) * magnification,
                cy + (ideal[1] - cy) * magnification,
            ];
            let fixed = centroid(&corrected, w, h, 1, rectilinear, 4.0);
            let fixed = centroid(&corrected, w, h, 1, fixed, 4.0);
            let gap = |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).hypot(a[1] - b[1]);
            // A dot the lens loses (beyond its image circle) has no centroid.
            if !(raw[0].is_finite() && fixed[0].is_finite()) {
                continue;
            }
            dist_before = dist_before.max(gap(raw, *ideal));
            dist_after = dist_after.max(gap(fixed, rectilinear));
            // Lateral colour at the corners: red and blue against green, each colour's whole
            // dot (8 px: a 4-px window cut the singlet's 6-px blue blur and read it 0.3 px on
            // the wrong side; the next dot is 36 px away).
            let corner = matches!(n, 0 | 6 | 28 | 34);
            if corner {
                for c in [0, 2] {
                    let before = centroid(&image.rgb, w, h, c, raw, 8.0);
                    let after = centroid(&corrected, w, h, c, fixed, 8.0);
                    lc_before = lc_before.max(gap(before, raw));
                    lc_after = lc_after.max(gap(after, fixed));
                }
            }
        }
        println!(
            "{}: distortion {:.3} px before, {:.3} px after; lateral colour at the corners {:.3} px before, {:.3} px after",
            file.name, dist_before, dist_after, lc_before, lc_after
        );
        assert!(
            dist_after.is_finite() && dist_before.is_finite(),
            "{}",
            file.name
        );
        // Issue 58's bounds: at most 0.1 px of distortion and 0.2 px of lateral colour left,
        // and the colours no further apart than before.
        assert!(
            dist_after <= 0.1,
            "{}: {dist_before} -> {dist_after}",
            file.name
        );
        assert!(
            lc_after <= 0.2 && lc_after <= lc_before + 0.01,
            "{}: lateral colour {lc_before} -> {lc_after}",
            file.name
        );
    }
}

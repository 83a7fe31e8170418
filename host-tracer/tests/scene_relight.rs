//! `SceneDesc::relight`: the scene illuminant's lights take another illuminant's spectrum at
//! their own luminance; other lights, reflectances and RGB scenes are left alone or refused.

use host_tracer::spectra::{illuminant_bands, xyz_weights, BANDS};
use host_tracer::tracer::scene::Colour;
use host_tracer::tracer::scene_file;

fn luminance(b: &[f32; BANDS]) -> f32 {
    b.iter().zip(&xyz_weights()).map(|(v, w)| v * w[1]).sum()
}

fn lights(scene: &host_tracer::tracer::scene::SceneDesc) -> Vec<[f32; BANDS]> {
    scene
        .shapes
        .iter()
        .filter_map(|s| s.emission.as_ref())
        .chain(scene.environment.as_ref())
        .map(|c| match c {
            Colour::Bands(b) => **b,
            Colour::Rgb(_) => panic!("the demo's lights are spectral"),
        })
        .collect()
}

/// Unit-luminance spectra agree to a relative 1e-4 of their peak.
fn same_spectrum(a: &[f32; BANDS], b: &[f32; BANDS]) -> bool {
    let (ya, yb) = (luminance(a), luminance(b));
    let peak = b.iter().fold(0.0f32, |m, v| m.max(v / yb));
    a.iter()
        .zip(b)
        .all(|(x, y)| (x / ya - y / yb).abs() <= 1e-4 * peak)
}

#[test]
fn the_demo_relit_under_a_keeps_luminance_and_its_bokeh_lamps() {
    let mut scene = scene_file::load("demo").unwrap();
    assert_eq!(scene.illuminant.as_deref(), Some("D65"));
    let before = lights(&scene);
    let materials = scene.materials.clone();
    let relit = scene.relight("A").unwrap();
    // The key light and the environment; the six lamps are A already.
    assert_eq!(relit, 2);
    assert_eq!(scene.illuminant.as_deref(), Some("A"));
    let (a, d65) = (
        illuminant_bands("A").unwrap(),
        illuminant_bands("D65").unwrap(),
    );
    let after = lights(&scene);
    let mut changed = 0;
    for (b, n) in before.iter().zip(&after) {
        let (yb, yn) = (luminance(b), luminance(n));
        assert!((yb - yn).abs() <= 1e-4 * yb, "luminance {yb} -> {yn}");
        assert!(same_spectrum(n, &a), "every light is A now");
        changed += usize::from(same_spectrum(b, &d65));
    }
    assert_eq!(changed, relit);
    assert_eq!(
        format!("{materials:?}"),
        format!("{:?}", scene.materials),
        "reflectances unchanged"
    );
    // Relighting with the scene illuminant changes nothing.
    let mut fresh = scene_file::load("demo").unwrap();
    assert_eq!(fresh.relight("D65").unwrap(), 0);
    assert_eq!(format!("{:?}", lights(&fresh)), format!("{before:?}"));
}

#[test]
fn relight_refuses_rgb_scenes_and_unknown_illuminants() {
    let mut cornell = scene_file::load("cornell-box").unwrap();
    assert_eq!(cornell.illuminant, None);
    let e = cornell.relight("A").unwrap_err().to_string();
    assert!(e.contains("named illuminant"), "{e}");
    let mut demo = scene_file::load("demo").unwrap();
    let e = demo.relight("D75").unwrap_err().to_string();
    assert!(e.contains("D75"), "{e}");
    assert_eq!(demo.illuminant.as_deref(), Some("D65"));
}

//! `camsim lens` end to end on the lenses that ship in `camsim/lenses/`: each reads, its
//! paraxial f-number is the design's, its focal length is the same from the table and the
//! JSON, rays trace (and one beyond the front element is vignetted there); bad files are
//! refused with the file and surface named.

use std::path::PathBuf;
use std::process::{Command, Output};

use serde_json::Value;

fn camsim(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_camsim"))
        .args(args)
        .output()
        .expect("camsim runs")
}

fn lens_path(name: &str) -> String {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("lenses")
        .join(name)
        .to_string_lossy()
        .into_owned()
}

#[test]
fn the_shipped_lenses_report_their_design_f_numbers() {
    for (file, f_number) in [
        ("tessar-f4.5.toml", 4.5),
        ("telephoto-f5.6.toml", 5.6),
        ("wide-angle-100deg-f4.toml", 4.0),
        ("cooke-triplet-f4.toml", 4.0),
        ("double-gauss-f2.toml", 2.0),
        // Thorlabs gives f = 26.5 mm for 27 mm of aperture; at the d line it is 25.9 mm.
        ("aspheric-singlet-acl3026u.toml", 0.9596),
    ] {
        let path = lens_path(file);
        let out = camsim(&["lens", &path, "--json"]);
        assert!(
            out.status.success(),
            "{file}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let v: Value = serde_json::from_slice(&out.stdout).unwrap();
        let n = v["f_number"].as_f64().unwrap();
        assert!((n - f_number).abs() < 1e-4 * f_number, "{file}: f/{n}");
        assert!(
            !v["source"].as_str().unwrap().is_empty(),
            "{file}: no source"
        );
        let table = String::from_utf8(camsim(&["lens", &path]).stdout).unwrap();
        let efl = format!("{:.6} mm", v["efl_mm"].as_f64().unwrap());
        assert!(table.contains(&efl), "{file}: {table}");
        // The figures change with the wavelength: the glasses disperse.
        let blue: Value = serde_json::from_slice(
            &camsim(&["lens", &path, "--json", "--wavelength", "486.1327"]).stdout,
        )
        .unwrap();
        assert_ne!(blue["bfl_mm"], v["bfl_mm"], "{file}");
    }
}

#[test]
fn rays_trace_to_the_image_plane_or_say_where_they_stopped() {
    let path = lens_path("tessar-f4.5.toml");
    let dir = std::env::temp_dir().join(format!("camsim-lens-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let rays = dir.join("rays.json");
    std::fs::write(
        &rays,
        r#"[{"origin": [0.001, 0, -5], "direction": [0, 0, 1]},
            {"origin": [25, 0, -5], "direction": [0, 0, 1], "wavelength_nm": 656.2725}]"#,
    )
    .unwrap();
    let out = camsim(&["lens", &path, "--json", "--trace", rays.to_str().unwrap()]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    let image = &v["rays"][0]["image"];
    assert!(image[0].as_f64().unwrap().abs() < 1e-6, "{v}");
    assert_eq!(v["rays"][1]["lost_at_surface"], 1);
    assert_eq!(v["rays"][1]["lost_because"], "vignetted");
    let text =
        String::from_utf8(camsim(&["lens", &path, "--trace", rays.to_str().unwrap()]).stdout)
            .unwrap();
    assert!(text.contains("lost at surface 1: vignetted"), "{text}");

    // Bad input: the file and the surface named.
    let bad = dir.join("bad.toml");
    let good = std::fs::read_to_string(&path).unwrap();
    std::fs::write(&bad, good.replacen("glass = \"F2\"", "glass = \"F99\"", 1)).unwrap();
    let out = camsim(&["lens", bad.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        err.contains("bad.toml") && err.contains("surface 3: glass") && err.contains("F99"),
        "{err}"
    );
    // --plot writes the curves as one SVG with a panel each.
    let plots = dir.join("plots");
    let out = camsim(&["lens", &path, "--plot", plots.to_str().unwrap()]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let svg = std::fs::read_to_string(plots.join("lens.svg")).unwrap();
    for panel in [
        "distortion",
        "lateral colour",
        "relative illumination",
        "RMS spot",
        "chromatic focal shift",
    ] {
        assert!(svg.contains(panel), "lens.svg has no {panel} panel");
    }
    std::fs::write(&rays, "[{\"origin\": [0, 0]}]").unwrap();
    let out = camsim(&["lens", &path, "--trace", rays.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    let out = camsim(&["lens", &path, "--wavelength", "5000"]);
    assert!(String::from_utf8_lossy(&out.stderr).contains("--wavelength"));
    let _ = std::fs::remove_dir_all(&dir);
}

/// The peers' Python (`.venv-tune`, which carries optiland), or `None` outside CI.
fn peers_python() -> Option<PathBuf> {
    let python = std::env::var_os("CAMSIM_TUNE_PYTHON")
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../.venv-tune/bin/python")
        });
    if python.is_file() {
        return Some(python);
    }
    let why = format!(
        "no peers' Python with optiland at {} (scripts/test-all.sh makes .venv-tune)",
        python.display()
    );
    if std::env::var_os("CAMSIM_REQUIRE_ORACLE").is_some() {
        panic!("{why}; required here (CAMSIM_REQUIRE_ORACLE is set)");
    }
    eprintln!("NOTE: {why}: the comparison with optiland did not run; CI requires it");
    None
}

/// Every shipped lens beside optiland 0.6.3 at the F, d and C lines: focal lengths, back
/// focus, pupil positions and diameters within 1e-6 relative, and real rays over three fields
/// and seven pupil points within 1e-6 mm on the same image plane
/// (`scripts/compare-optiland-lens.py`, which exits 1 otherwise).
#[test]
fn the_shipped_lenses_agree_with_optiland() {
    let Some(python) = peers_python() else {
        return;
    };
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut lenses: Vec<PathBuf> = std::fs::read_dir(root.join("camsim/lenses"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    lenses.sort();
    assert!(lenses.len() >= 6);
    let out = Command::new(python)
        .arg("-W")
        .arg("ignore")
        .arg(root.join("scripts/compare-optiland-lens.py"))
        .arg(env!("CARGO_BIN_EXE_camsim"))
        .args(&lenses)
        .output()
        .expect("the comparison runs");
    let text = String::from_utf8_lossy(&out.stdout);
    println!("{text}");
    assert!(
        out.status.success(),
        "camsim and optiland differ:\n{text}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(text.contains("largest paraxial difference"), "{text}");
}

#[test]
fn demo_and_render_go_through_a_lens_file() {
    let out_dir = std::env::temp_dir().join(format!("camsim-lens-demo-{}", std::process::id()));
    let dir = out_dir.to_string_lossy().into_owned();
    let lens = lens_path("tessar-f4.5.toml");
    let out = camsim(&[
        "demo", "--lens", &lens, "--width", "96", "--height", "64", "--spp", "6", "--output", &dir,
        "--json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["lens"][0], "Tessar f/4.5");
    // The demo's f/1.4 is wider than the Tessar opens: it renders at the lens's widest.
    assert!(
        (v["lens"][1].as_f64().unwrap() - 4.5).abs() < 1e-6,
        "{}",
        v["lens"]
    );
    let vignetted = v["vignetted_fraction"].as_f64().unwrap();
    assert!(vignetted > 0.01 && vignetted < 0.9, "{vignetted}");
    assert!(out_dir.join("srgb.png").exists());
    // The corrections derived from the prescription, and the frame developed with them.
    let fix = &v["lens_correction"];
    let f = fix["focal_length_mm"].as_f64().unwrap();
    // The Tessar's 101.5 mm, scaled by the focusing move (the film further back for the
    // chart 1.2 m away).
    assert!(f > 101.0 && f < 125.0, "{fix}");
    assert!(fix["k"].as_array().unwrap().len() == 3, "{fix}");
    let gain = fix["shading_max_gain"].as_f64().unwrap();
    assert!(gain > 1.01 && gain < 2.0, "{fix}");
    let [red, blue] = [0, 1].map(|c| fix["lateral_colour_scale"][c].as_f64().unwrap());
    assert!(
        red != 1.0 && blue != 1.0 && (red - 1.0).abs() < 0.01,
        "{fix}"
    );
    let plain = std::fs::read(out_dir.join("srgb.png")).unwrap();
    let corrected = std::fs::read(out_dir.join("corrected.png")).unwrap();
    assert!(plain != corrected);
    assert!(out_dir.join("lens_comparison.png").exists());

    // A scene file naming the lens; its path is relative to the scene's folder.
    let scene = out_dir.join("scene.toml");
    std::fs::copy(&lens, out_dir.join("tessar.toml")).unwrap();
    let text = "[film]\nwidth = 32\nheight = 24\nspp = 4\n\n[camera]\nposition = [0.0, 0.0, 3.0]\n\
                target = [0.0, 0.0, 0.0]\nlens = \"tessar.toml\"\nf_number = 8.0\n\n\
                [environment]\nrgb = [1.0, 1.0, 1.0]\n";
    std::fs::write(&scene, text).unwrap();
    let preview = out_dir.join("p.png").to_string_lossy().into_owned();
    let s = scene.to_string_lossy().into_owned();
    let out = camsim(&["render", "--scene", &s, "--preview", &preview, "--json"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["camera"], "lens Tessar f/4.5");
    // A white sky through the lens: the centre of the frame reads about 1 (the thin lens's
    // radiance), so the mean is a little under.
    let mean = v["mean_rgb"][1].as_f64().unwrap();
    assert!(mean > 0.8 && mean <= 1.02, "{mean}");
    // A thin-lens setting beside the lens file is refused, naming it.
    std::fs::write(
        &scene,
        text.replace("f_number = 8.0", "focal_length_mm = 50.0"),
    )
    .unwrap();
    let out = camsim(&["render", "--scene", &s, "--preview", &preview]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("focal_length_mm"), "{err}");
    let out = camsim(&[
        "render",
        "--scene",
        &s.replace("scene", "nothing"),
        "--lens",
        &lens,
    ]);
    assert!(!out.status.success());
    std::fs::remove_dir_all(&out_dir).ok();
}

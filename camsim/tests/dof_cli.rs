//! `camsim dof` end to end: the binary's JSON against the formulas, computed here
//! independently, to 1e-9 relative; and its one-line errors.

use std::process::{Command, Output};

use proptest::prelude::*;
use serde_json::Value;

/// A valid `camsim dof` argument list (50 mm, f/2.8, c = 0.03 mm, focused at 3 m).
const GOOD_ARGS: [&str; 8] = [
    "--focal-length-mm",
    "50",
    "--f-number",
    "2.8",
    "--coc-mm",
    "0.03",
    "--focus-mm",
    "3000",
];

fn camsim(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_camsim"))
        .args(args)
        .output()
        .expect("camsim runs")
}

fn dof_json(f: f64, n: f64, c: f64, s: &str) -> Value {
    let (f, n, c) = (f.to_string(), n.to_string(), c.to_string());
    let out = camsim(&[
        "dof",
        "--focal-length-mm",
        &f,
        "--f-number",
        &n,
        "--coc-mm",
        &c,
        "--focus-mm",
        s,
        "--json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("one JSON object")
}

fn close(got: &Value, want: f64) -> bool {
    let got = got.as_f64().expect("a number");
    (got - want).abs() <= 1e-9 * want.abs().max(f64::MIN_POSITIVE)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    #[test]
    fn json_matches_the_formulas(f in 4.0f64..600.0, n in 0.5f64..64.0, c in 0.002f64..0.1, k in 1.01f64..5000.0) {
        let s = f * k;
        let v = dof_json(f, n, c, &s.to_string());
        let h = f * f / (n * c) + f;
        prop_assert!(close(&v["hyperfocal_mm"], h));
        let near = s * (h - f) / (h + s - 2.0 * f);
        prop_assert!(close(&v["near_mm"], near));
        if s < h {
            let far = s * (h - f) / (h - s);
            prop_assert!(close(&v["far_mm"], far));
            prop_assert!(close(&v["dof_mm"], far - near));
        } else {
            prop_assert!(v["far_mm"].is_null() && v["dof_mm"].is_null());
        }
        prop_assert!(close(&v["dof_approx_mm"], 2.0 * s * s * n * c / (f * f)));
        let s_i = 1.0 / (1.0 / f - 1.0 / s);
        prop_assert!(close(&v["image_distance_mm"], s_i));
        prop_assert!(close(&v["magnification"], -s_i / s));
        let keys: Vec<&String> = v.as_object().unwrap().keys().collect();
        prop_assert_eq!(keys.len(), 7);
    }
}

#[test]
fn focus_at_infinity_and_at_hyperfocal() {
    let v = dof_json(50.0, 2.8, 0.03, "inf");
    let h = 50.0 * 50.0 / (2.8 * 0.03) + 50.0;
    assert!(close(&v["near_mm"], h - 50.0));
    assert!(v["far_mm"].is_null() && v["dof_mm"].is_null() && v["dof_approx_mm"].is_null());
    assert_eq!(v["image_distance_mm"].as_f64(), Some(50.0));
    assert_eq!(v["magnification"].as_f64(), Some(0.0));
    // At exactly H the far limit is infinite.
    let at_h = dof_json(50.0, 2.8, 0.03, &h.to_string());
    assert!(at_h["far_mm"].is_null());
}

#[test]
fn table_without_json() {
    let mut args = vec!["dof"];
    args.extend(GOOD_ARGS);
    let out = camsim(&args);
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    for label in [
        "hyperfocal distance",
        "near limit",
        "far limit",
        "depth of field",
        "sensor-to-lens distance",
        "magnification",
    ] {
        assert!(text.contains(label), "missing {label} in\n{text}");
    }
    assert!(text.contains("2729.456 mm"), "{text}");
}

#[test]
fn bad_values_give_one_line_naming_the_argument_and_range() {
    let good = GOOD_ARGS;
    let cases = [
        (1, "-50", "--focal-length-mm", "> 0"),
        (1, "0", "--focal-length-mm", "> 0"),
        (1, "fifty", "--focal-length-mm", "> 0"),
        (3, "0.4", "--f-number", ">= 0.5"),
        (3, "-2", "--f-number", ">= 0.5"),
        (3, "NaN", "--f-number", ">= 0.5"),
        (5, "0", "--coc-mm", "> 0"),
        (5, "-0.03", "--coc-mm", "> 0"),
        (7, "40", "--focus-mm", "> the focal length"),
        (7, "50", "--focus-mm", "> the focal length"),
        (7, "far", "--focus-mm", "or inf"),
    ];
    for (index, value, arg, range) in cases {
        let mut args = vec!["dof"];
        let mut values = good;
        values[index] = value;
        args.extend(values);
        let out = camsim(&args);
        assert!(!out.status.success(), "{arg} {value} accepted");
        let err = String::from_utf8(out.stderr).unwrap();
        assert_eq!(err.lines().count(), 1, "{err}");
        assert!(
            err.contains(arg) && err.contains(range) && err.contains(value),
            "{err}"
        );
        assert!(out.stdout.is_empty());
    }
}

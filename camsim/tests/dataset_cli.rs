//! `camsim dataset` as schedulers run it: the same bytes whatever the split, order, thread
//! count or process; the recipes in `deploy/` run as independent processes under
//! `xargs -P2`; finished samples skipped, half-written ones never taken for samples; the
//! manifest finds what is missing or damaged; a bad spec refused before anything renders.

mod common;
use common::{camsim, temp_dir};

use std::path::{Path, PathBuf};
use std::process::Command;

const COUNT: u64 = 9;

/// A small spec drawing every generator, a built-in RGB scene and every parameter.
fn spec(dir: &Path) -> PathBuf {
    let images = Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/kodak");
    let text = format!(
        r#"[dataset]
seed = 19
count = {COUNT}
width = 40
height = 30
spp = 2
isp = true

[scene]
generators = ["colorchecker", "slanted-edge", "checkerboard", "primitives", "textured-plane", "demo", "cornell-box"]
images = {images:?}
texture_cells = 24
objects = {{ min = 2, max = 6 }}
subject_distance_m = {{ min = 0.8, max = 2.0 }}

[camera]
f_number = {{ min = 1.4, max = 16, log = true }}
focus_ratio = {{ min = 0.8, max = 1.25 }}
motion_blur_px = [0, 4]
aperture = ["disk", "hexagon", "heart"]
chromatic_aberration = [0, 0.2]
distortion_k1 = {{ min = -0.1, max = 0.1 }}

[sensor]
camera = ["nikon-5100", "canon-eos-5d-mark-ii"]
illuminant = ["A", "D65", "FL11"]
iso = {{ min = 100, max = 3200, log = true }}
noise = ["realistic", "ideal"]
pattern = ["RGGB", "GBRG"]
bits = [10, 12, 14]
shading = {{ min = 0, max = 1 }}
defects_per_million = {{ min = 0, max = 2000 }}
"#
    );
    let path = dir.join("spec.toml");
    std::fs::write(&path, text).unwrap();
    path
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Every file under `dir` (relative path, bytes), sorted; the manifest left out.
fn files(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else if p.file_name().unwrap() != "manifest.jsonl" {
                let rel = p.strip_prefix(dir).unwrap().display().to_string();
                out.push((rel, std::fs::read(&p).unwrap()));
            }
        }
    }
    out.sort();
    out
}

fn assert_same_dataset(a: &Path, b: &Path) {
    let (fa, fb) = (files(a), files(b));
    let names = |f: &[(String, Vec<u8>)]| f.iter().map(|(n, _)| n.clone()).collect::<Vec<_>>();
    assert_eq!(names(&fa), names(&fb));
    for ((name, x), (_, y)) in fa.iter().zip(&fb) {
        assert!(
            x == y,
            "{name} differs between {} and {}",
            a.display(),
            b.display()
        );
    }
}

/// The reference: every index in one process, one render thread.
fn reference(dir: &Path, spec: &Path) -> PathBuf {
    let out = dir.join("reference");
    let range = format!("0..{COUNT}");
    let (ok, stdout, stderr) = camsim(&[
        "dataset",
        "--spec",
        s(spec),
        "--out",
        s(&out),
        "--range",
        &range,
        "--threads",
        "1",
    ]);
    assert!(ok, "{stderr}");
    assert!(
        stdout.contains(&format!("{COUNT} samples written")),
        "{stdout}"
    );
    out
}

#[test]
fn any_split_order_and_thread_count_writes_the_same_bytes() {
    let dir = temp_dir("dataset-split");
    let spec = spec(&dir);
    let reference = reference(&dir, &spec);
    let record: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(reference.join("000000/record.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(record["index"], 0);
    for key in ["scene", "lens", "sensor", "capture", "render", "files"] {
        assert!(record[key].is_object(), "{key} missing: {record}");
    }
    // Every generator and the RGB scene were drawn by this spec's seed.
    let generators: Vec<String> = (0..COUNT)
        .map(|i| {
            let r: serde_json::Value = serde_json::from_str(
                &std::fs::read_to_string(reference.join(format!("{i:06}/record.json"))).unwrap(),
            )
            .unwrap();
            // An RGB scene keeps its own lights; its record does not claim the drawn one.
            let spectral = r["render"]["spectral"].as_bool().unwrap();
            assert_eq!(r["sensor"]["illuminant"].is_null(), !spectral, "{r}");
            r["scene"]["generator"].as_str().unwrap().to_owned()
        })
        .collect();
    for g in [
        "colorchecker",
        "slanted-edge",
        "checkerboard",
        "primitives",
        "textured-plane",
        "demo",
        "cornell-box",
    ] {
        assert!(
            generators.iter().any(|x| x == g),
            "{g} not drawn: {generators:?}"
        );
    }

    // Shards in reverse order with every core, then single indices: the same files.
    let split = dir.join("split");
    for shard in ["2/3", "1/3"] {
        let (ok, _, stderr) = camsim(&[
            "dataset",
            "--spec",
            s(&spec),
            "--out",
            s(&split),
            "--shard",
            shard,
            "--threads",
            "0",
        ]);
        assert!(ok, "{stderr}");
    }
    for index in (0..COUNT).rev() {
        let (ok, _, stderr) = camsim(&[
            "dataset",
            "--spec",
            s(&spec),
            "--out",
            s(&split),
            "--index",
            &index.to_string(),
            "--threads",
            "2",
        ]);
        assert!(ok, "{stderr}");
        let skipped = index % 3 != 0;
        assert_eq!(
            stderr.contains("already complete: skipped"),
            skipped,
            "{stderr}"
        );
    }
    assert_same_dataset(&reference, &split);

    // The manifest: one line per sample, in index order, each with its folder.
    let (ok, stdout, stderr) = camsim(&["dataset", "--index-manifest", s(&split)]);
    assert!(ok, "{stderr}");
    assert!(
        stdout.contains(&format!("{COUNT} of {COUNT} samples complete")),
        "{stdout}"
    );
    let manifest = std::fs::read_to_string(split.join("manifest.jsonl")).unwrap();
    let lines: Vec<serde_json::Value> = manifest
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(lines.len() as u64, COUNT);
    for (i, l) in lines.iter().enumerate() {
        assert_eq!(l["index"], i as u64);
        assert_eq!(l["path"], format!("{i:06}"));
    }
}

/// Each recipe's command lines (`deploy/`), run as separate processes two at a time with the
/// scheduler's index variables set, form the same dataset.
#[test]
fn the_scheduler_recipes_run_under_xargs_form_the_same_dataset() {
    let dir = temp_dir("dataset-recipes");
    let spec = spec(&dir);
    let reference = reference(&dir, &spec);
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../deploy");
    let bin = Path::new(env!("CARGO_BIN_EXE_camsim"));
    let mut ran = 0;
    for (recipe, variable) in [
        ("k8s-indexed-job.yaml", "JOB_COMPLETION_INDEX"),
        ("slurm-array.sh", "SLURM_ARRAY_TASK_ID"),
    ] {
        let text = std::fs::read_to_string(root.join(recipe)).unwrap();
        let commands: Vec<&str> = text
            .lines()
            .map(|l| l.trim().trim_start_matches("- ").trim_start_matches("# "))
            .filter(|l| l.starts_with("camsim dataset "))
            .collect();
        assert!(
            !commands.is_empty(),
            "no camsim dataset command in {recipe}"
        );
        for (k, command) in commands.iter().enumerate() {
            // The recipe's /data is a folder of this test's; its spec the test spec.
            let data = dir.join(format!("data-{recipe}-{k}"));
            std::fs::create_dir_all(&data).unwrap();
            std::fs::copy(&spec, data.join("spec.toml")).unwrap();
            let line = command
                .replace("/data/", &format!("{}/", data.display()))
                .replacen("camsim", s(bin), 1);
            let tasks = if line.contains("--shard") { 3 } else { COUNT };
            let script = format!(
                "seq 0 {} | xargs -P2 -I{{}} env {variable}={{}} SLURM_ARRAY_TASK_COUNT={tasks} \
                 SLURM_CPUS_PER_TASK=1 sh -c '{}'",
                tasks - 1,
                line.replace('\'', "'\\''")
            );
            let status = Command::new("sh").arg("-c").arg(&script).output().unwrap();
            assert!(
                status.status.success(),
                "{script}\n{}",
                String::from_utf8_lossy(&status.stderr)
            );
            assert_same_dataset(&reference, &data.join("out"));
            ran += 1;
        }
    }
    assert!(ran >= 3, "{ran} recipe commands");
}

#[test]
fn unfinished_and_damaged_samples_are_found_and_redone() {
    let dir = temp_dir("dataset-damage");
    let spec = spec(&dir);
    let out = dir.join("out");
    let (ok, _, stderr) = camsim(&[
        "dataset",
        "--spec",
        s(&spec),
        "--out",
        s(&out),
        "--range",
        "0..3",
    ]);
    assert!(ok, "{stderr}");
    // A worker that died mid-sample leaves a temporary folder, never a sample.
    std::fs::create_dir_all(out.join(".partial-000004-1-1")).unwrap();
    std::fs::write(out.join(".partial-000004-1-1/raw.dng"), b"half").unwrap();
    let mut bytes = std::fs::read(out.join("000001/raw.dng")).unwrap();
    bytes[200] ^= 1;
    std::fs::write(out.join("000001/raw.dng"), bytes).unwrap();
    let (ok, _, stderr) = camsim(&["dataset", "--index-manifest", s(&out)]);
    assert!(!ok);
    assert!(stderr.contains("2 of 9 samples complete"), "{stderr}");
    assert!(stderr.contains("missing 6: 3, 4, 5, 6, 7, 8"), "{stderr}");
    assert!(
        stderr.contains("corrupt 000001: raw.dng differs from its record"),
        "{stderr}"
    );
    assert!(
        stderr.contains("1 unfinished temporary folders"),
        "{stderr}"
    );
    assert!(
        stderr.contains("error: 6 missing and 1 corrupt samples"),
        "{stderr}"
    );
    // Deleting the damaged sample and running again completes the dataset.
    std::fs::remove_dir_all(out.join("000001")).unwrap();
    let (ok, stdout, stderr) = camsim(&["dataset", "--spec", s(&spec), "--out", s(&out)]);
    assert!(ok, "{stderr}");
    assert!(
        stdout.contains("7 samples written, 2 already complete"),
        "{stdout}"
    );
    let (ok, stdout, stderr) = camsim(&["dataset", "--index-manifest", s(&out)]);
    assert!(ok, "{stderr}");
    assert!(stdout.contains("9 of 9 samples complete"), "{stdout}");
}

#[test]
fn bad_specs_and_selections_are_refused_before_rendering() {
    let dir = temp_dir("dataset-refusals");
    let spec_path = spec(&dir);
    let good = std::fs::read_to_string(&spec_path).unwrap();
    let out = dir.join("out");
    let cases = [
        (
            "illuminant = [\"A\", \"D65\", \"FL11\"]",
            "illuminant = [\"A\", \"D66\"]",
            "sensor.illuminant: \"D66\" is not one of",
        ),
        (
            "bits = [10, 12, 14]",
            "bits = [10, 18]",
            "sensor.bits: ADC bits in 8..=16",
        ),
        (
            "iso = { min = 100, max = 3200, log = true }",
            "iso = { min = 0, max = 3200, log = true }",
            "sensor.iso: a log-uniform range needs min > 0",
        ),
        (
            "spp = 2",
            "spp = 2\nsamples = 3",
            "dataset.samples: unknown key",
        ),
        (
            "aperture = [\"disk\", \"hexagon\", \"heart\"]",
            "aperture = \"star\"",
            "camera.aperture: \"star\" is not one of",
        ),
        (
            "\"cornell-box\"]",
            "\"cornell-box\", \"nowhere.toml\"]",
            "\"nowhere.toml\" is neither a generator",
        ),
    ];
    for (from, to, message) in cases {
        assert!(good.contains(from), "{from}");
        let bad = dir.join("bad.toml");
        std::fs::write(&bad, good.replace(from, to)).unwrap();
        let (ok, _, stderr) = camsim(&["dataset", "--spec", s(&bad), "--out", s(&out)]);
        assert!(!ok);
        assert!(stderr.contains(message), "{message}: {stderr}");
        assert!(!out.exists(), "a refused spec wrote {}", out.display());
    }
    for (flag, value, message) in [
        ("--index", "9", "--index"),
        ("--range", "5..10", "--range"),
        ("--shard", "3/3", "--shard"),
    ] {
        let (ok, _, stderr) = camsim(&[
            "dataset",
            "--spec",
            s(&spec_path),
            "--out",
            s(&out),
            flag,
            value,
        ]);
        assert!(!ok);
        assert!(stderr.contains(message), "{stderr}");
    }
    // A folder of another spec's samples is not mixed into.
    let (ok, _, stderr) = camsim(&[
        "dataset",
        "--spec",
        s(&spec_path),
        "--out",
        s(&out),
        "--index",
        "0",
    ]);
    assert!(ok, "{stderr}");
    let other = dir.join("other.toml");
    std::fs::write(&other, good.replace("seed = 19\n", "seed = 20\n")).unwrap();
    let (ok, _, stderr) = camsim(&[
        "dataset",
        "--spec",
        s(&other),
        "--out",
        s(&out),
        "--index",
        "1",
    ]);
    assert!(!ok);
    assert!(stderr.contains("holds samples of another spec"), "{stderr}");
}

/// A camera and light whose colour matrix is beyond the ISP's range (the Sigma's Foveon-like
/// response under A) still give a raw and its truth; the record says why there is no ISP
/// output.
#[test]
fn a_frame_the_isp_cannot_develop_is_written_without_its_output() {
    let dir = temp_dir("dataset-no-isp");
    let spec = dir.join("spec.toml");
    std::fs::write(
        &spec,
        "[dataset]\nseed = 3\ncount = 1\nwidth = 32\nheight = 24\nspp = 1\nisp = true\n\n\
         [sensor]\ncamera = \"sigma-sdmerill\"\nilluminant = \"A\"\n",
    )
    .unwrap();
    let out = dir.join("out");
    let (ok, _, stderr) = camsim(&["dataset", "--spec", s(&spec), "--out", s(&out)]);
    assert!(ok, "{stderr}");
    let sample = out.join("000000");
    for name in [
        "raw.dng",
        "truth_camera.exr",
        "truth_srgb.exr",
        "record.json",
    ] {
        assert!(sample.join(name).is_file(), "{name}");
    }
    assert!(!sample.join("srgb.png").exists());
    let record: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(sample.join("record.json")).unwrap())
            .unwrap();
    assert!(record["capture"]["ccm"].is_null(), "{record}");
    let why = record["isp_refused"].as_str().unwrap();
    assert!(why.starts_with("colour matrix: "), "{why}");
    assert!(record["files"].get("srgb.png").is_none());
}

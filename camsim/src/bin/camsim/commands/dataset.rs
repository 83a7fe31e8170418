//! `camsim dataset`: renders a synthetic raw dataset's samples (see `camsim::dataset`), one
//! line per sample on stderr, and gathers finished datasets into a checked manifest.

use std::path::PathBuf;
use std::time::Instant;

use camsim::dataset::{self, Outcome, Selection, Spec};
use camsim::Error;
use clap::Args;

/// Arguments of `camsim dataset`.
#[derive(Args, Debug)]
pub struct DatasetArgs {
    /// The dataset spec (TOML: [dataset], [scene], [camera], [sensor]; docs/scale.md).
    #[arg(
        long,
        value_name = "spec.toml",
        required_unless_present = "index_manifest"
    )]
    pub spec: Option<PathBuf>,
    /// The dataset's folder: one folder per sample, NNNNNN/.
    #[arg(long, value_name = "DIR", required_unless_present = "index_manifest")]
    pub out: Option<PathBuf>,
    /// Only this sample (a scheduler's task index: $JOB_COMPLETION_INDEX, $SLURM_ARRAY_TASK_ID).
    #[arg(long, value_name = "I", group = "selection")]
    pub index: Option<u64>,
    /// Only samples A..B (B excluded).
    #[arg(long, value_name = "A..B", group = "selection", value_parser = parse_range)]
    pub range: Option<(u64, u64)>,
    /// Only shard K of N (0-based): the samples whose index is K modulo N.
    #[arg(long, value_name = "K/N", group = "selection", value_parser = parse_shard)]
    pub shard: Option<(u64, u64)>,
    /// A tuning file from `camsim tune` (overrides the spec's `dataset.tuning`): every sample
    /// is calibrated, white-balanced and developed with it, and its raw.dng carries it
    /// (colour matrices, AsShotNeutral, black level, NoiseProfile, FixBadPixelsList, GainMaps).
    /// Copied to OUT/tuning.toml; a folder holds one tuning.
    #[arg(long, value_name = "tuning.toml")]
    pub tuning: Option<PathBuf>,
    /// Render threads per sample (0: one per core; 1 when many processes share a machine).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// One JSON object per sample on stdout (index, status, seconds by step).
    #[arg(long)]
    pub json: bool,
    /// Instead of rendering: gather DIR's records into DIR/manifest.jsonl and check every
    /// sample's files; fails if any is missing or corrupt.
    #[arg(long, value_name = "DIR", conflicts_with_all = ["spec", "out", "selection"])]
    pub index_manifest: Option<PathBuf>,
}

fn parse_range(s: &str) -> Result<(u64, u64), String> {
    let (a, b) = s
        .split_once("..")
        .ok_or_else(|| format!("{s:?}: give A..B"))?;
    let n = |v: &str| {
        v.trim()
            .parse::<u64>()
            .map_err(|_| format!("{s:?}: give A..B, whole numbers"))
    };
    Ok((n(a)?, n(b)?))
}

fn parse_shard(s: &str) -> Result<(u64, u64), String> {
    let (k, n) = s
        .split_once('/')
        .ok_or_else(|| format!("{s:?}: give K/N"))?;
    let v = |v: &str| {
        v.trim()
            .parse::<u64>()
            .map_err(|_| format!("{s:?}: give K/N, whole numbers"))
    };
    Ok((v(k)?, v(n)?))
}

/// Runs `camsim dataset`.
pub fn run(args: &DatasetArgs) -> Result<String, Error> {
    if let Some(dir) = &args.index_manifest {
        let report = dataset::index_manifest(dir)?;
        let text = report.text(&dir.join("manifest.jsonl"));
        if !report.is_complete() {
            eprint!("{text}");
            return Err(Error::Message(format!(
                "{} missing and {} corrupt samples in {}",
                report.missing.len(),
                report.corrupt.len(),
                dir.display()
            )));
        }
        return Ok(text);
    }
    let (Some(spec_path), Some(out)) = (&args.spec, &args.out) else {
        return Err(Error::Message("give --spec and --out".into()));
    };
    let mut spec = Spec::load(spec_path)?;
    if let Some(tuning) = &args.tuning {
        spec.set_tuning(tuning)?;
    }
    let selection = match (args.index, args.range, args.shard) {
        (Some(i), _, _) => Selection::Index(i),
        (_, Some((a, b)), _) => Selection::Range(a, b),
        (_, _, Some((k, n))) => Selection::Shard(k, n),
        _ => Selection::All,
    };
    let indices = selection.indices(spec.count)?;
    dataset::prepare_out(&spec, out)?;
    let started = Instant::now();
    let (mut written, mut present) = (0usize, 0usize);
    let mut lines = String::new();
    for (k, &index) in indices.iter().enumerate() {
        let outcome = dataset::generate(&spec, out, index, args.threads)?;
        let done = format!("[{}/{}] {index:06}", k + 1, indices.len());
        match outcome {
            Outcome::Written(t) => {
                written += 1;
                eprintln!(
                    "{done} written in {:.2} s (render {:.2}, sensor {:.2}, ISP {:.2}, files {:.2})",
                    t.total_s, t.render_s, t.sensor_s, t.isp_s, t.write_s
                );
                if args.json {
                    let mut v =
                        serde_json::to_value(t).map_err(|e| Error::Message(e.to_string()))?;
                    v["index"] = index.into();
                    v["status"] = "written".into();
                    lines += &format!("{v}\n");
                }
            }
            Outcome::Present => {
                present += 1;
                eprintln!("{done} already complete: skipped");
                if args.json {
                    lines += &format!(
                        "{}\n",
                        serde_json::json!({"index": index, "status": "present"})
                    );
                }
            }
        }
    }
    if args.json {
        return Ok(lines);
    }
    let elapsed = started.elapsed().as_secs_f64();
    let samples = if written == 1 { "sample" } else { "samples" };
    Ok(format!(
        "{written} {samples} written, {present} already complete, in {elapsed:.1} s{}; {}\n",
        if written > 0 {
            format!(" ({:.2} s per sample)", elapsed / written as f64)
        } else {
            String::new()
        },
        out.display()
    ))
}

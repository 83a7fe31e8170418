//! `camsim dataset --index-manifest`: the samples' records gathered into `manifest.jsonl`,
//! one JSON object per line (what `pyarrow.json.read_json`, `pandas.read_json(lines=True)`
//! and `datasets.load_dataset("json")` read), with every file checked against its record.

use std::path::Path;

use serde_json::Value;

use super::{fnv1a, sample_dir, write_atomically};
use crate::error::Error;
use raw_formats::FormatError;

/// What the manifest found.
#[derive(Debug, Clone, PartialEq, Default, serde::Serialize)]
pub struct ManifestReport {
    /// Samples the spec asks for.
    pub count: u64,
    /// Samples complete and intact (in the manifest).
    pub complete: u64,
    /// Indices with no sample.
    pub missing: Vec<u64>,
    /// Indices whose record is unreadable or whose files differ from it, with why.
    pub corrupt: Vec<(u64, String)>,
    /// Unfinished temporary folders left by workers that stopped (safe to delete).
    pub partial: Vec<String>,
}

impl ManifestReport {
    /// Whether every sample is there and intact.
    pub fn is_complete(&self) -> bool {
        self.missing.is_empty() && self.corrupt.is_empty()
    }

    /// A readable summary, naming up to 20 missing and corrupt indices.
    pub fn text(&self, manifest: &Path) -> String {
        let mut t = format!(
            "{} of {} samples complete; manifest {}\n",
            self.complete,
            self.count,
            manifest.display()
        );
        if !self.missing.is_empty() {
            let shown: Vec<String> = self.missing.iter().take(20).map(u64::to_string).collect();
            let more = if self.missing.len() > 20 { ", ..." } else { "" };
            t += &format!(
                "missing {}: {}{more}\n",
                self.missing.len(),
                shown.join(", ")
            );
        }
        for (i, why) in self.corrupt.iter().take(20) {
            t += &format!("corrupt {i:06}: {why}\n");
        }
        if !self.partial.is_empty() {
            t += &format!(
                "{} unfinished temporary folders (from stopped workers; safe to delete)\n",
                self.partial.len()
            );
        }
        t
    }
}

/// What is wrong with a sample folder (its `Display` is the manifest's reason).
#[derive(Debug)]
enum Damage {
    /// `record.json` unreadable or not JSON.
    Record(String),
    /// The record is another index's.
    OtherIndex(Value),
    /// The record lists no files.
    NoFiles,
    /// A listed file is unreadable.
    Unreadable(String, std::io::Error),
    /// A listed file's size or checksum differs from the record's.
    Differs(String),
}

impl std::fmt::Display for Damage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Damage::Record(why) => write!(f, "record.json: {why}"),
            Damage::OtherIndex(i) => write!(f, "record.json is for index {i}"),
            Damage::NoFiles => write!(f, "record.json lists no files"),
            Damage::Unreadable(name, e) => write!(f, "{name}: {e}"),
            Damage::Differs(name) => {
                write!(f, "{name} differs from its record (size or checksum)")
            }
        }
    }
}

/// Checks one sample's record and files; the record with its folder added.
fn check(dir: &Path, index: u64) -> Result<Value, Damage> {
    let path = dir.join("record.json");
    let text = std::fs::read_to_string(&path).map_err(|e| Damage::Record(e.to_string()))?;
    let mut record: Value =
        serde_json::from_str(&text).map_err(|e| Damage::Record(e.to_string()))?;
    if record["index"].as_u64() != Some(index) {
        return Err(Damage::OtherIndex(record["index"].clone()));
    }
    let Some(files) = record["files"].as_object() else {
        return Err(Damage::NoFiles);
    };
    for (name, expected) in files {
        let bytes =
            std::fs::read(dir.join(name)).map_err(|e| Damage::Unreadable(name.clone(), e))?;
        let hash = format!("{:016x}", fnv1a(&bytes));
        if expected["bytes"].as_u64() != Some(bytes.len() as u64)
            || expected["fnv1a64"].as_str() != Some(hash.as_str())
        {
            return Err(Damage::Differs(name.clone()));
        }
    }
    let folder = dir
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    if let Some(map) = record.as_object_mut() {
        map.insert("path".into(), Value::String(folder));
    }
    Ok(record)
}

/// Gathers the records of the dataset in `out` (whose `spec.toml` says how many samples
/// there are) into `out/manifest.jsonl`, in index order, checking each sample's files.
pub fn index_manifest(out: &Path) -> Result<ManifestReport, Error> {
    // Only the count: the copy's relative paths (images) were relative to the original.
    let copy = out.join("spec.toml");
    let text = std::fs::read_to_string(&copy).map_err(|e| FormatError::io(&copy, e))?;
    let count = text
        .parse::<toml::Table>()
        .ok()
        .and_then(|t| t.get("dataset")?.get("count")?.as_integer())
        .filter(|c| *c >= 1)
        .ok_or_else(|| Error::Message(format!("{}: no dataset.count", copy.display())))?;
    let spec_count = count as u64;
    let mut report = ManifestReport {
        count: spec_count,
        ..ManifestReport::default()
    };
    let mut lines = String::new();
    for index in 0..spec_count {
        let dir = sample_dir(out, index);
        if !dir.exists() {
            report.missing.push(index);
            continue;
        }
        match check(&dir, index) {
            Ok(record) => {
                lines +=
                    &serde_json::to_string(&record).map_err(|e| Error::Message(e.to_string()))?;
                lines.push('\n');
                report.complete += 1;
            }
            Err(why) => report.corrupt.push((index, why.to_string())),
        }
    }
    let entries = std::fs::read_dir(out).map_err(|e| FormatError::io(out, e))?;
    for entry in entries.flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        if name.starts_with(".partial-") {
            report.partial.push(name);
        }
    }
    report.partial.sort();
    write_atomically(&out.join("manifest.jsonl"), lines.as_bytes())?;
    Ok(report)
}

//! `camsim bench tune`: camsim's tuning of simulated cameras beside Raspberry Pi's Camera Tuning
//! Tool (`rpi-ctt`) and the EMVA 1288 reference implementation (`emva1288`), every tool on the
//! same captures in the same run, each judged against the simulator's truth.
//!
//! Per camera (two spectral responses), the standard capture set
//! ([`CaptureSetSpec::standard`]: charts under A, D65 and LED-B3, flat fields at 2865 and
//! 6499 K, darks, photon-transfer pairs at ISO 100 and 400) is shot, then
//! - **colour matrices**: camsim's and rpi-ctt's, each at the light's colour temperature (both
//!   interpolate in mired between the lights they fitted), applied to the 24 patches as the
//!   camera sees them noise-free and white-balanced by the light's own colour
//!   ([`simulate::balanced_patches`]), exposure scaled to the greys, CIEDE2000 against the
//!   chart under the light adapted to D65 ([`reference::chart_srgb`]), on the three fitted
//!   lights and on D50, held out of both tools' fits;
//! - **lens shading**: the true fall-off times each tool's correction at the flat fields'
//!   colour temperatures, relative to the centre: the largest residual at the four corners
//!   and the RMS over the frame. rpi-ctt's tables are read as libcamera's PiSP IPA applies
//!   them (each of the 32 x 32 entries the centre of its cell of an even grid, bilinear, held
//!   at the edges; red `luminance x Cr`, green `luminance`, blue `luminance x Cb`), at full
//!   luminance strength (the tuning's `luminance_strength` is
//!   the ISP's choice of how much to correct, not the table's accuracy);
//! - **noise**: the DNG `NoiseProfile` (`var = S x + O`, `x` a fraction of the range) per ISO
//!   and colour, camsim's from the pairs against emva1288's system gain K and dark noise
//!   (`S = K / range`, `O = sigma_y_dark^2 / range^2`, green the mean of its two positions),
//!   both against the sensor model's.
//!
//! The peers run in `.venv-tune` (`scripts/test-all.sh` makes it from
//! `tests/oracle/tune-peers-requirements.txt`; `$CAMSIM_TUNE_PYTHON` overrides): rpi-ctt and
//! colour-checker-detection depend on OpenCV 4's wheel, which cannot share the oracle's
//! environment with its OpenCV 5.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

use serde::{Deserialize, Serialize};

use super::{run_python, ProgressFn, SuiteSettings};
use crate::error::Error;
use crate::tune::{self, fit, reference, simulate, TuneSettings};
use host_tracer::sensor::SensorConfig;
use simulate::CaptureSetSpec;

/// The cameras tuned.
pub const CAMERAS: [&str; 2] = ["nikon-5100", "canon-eos-5d-mark-ii"];
/// The light held out of every tool's fit.
pub const HELD_OUT: &str = "D50";
/// The tools, as the figures name them.
pub const CAMSIM: &str = "camsim";
/// Raspberry Pi's Camera Tuning Tool.
pub const RPI_CTT: &str = "rpi-ctt";
/// The EMVA 1288 reference implementation.
pub const EMVA1288: &str = "emva1288";

/// What `camsim bench tune` measured.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct TuneSuite {
    /// Per camera.
    pub cameras: Vec<TuneCamera>,
    /// The peers' package versions, if they ran.
    pub peer_versions: Option<BTreeMap<String, String>>,
    /// Why the peers did not run, if they did not.
    pub peers_skipped: Option<String>,
}

/// One camera's figures.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct TuneCamera {
    /// Spectral response.
    pub camera: String,
    /// Frame width and height of the captures.
    pub size: [usize; 2],
    /// Seconds each tool took on the set (camsim: the whole tuning; rpi-ctt: its command
    /// line; emva1288: the photon-transfer analysis).
    pub seconds: BTreeMap<String, f64>,
    /// A peer that ran but failed on this set, and its message.
    pub peer_errors: BTreeMap<String, String>,
    /// Colour matrices, per light and tool.
    pub ccm: Vec<CcmFigure>,
    /// Shading residual, per flat-field colour temperature, colour and tool.
    pub shading: Vec<ShadingFigure>,
    /// Noise profile, per ISO, colour and tool.
    pub noise: Vec<NoiseFigure>,
}

/// A tool's colour matrix under one light.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CcmFigure {
    /// The light.
    pub illuminant: String,
    /// Its colour temperature, K (as the capture's file name gives it).
    pub cct: f64,
    /// Whether the light was held out of the fits.
    pub held_out: bool,
    /// The tool.
    pub tool: String,
    /// CIEDE2000 per patch (1 dark skin .. 24 black).
    pub delta_e: Vec<f64>,
    /// Their mean.
    pub mean: f64,
}

/// A tool's shading correction at one colour temperature, one colour.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ShadingFigure {
    /// Colour temperature of the flat field, K.
    pub cct: f64,
    /// 0 red, 1 green, 2 blue.
    pub colour: usize,
    /// The tool.
    pub tool: String,
    /// Largest residual at the four corners, percent.
    pub corner_pct: f64,
    /// RMS residual over the frame, percent.
    pub rms_pct: f64,
}

/// A tool's noise profile at one ISO, one colour.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NoiseFigure {
    /// ISO.
    pub iso: f64,
    /// 0 red, 1 green, 2 blue.
    pub colour: usize,
    /// The tool.
    pub tool: String,
    /// S as estimated.
    pub scale: f64,
    /// O as estimated.
    pub offset: f64,
    /// The sensor model's S.
    pub true_scale: f64,
    /// The sensor model's O.
    pub true_offset: f64,
}

impl NoiseFigure {
    /// |S - S_true| / S_true, percent.
    pub fn scale_error_pct(&self) -> f64 {
        100.0 * (self.scale - self.true_scale).abs() / self.true_scale
    }
    /// |O - O_true| / O_true, percent.
    pub fn offset_error_pct(&self) -> f64 {
        100.0 * (self.offset - self.true_offset).abs() / self.true_offset
    }
}

/// The tuning peers' Python: `$CAMSIM_TUNE_PYTHON`, else `.venv-tune/bin/python`.
pub fn tune_python() -> PathBuf {
    std::env::var_os("CAMSIM_TUNE_PYTHON")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(".venv-tune/bin/python"))
}

#[derive(Deserialize)]
struct PeerReply {
    versions: BTreeMap<String, String>,
    ctt: CttReply,
    emva1288: EmvaReply,
}

#[derive(Deserialize)]
struct CttReply {
    error: Option<String>,
    seconds: Option<f64>,
    tuning: Option<serde_json::Value>,
}

#[derive(Deserialize)]
struct EmvaReply {
    error: Option<String>,
    seconds: Option<f64>,
    per_iso: Option<Vec<EmvaIso>>,
}

#[derive(Deserialize)]
struct EmvaIso {
    iso: f64,
    positions: Vec<EmvaPosition>,
}

#[derive(Deserialize)]
struct EmvaPosition {
    #[serde(rename = "K")]
    k: f64,
    sigma_y_dark: f64,
}

/// rpi-ctt's tables as the bench reads them.
struct CttTables {
    /// CCMs by colour temperature.
    ccms: Vec<(f64, [[f64; 3]; 3])>,
    /// Luminance table and the grid's nodes across and down.
    luminance: Vec<f64>,
    grid: (usize, usize),
    /// Cr and Cb tables by colour temperature.
    cr: Vec<(f64, Vec<f64>)>,
    cb: Vec<(f64, Vec<f64>)>,
}

impl CttTables {
    fn from_json(tuning: &serde_json::Value) -> Result<CttTables, super::PeerError> {
        let malformed = |problem: String| super::PeerError::Reply {
            script: "rpi-ctt's tuning file",
            problem,
        };
        let numbers = |v: &serde_json::Value| -> Option<Vec<f64>> {
            v.as_array()?
                .iter()
                .map(serde_json::Value::as_f64)
                .collect()
        };
        let ccms = tuning["rpi.ccm"]["ccms"]
            .as_array()
            .ok_or_else(|| malformed("no rpi.ccm ccms".into()))?
            .iter()
            .map(|e| {
                let ct = e["ct"].as_f64()?;
                let m = numbers(&e["ccm"]).filter(|m| m.len() == 9)?;
                Some((
                    ct,
                    std::array::from_fn(|r| [m[3 * r], m[3 * r + 1], m[3 * r + 2]]),
                ))
            })
            .collect::<Option<Vec<_>>>()
            .ok_or_else(|| malformed("a malformed rpi.ccm entry".into()))?;
        let alsc = &tuning["rpi.alsc"];
        let luminance = numbers(&alsc["luminance_lut"])
            .ok_or_else(|| malformed("no rpi.alsc luminance_lut".into()))?;
        let grid = match luminance.len() {
            1024 => (32, 32),
            192 => (16, 12),
            n => {
                return Err(malformed(format!(
                    "an ALSC table of {n} entries (not PiSP's or VC4's)"
                )))
            }
        };
        let tables = |key: &str| -> Result<Vec<(f64, Vec<f64>)>, super::PeerError> {
            alsc[key]
                .as_array()
                .ok_or_else(|| malformed(format!("no rpi.alsc {key}")))?
                .iter()
                .map(|e| Some((e["ct"].as_f64()?, numbers(&e["table"])?)))
                .collect::<Option<Vec<_>>>()
                .filter(|t| t.iter().all(|(_, v)| v.len() == luminance.len()))
                .ok_or_else(|| malformed(format!("a malformed rpi.alsc {key}")))
        };
        Ok(CttTables {
            ccms,
            cr: tables("calibrations_Cr")?,
            cb: tables("calibrations_Cb")?,
            luminance,
            grid,
        })
    }

    fn ccm_at(&self, cct: f64) -> [[f64; 3]; 3] {
        std::array::from_fn(|r| {
            std::array::from_fn(|k| {
                tune::interpolate_mired(&self.ccms, |e| e.0, cct, |e| e.1[r][k])
            })
        })
    }

    /// The gain of colour `c` at pixel `(x, y)` of a `w x h` frame at `cct`.
    fn shading_gain(&self, x: f64, y: f64, c: usize, cct: f64, w: usize, h: usize) -> f64 {
        let lum = self.at(&self.luminance, x, y, w, h);
        let colour = match c {
            0 => &self.cr,
            2 => &self.cb,
            _ => return lum,
        };
        lum * tune::interpolate_mired(colour, |e| e.0, cct, |e| self.at(&e.1, x, y, w, h))
    }

    /// A table's value at pixel `(x, y)`, as libcamera's PiSP IPA reads it (`resampleTable`
    /// in `src/ipa/rpi/pisp/pisp.cpp`): each entry the centre of its cell of an even grid over
    /// the frame, bilinear between centres, held beyond the outer ones.
    fn at(&self, table: &[f64], x: f64, y: f64, w: usize, h: usize) -> f64 {
        let (gw, gh) = self.grid;
        let fx = ((x + 0.5) / w as f64 * gw as f64 - 0.5).clamp(0.0, (gw - 1) as f64);
        let fy = ((y + 0.5) / h as f64 * gh as f64 - 0.5).clamp(0.0, (gh - 1) as f64);
        let (ix, iy) = ((fx as usize).min(gw - 2), (fy as usize).min(gh - 2));
        let (tx, ty) = (fx - ix as f64, fy - iy as f64);
        let g = |i: usize, j: usize| table[j * gw + i];
        (1.0 - ty) * ((1.0 - tx) * g(ix, iy) + tx * g(ix + 1, iy))
            + ty * ((1.0 - tx) * g(ix, iy + 1) + tx * g(ix + 1, iy + 1))
    }
}

/// Runs the suite: shoots each camera's set under `settings.out/tune/<camera>/`, tunes it,
/// runs the peers (with `python`), and measures every tool against the truth.
pub fn tune_suite(
    settings: &SuiteSettings,
    python: &Path,
    peers_skipped: &mut Option<String>,
    progress: ProgressFn<'_>,
) -> Result<TuneSuite, Error> {
    let mut suite = TuneSuite::default();
    for camera in CAMERAS {
        let dir = settings.out.join("tune").join(camera);
        let _ = std::fs::remove_dir_all(&dir);
        let mut spec = CaptureSetSpec::standard(SensorConfig {
            camera: camera.into(),
            ..SensorConfig::realistic()
        });
        if settings.quick {
            spec.width = 240;
            spec.height = 180;
        }
        progress(&format!("tune: shooting {camera}'s capture set"));
        let captures = dir.join("captures");
        let truth = simulate::write_capture_set(&spec, &captures, &mut |_| {})?;
        progress(&format!("tune: camsim tune on {camera}"));
        let started = Instant::now();
        let tuned = tune::tune(&TuneSettings::new(&captures), &mut |_| {})?;
        let mut figures = TuneCamera {
            camera: camera.into(),
            size: [spec.width, spec.height],
            ..TuneCamera::default()
        };
        figures
            .seconds
            .insert(CAMSIM.into(), started.elapsed().as_secs_f64());

        progress(&format!("tune: rpi-ctt and emva1288 on {camera}"));
        let reply = peers(
            &captures,
            &dir.join("rpi-ctt"),
            &truth,
            &spec.ptc_levels,
            python,
        );
        let (ctt, emva) = match reply {
            Ok(reply) => {
                suite.peer_versions = Some(reply.versions);
                (Some(reply.ctt), Some(reply.emva1288))
            }
            Err(why) if !settings.require_peers => {
                let why = match why {
                    super::PeerError::NoPython { python } => format!(
                        "no Python at {} (scripts/test-all.sh makes .venv-tune with rpi-ctt and \
                         emva1288; or set CAMSIM_TUNE_PYTHON)",
                        python.display()
                    ),
                    other => other.to_string(),
                };
                *peers_skipped = Some(format!("tune: {why}"));
                suite.peers_skipped = Some(why);
                (None, None)
            }
            Err(why) => return Err(Error::Message(format!("camsim bench tune: {why}"))),
        };
        let ctt_tables = match ctt {
            Some(CttReply {
                tuning: Some(t),
                seconds,
                ..
            }) => {
                if let Some(s) = seconds {
                    figures.seconds.insert(RPI_CTT.into(), s);
                }
                match CttTables::from_json(&t) {
                    Ok(t) => Some(t),
                    Err(e) => {
                        figures.peer_errors.insert(RPI_CTT.into(), e.to_string());
                        None
                    }
                }
            }
            Some(CttReply { error, .. }) => {
                let e = error.unwrap_or_else(|| "no tuning".into());
                figures.peer_errors.insert(RPI_CTT.into(), e);
                None
            }
            None => None,
        };
        if settings.require_peers {
            if let Some(e) = figures.peer_errors.get(RPI_CTT) {
                return Err(Error::Message(format!(
                    "camsim bench tune: rpi-ctt on {camera}: {e}"
                )));
            }
        }

        // Colour matrices under every light, the held-out one too.
        let illuminants_table =
            host_tracer::spectra::Table::parse(host_tracer::spectra::ILLUMINANTS)?;
        let lights: Vec<(String, bool)> = spec
            .chart_illuminants
            .iter()
            .map(|n| (n.clone(), false))
            .chain(std::iter::once((HELD_OUT.to_string(), true)))
            .collect();
        for (name, held_out) in lights {
            let cct = simulate::illuminant_cct(&name)?.round();
            let balanced = simulate::balanced_patches(camera, &name)?;
            let light = illuminants_table.named("illuminant", &name)?;
            let target = reference::chart_srgb(light)?;
            let mut tools = vec![(CAMSIM, tuned.tuning.ccm_at(cct))];
            if let Some(t) = &ctt_tables {
                tools.push((RPI_CTT, t.ccm_at(cct)));
            }
            for (tool, ccm) in tools {
                let delta_e = fit::ccm_errors_at_grey_exposure(&ccm, &balanced, &target);
                figures.ccm.push(CcmFigure {
                    illuminant: name.clone(),
                    cct,
                    held_out,
                    tool: tool.into(),
                    mean: delta_e.iter().sum::<f64>() / delta_e.len() as f64,
                    delta_e,
                });
            }
        }

        // Shading at each flat field's colour temperature.
        for name in &spec.flat_illuminants {
            let cct = simulate::illuminant_cct(name)?.round();
            for c in 0..3 {
                let t = &tuned.tuning;
                let ours = |x: f64, y: f64| t.shading_gain(x + 0.5, y + 0.5, c, cct);
                let (corner, rms) = simulate::shading_residual(&truth.shading, &spec, c, &ours);
                figures.shading.push(ShadingFigure {
                    cct,
                    colour: c,
                    tool: CAMSIM.into(),
                    corner_pct: 100.0 * corner,
                    rms_pct: 100.0 * rms,
                });
                if let Some(tables) = &ctt_tables {
                    let theirs =
                        |x: f64, y: f64| tables.shading_gain(x, y, c, cct, spec.width, spec.height);
                    let (corner, rms) =
                        simulate::shading_residual(&truth.shading, &spec, c, &theirs);
                    figures.shading.push(ShadingFigure {
                        cct,
                        colour: c,
                        tool: RPI_CTT.into(),
                        corner_pct: 100.0 * corner,
                        rms_pct: 100.0 * rms,
                    });
                }
            }
        }

        // Noise per ISO and colour.
        let range = f64::from(spec.sensor.white_level() - truth.black);
        for (iso, profile) in &truth.noise {
            let (true_s, true_o) = (profile.scale(), profile.offset());
            let truth_of = |c: usize| (f64::from(true_s[c]), f64::from(true_o[c]));
            if let Some(entry) = tuned.tuning.noise.iter().find(|e| e.iso == *iso) {
                for c in 0..3 {
                    let (ts, to) = truth_of(c);
                    figures.noise.push(NoiseFigure {
                        iso: *iso,
                        colour: c,
                        tool: CAMSIM.into(),
                        scale: entry.scale[c],
                        offset: entry.offset[c],
                        true_scale: ts,
                        true_offset: to,
                    });
                }
            }
            let Some(per_iso) = emva.as_ref().and_then(|e| e.per_iso.as_ref()) else {
                continue;
            };
            let Some(theirs) = per_iso.iter().find(|e| e.iso == *iso) else {
                continue;
            };
            if theirs.positions.len() != 4 {
                continue;
            }
            for c in 0..3 {
                let at: Vec<&EmvaPosition> = (0..4)
                    .filter(|p| spec.sensor.pattern.colour_at(p % 2, p / 2).index() == c)
                    .map(|p| &theirs.positions[p])
                    .collect();
                let n = at.len().max(1) as f64;
                let k = at.iter().map(|p| p.k).sum::<f64>() / n;
                let dark = at.iter().map(|p| p.sigma_y_dark.powi(2)).sum::<f64>() / n;
                let (ts, to) = truth_of(c);
                figures.noise.push(NoiseFigure {
                    iso: *iso,
                    colour: c,
                    tool: EMVA1288.into(),
                    scale: k / range,
                    offset: dark / (range * range),
                    true_scale: ts,
                    true_offset: to,
                });
            }
        }
        match emva {
            Some(EmvaReply { error: Some(e), .. }) => {
                if settings.require_peers {
                    return Err(Error::Message(format!(
                        "camsim bench tune: emva1288 on {camera}: {e}"
                    )));
                }
                figures.peer_errors.insert(EMVA1288.into(), e);
            }
            Some(EmvaReply {
                seconds: Some(s), ..
            }) => {
                figures.seconds.insert(EMVA1288.into(), s);
            }
            _ => {}
        }
        suite.cameras.push(figures);
    }
    Ok(suite)
}

/// Runs the peer script on the capture folder.
fn peers(
    captures: &Path,
    work: &Path,
    truth: &simulate::CaptureTruth,
    ptc_levels: &[f64],
    python: &Path,
) -> Result<PeerReply, super::PeerError> {
    let name = |p: &Path| {
        p.file_name()
            .map(|f| f.to_string_lossy().to_string())
            .unwrap_or_default()
    };
    let manifest: Vec<String> = truth
        .files
        .iter()
        .map(|f| name(f))
        .filter(|n| !n.starts_with("ptc_"))
        .collect();
    let mut ptc = Vec::new();
    for (iso, _) in &truth.noise {
        let prefix = format!("ptc_{}_", iso.round());
        let pair = |label: &str| {
            let f = |side: &str| {
                captures
                    .join(format!("{prefix}{label}_{side}.dng"))
                    .to_string_lossy()
                    .to_string()
            };
            [f("a"), f("b")]
        };
        let mut labels: Vec<usize> = truth
            .files
            .iter()
            .filter_map(|f| {
                let n = name(f);
                let rest = n.strip_prefix(&prefix)?;
                rest.strip_suffix("_a.dng")?.parse().ok()
            })
            .collect();
        labels.sort_unstable();
        let exposure = raw_formats::dng::Dng::read(&captures.join(format!("{prefix}dark_a.dng")))
            .ok()
            .and_then(|d| d.processing.exposure_time_s)
            .unwrap_or(1.0);
        let levels: Vec<serde_json::Value> = labels
            .iter()
            .map(|l| {
                let [a, b] = pair(&l.to_string());
                // The relative light stands in for the photon count (emva1288 orders the
                // points by it; K and the dark noise do not use its scale).
                let level = ptc_levels.get(*l).copied().unwrap_or((*l + 1) as f64);
                serde_json::json!([level, a, b])
            })
            .collect();
        ptc.push(serde_json::json!({
            "iso": iso, "exposure_s": exposure, "dark": pair("dark"), "levels": levels,
        }));
    }
    let request = serde_json::json!({
        "captures": captures, "work": work, "manifest": manifest, "ptc": ptc,
    });
    run_python(python, include_str!("tune_peers.py"), &request)
}

const COLOURS: [&str; 3] = ["red", "green", "blue"];

impl TuneSuite {
    /// The suite's tables (Markdown): colour matrices, shading, noise, time, per camera.
    pub fn table(&self) -> String {
        let mut md = String::from(
            "Each camera's standard capture set (charts under A, D65 and LED-B3, flat fields at \
             2865 and 6499 K, darks, photon-transfer pairs at ISO 100 and 400), tuned by camsim, \
             by rpi-ctt (`ctt -t pisp`) and, for the noise, by emva1288, every tool judged \
             against the simulator's truth. Colour matrix: mean CIEDE2000 over the 24 patches as \
             the camera sees them noise-free, white-balanced by the light, exposure scaled to the \
             greys, against the chart under the light adapted to D65; D50 is held out of every \
             fit. Shading: the true fall-off times the tool's correction, relative to the centre. \
             Noise: the DNG NoiseProfile `var = S x + O`, error against the sensor model's.",
        );
        if let Some(v) = &self.peer_versions {
            let list: Vec<String> = v.iter().map(|(k, v)| format!("{k} {v}")).collect();
            md += &format!(" Peers: {}.", list.join(", "));
        }
        if let Some(why) = &self.peers_skipped {
            md += &format!(" The peers did not run: {why}.");
        }
        md += "\n";
        for cam in &self.cameras {
            md += &format!(
                "\n### {} ({} x {})\n\n| light | camsim CCM mean | rpi-ctt CCM mean |\n|---|---|---|\n",
                cam.camera, cam.size[0], cam.size[1]
            );
            let mut lights: Vec<(&str, f64, bool)> = cam
                .ccm
                .iter()
                .map(|f| (f.illuminant.as_str(), f.cct, f.held_out))
                .collect();
            lights.dedup();
            for (light, cct, held) in lights {
                let mean = |tool: &str| {
                    cam.ccm
                        .iter()
                        .find(|f| f.illuminant == light && f.tool == tool)
                        .map_or("-".into(), |f| format!("{:.2}", f.mean))
                };
                md += &format!(
                    "| {light} ({cct} K{}) | {} | {} |\n",
                    if held { ", held out" } else { "" },
                    mean(CAMSIM),
                    mean(RPI_CTT)
                );
            }
            md += "\n| flat field | colour | camsim corner / RMS % | rpi-ctt corner / RMS % |\n|---|---|---|---|\n";
            let mut ccts: Vec<f64> = cam.shading.iter().map(|f| f.cct).collect();
            ccts.dedup();
            for cct in ccts {
                for (c, colour) in COLOURS.iter().enumerate() {
                    let of = |tool: &str| {
                        cam.shading
                            .iter()
                            .find(|f| f.cct == cct && f.colour == c && f.tool == tool)
                            .map_or("-".into(), |f| {
                                format!("{:.2} / {:.2}", f.corner_pct, f.rms_pct)
                            })
                    };
                    md += &format!(
                        "| {cct} K | {colour} | {} | {} |\n",
                        of(CAMSIM),
                        of(RPI_CTT)
                    );
                }
            }
            md += "\n| ISO | colour | true S, O | camsim S, O (error %) | emva1288 S, O (error %) |\n|---|---|---|---|---|\n";
            let mut isos: Vec<f64> = cam.noise.iter().map(|f| f.iso).collect();
            isos.sort_by(f64::total_cmp);
            isos.dedup();
            for iso in isos {
                for (c, colour) in COLOURS.iter().enumerate() {
                    let find = |tool: &str| {
                        cam.noise
                            .iter()
                            .find(|f| f.iso == iso && f.colour == c && f.tool == tool)
                    };
                    let of = |tool: &str| {
                        find(tool).map_or("-".into(), |f| {
                            format!(
                                "{:.3e}, {:.3e} ({:.1}, {:.1})",
                                f.scale,
                                f.offset,
                                f.scale_error_pct(),
                                f.offset_error_pct()
                            )
                        })
                    };
                    let truth = find(CAMSIM).or(find(EMVA1288)).map_or("-".into(), |f| {
                        format!("{:.3e}, {:.3e}", f.true_scale, f.true_offset)
                    });
                    md += &format!(
                        "| {iso} | {colour} | {truth} | {} | {} |\n",
                        of(CAMSIM),
                        of(EMVA1288)
                    );
                }
            }
            let times: Vec<String> = cam
                .seconds
                .iter()
                .map(|(k, v)| format!("{k} {v:.2} s"))
                .collect();
            md += &format!("\nTime on the set: {}.\n", times.join(", "));
            for (tool, e) in &cam.peer_errors {
                md += &format!("\n{tool} failed on this set: {e}\n");
            }
        }
        md
    }

    /// Where camsim is farther from the truth than the peer it is measured against: per camera
    /// and light, camsim's mean CIEDE2000 above rpi-ctt's; per camera, its S or O error
    /// averaged over every ISO and colour above emva1288's. Empty when it is never farther (or
    /// the peers did not run).
    pub fn behind_the_peers(&self) -> Vec<String> {
        let mut out = Vec::new();
        for cam in &self.cameras {
            for ours in cam.ccm.iter().filter(|f| f.tool == CAMSIM) {
                if let Some(theirs) = cam
                    .ccm
                    .iter()
                    .find(|f| f.tool == RPI_CTT && f.illuminant == ours.illuminant)
                {
                    if ours.mean > theirs.mean {
                        out.push(format!(
                            "{} {}: camsim's CCM {:.2} against rpi-ctt's {:.2}",
                            cam.camera, ours.illuminant, ours.mean, theirs.mean
                        ));
                    }
                }
            }
            // Noise: the mean error over every ISO and colour. Line by line the two tools
            // measure the same pairs by the same method and differ by hundredths of a percent,
            // far under the estimate's own sampling error (a variance from n pixels is
            // uncertain by sqrt(2 / n), 0.7 % for this set's planes): a line-by-line verdict
            // would be a coin toss.
            for (what, error) in [
                ("S", NoiseFigure::scale_error_pct as fn(&NoiseFigure) -> f64),
                ("O", NoiseFigure::offset_error_pct),
            ] {
                let mean = |tool: &str| {
                    let v: Vec<f64> = cam
                        .noise
                        .iter()
                        .filter(|f| f.tool == tool)
                        .map(error)
                        .collect();
                    (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
                };
                if let (Some(a), Some(b)) = (mean(CAMSIM), mean(EMVA1288)) {
                    if a > b {
                        out.push(format!(
                            "{}: camsim's {what} {a:.3} % off on average against emva1288's {b:.3} %",
                            cam.camera
                        ));
                    }
                }
            }
        }
        out
    }
}

/// Draws `tune.svg` (per camera: each light's mean CCM error, each flat field's corner
/// residual, each ISO's noise errors, camsim beside its peers) and `tune_ccm.svg` (CIEDE2000
/// per patch under every light, camsim beside rpi-ctt).
pub fn charts(suite: &TuneSuite, caption: &str, out: &Path) -> Result<(), Error> {
    let summary = out.join("tune.svg");
    draw_summary(suite, caption, &summary)
        .map_err(|e| Error::Message(format!("drawing {}: {e}", summary.display())))?;
    let patches = out.join("tune_ccm.svg");
    draw_patches(suite, caption, &patches)
        .map_err(|e| Error::Message(format!("drawing {}: {e}", patches.display())))
}

type Drawn = Result<(), Box<dyn std::error::Error>>;

/// Okabe and Ito's palette, as the bench's charts use it: camsim, then the peer.
const TOOL_COLOURS: [plotters::style::RGBColor; 2] = [
    plotters::style::RGBColor(0, 114, 178),
    plotters::style::RGBColor(230, 159, 0),
];
const FONT: &str = "sans-serif";

/// Grouped bars: one group per label, one bar per series (camsim, then the peer).
fn grouped_bars<DB: plotters::prelude::DrawingBackend>(
    area: &plotters::prelude::DrawingArea<DB, plotters::coord::Shift>,
    title: &str,
    y_desc: &str,
    labels: &[String],
    series: &[(&str, Vec<Option<f64>>)],
) -> Drawn
where
    DB::ErrorType: 'static,
{
    use plotters::prelude::*;
    let top = series
        .iter()
        .flat_map(|(_, v)| v.iter().flatten())
        .fold(0.0f64, |a, &b| a.max(b))
        .max(1e-9)
        * 1.15;
    let n = labels.len().max(1);
    let mut chart = ChartBuilder::on(area)
        .caption(title, (FONT, 14))
        .margin(8)
        .x_label_area_size(40)
        .y_label_area_size(52)
        .build_cartesian_2d(-0.5..n as f64 - 0.5, 0.0..top)?;
    let names = labels.to_vec();
    chart
        .configure_mesh()
        .disable_x_mesh()
        .x_labels(n)
        .x_label_formatter(&move |v| {
            let i = v.round();
            if (v - i).abs() < 0.01 && i >= 0.0 {
                names.get(i as usize).cloned().unwrap_or_default()
            } else {
                String::new()
            }
        })
        .y_desc(y_desc)
        .label_style((FONT, 10))
        .draw()?;
    let width = 0.8 / series.len().max(1) as f64;
    for (s, (name, values)) in series.iter().enumerate() {
        let colour = TOOL_COLOURS[s % TOOL_COLOURS.len()];
        chart
            .draw_series(values.iter().enumerate().filter_map(|(i, v)| {
                let v = (*v)?;
                let x0 = i as f64 - 0.4 + s as f64 * width;
                Some(Rectangle::new(
                    [(x0, 0.0), (x0 + width, v)],
                    colour.filled(),
                ))
            }))?
            .label(name.to_string())
            .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 10, y + 5)], colour.filled()));
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK.mix(0.3))
        .label_font((FONT, 11))
        .draw()?;
    Ok(())
}

fn draw_summary(suite: &TuneSuite, caption: &str, path: &Path) -> Drawn {
    use plotters::prelude::*;
    let rows = suite.cameras.len().max(1);
    let root = SVGBackend::new(path, (1500, 340 * rows as u32 + 70)).into_drawing_area();
    let body = super::charts::captioned(
        &root,
        "camsim tune against rpi-ctt and emva1288 on the same simulated captures (lower is better)",
        20,
        caption,
    )?;
    for (row, cam) in body.split_evenly((rows, 1)).iter().zip(&suite.cameras) {
        let panels = row.split_evenly((1, 3));
        let mut lights: Vec<(String, bool)> = cam
            .ccm
            .iter()
            .map(|f| (f.illuminant.clone(), f.held_out))
            .collect();
        lights.dedup();
        let ccm_of = |tool: &str| -> Vec<Option<f64>> {
            lights
                .iter()
                .map(|(l, _)| {
                    cam.ccm
                        .iter()
                        .find(|f| &f.illuminant == l && f.tool == tool)
                        .map(|f| f.mean)
                })
                .collect()
        };
        let labels: Vec<String> = lights
            .iter()
            .map(|(l, held)| {
                if *held {
                    format!("{l} (held out)")
                } else {
                    l.clone()
                }
            })
            .collect();
        grouped_bars(
            &panels[0],
            &format!("{}: colour matrix", cam.camera),
            "mean CIEDE2000",
            &labels,
            &[(CAMSIM, ccm_of(CAMSIM)), (RPI_CTT, ccm_of(RPI_CTT))],
        )?;
        let mut keys: Vec<(f64, usize)> = cam.shading.iter().map(|f| (f.cct, f.colour)).collect();
        keys.dedup();
        let shading_of = |tool: &str| -> Vec<Option<f64>> {
            keys.iter()
                .map(|(cct, c)| {
                    cam.shading
                        .iter()
                        .find(|f| f.cct == *cct && f.colour == *c && f.tool == tool)
                        .map(|f| f.corner_pct)
                })
                .collect()
        };
        let labels: Vec<String> = keys
            .iter()
            .map(|(cct, c)| format!("{cct} K {}", &COLOURS[*c][..1]))
            .collect();
        grouped_bars(
            &panels[1],
            "shading left at the corners",
            "residual, % of the centre",
            &labels,
            &[(CAMSIM, shading_of(CAMSIM)), (RPI_CTT, shading_of(RPI_CTT))],
        )?;
        let mut keys: Vec<(f64, usize)> = cam.noise.iter().map(|f| (f.iso, f.colour)).collect();
        keys.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        keys.dedup();
        let noise_of = |tool: &str| -> Vec<Option<f64>> {
            keys.iter()
                .flat_map(|(iso, c)| {
                    let f = cam
                        .noise
                        .iter()
                        .find(|f| f.iso == *iso && f.colour == *c && f.tool == tool);
                    [
                        f.map(NoiseFigure::scale_error_pct),
                        f.map(NoiseFigure::offset_error_pct),
                    ]
                })
                .collect()
        };
        let labels: Vec<String> = keys
            .iter()
            .flat_map(|(iso, c)| {
                let c = &COLOURS[*c][..1];
                [format!("{iso} {c} S"), format!("{iso} {c} O")]
            })
            .collect();
        grouped_bars(
            &panels[2],
            "noise profile (photon transfer)",
            "error, %",
            &labels,
            &[(CAMSIM, noise_of(CAMSIM)), (EMVA1288, noise_of(EMVA1288))],
        )?;
    }
    root.present()?;
    Ok(())
}

fn draw_patches(suite: &TuneSuite, caption: &str, path: &Path) -> Drawn {
    use plotters::prelude::*;
    let panels: Vec<(&TuneCamera, String)> = suite
        .cameras
        .iter()
        .flat_map(|cam| {
            let mut lights: Vec<String> = cam.ccm.iter().map(|f| f.illuminant.clone()).collect();
            lights.dedup();
            lights.into_iter().map(move |l| (cam, l))
        })
        .collect();
    let n = panels.len().max(1);
    let root = SVGBackend::new(path, (1300, 230 * n as u32 + 70)).into_drawing_area();
    let body = super::charts::captioned(
        &root,
        "CIEDE2000 per ColorChecker patch after each tool's colour matrix (noise-free patches, white-balanced by the light)",
        18,
        caption,
    )?;
    let labels: Vec<String> = (1..=24).map(|i| i.to_string()).collect();
    for (area, (cam, light)) in body.split_evenly((n, 1)).iter().zip(&panels) {
        let of = |tool: &str| -> Vec<Option<f64>> {
            let f = cam
                .ccm
                .iter()
                .find(|f| &f.illuminant == light && f.tool == tool);
            (0..24)
                .map(|i| f.and_then(|f| f.delta_e.get(i).copied()))
                .collect()
        };
        let held = cam.ccm.iter().any(|f| &f.illuminant == light && f.held_out);
        grouped_bars(
            area,
            &format!(
                "{} under {light}{}",
                cam.camera,
                if held { " (held out)" } else { "" }
            ),
            "CIEDE2000",
            &labels,
            &[(CAMSIM, of(CAMSIM)), (RPI_CTT, of(RPI_CTT))],
        )?;
    }
    root.present()?;
    Ok(())
}

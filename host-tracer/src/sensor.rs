//! The simulated image sensor: scene radiance in, a raw Bayer mosaic out, with the noise-free
//! truth beside it.
//!
//! Per pixel, in this order (the arithmetic is in [`pixel`], plain functions firmware tests can
//! reuse):
//! 1. **Spectral response**: camera RGB radiance = sum over the tracer's 31 bands of the scene
//!    radiance times the camera's sensitivity ([`Response`]). Sensitivities are normalised so an
//!    equal-energy spectrum of luminance 1 gives green 1. RGB-only scenes take the RGB path:
//!    camera RGB is the rendered linear sRGB.
//!    With [`SensorConfig::olpf`] on (the realistic preset), an optical low-pass filter then
//!    blurs the radiance by `[1 2 1] / 4` along each axis ([`olpf`]), as the birefringent plate
//!    in front of most cameras' sensors does; the truth is taken after it.
//! 2. **Exposure**: the pixel's irradiance is `pi L / (4 N^2)` (thin lens, object far away);
//!    electrons = irradiance x exposure time x `sensitivity_e_per_lux_s` x `qe_scale`, times the
//!    lens's vignetting (cos^4 of the field angle) and a colour-shading term that takes a
//!    further `colour_shading[c]` of channel `c` away at the frame corner, growing as r^2.
//! 3. **Fixed patterns** from `seed`: PRNU (gain, normal with sd `prnu`) and DSNU (offset
//!    electrons, normal with sd `dsnu_e`), the same in every frame of a sensor.
//! 4. **Temporal noise** from `frame_seed`: photon shot noise (Poisson on signal plus dark
//!    charge), dark current (`dark_current_e_per_s` x time), read noise (normal, electrons),
//!    row and column noise (one normal offset per row or column per frame). The mean dark
//!    charge is taken away again, as a sensor's black-level clamp on its optically black
//!    pixels (which collect the same dark charge) takes it away: its shot noise stays.
//! 5. **Saturation** at the full well, then the **ADC**: `round(e x gain) + black`, clipped to
//!    `[0, 2^bits - 1]`, where `gain = (iso / base_iso) x (white - black) / full_well`
//!    digital numbers per electron: at base ISO a full well reaches white.
//! 6. **Defective pixels** from `seed`: hot (reads white), dead (reads black), stuck (reads a
//!    fixed mid value).
//! 7. The **CFA** keeps one channel per pixel by the pattern.
//!
//! [`SensorConfig::ideal`] has every noise source, shading and defect off; each can be turned
//! on alone. [`SensorConfig::realistic`] turns them all on at typical values.
//!
//! ```
//! use host_tracer::sensor::{pixel, SensorConfig};
//! let c = SensorConfig::ideal();
//! // 12-bit ADC, black 256, full well 20000 e-: ISO 100 gives (4095 - 256) / 20000 DN per e-.
//! let gain = c.dn_per_electron();
//! assert!((gain - 3839.0 / 20000.0).abs() < 1e-12);
//! assert_eq!(pixel::adc(10000.0, gain, 256, 4095), 256 + 1920);
//! assert_eq!(pixel::adc(1e9, gain, 256, 4095), 4095);
//! ```

use isp_core::noise::NoiseProfile;
use isp_core::CfaPattern;
use raw_formats::RawImage;

use crate::error::{Error, Result};
use crate::random::Rng;
use crate::spectra::{bands_from_grid, Table, BANDS, CAMERAS, CIE1931};

/// Per-pixel arithmetic of the sensor, free of any image type.
pub mod pixel {
    use crate::random::Rng;

    /// Uniform in `[0, 1)` with 53 random bits.
    pub fn uniform(rng: &mut Rng) -> f64 {
        let bits = ((rng.next_u32() as u64) << 32) | rng.next_u32() as u64;
        (bits >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// A standard normal deviate (Box-Muller, one of the pair).
    pub fn normal(rng: &mut Rng) -> f64 {
        let u = 1.0 - uniform(rng); // (0, 1]: the log is finite
        let v = uniform(rng);
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    }

    /// `ln(k!)`: exact sums below 16, Stirling's series above (error below 1e-12).
    pub fn ln_factorial(k: f64) -> f64 {
        if k < 16.0 {
            (2..=k as u64).map(|i| (i as f64).ln()).sum()
        } else {
            let k2 = k * k;
            k * k.ln() - k + 0.5 * (std::f64::consts::TAU * k).ln() + 1.0 / (12.0 * k)
                - 1.0 / (360.0 * k * k2)
                + 1.0 / (1260.0 * k * k2 * k2)
        }
    }

    /// A Poisson deviate of mean `mean` (>= 0; NaN and negative give 0). Below 10, Knuth's
    /// product of uniforms; above, Hoermann's transformed rejection with squeeze (PTRS,
    /// "The transformed rejection method for generating Poisson random variables", 1993).
    pub fn poisson(rng: &mut Rng, mean: f64) -> f64 {
        if mean.is_nan() || mean <= 0.0 {
            return 0.0;
        }
        if mean < 10.0 {
            let limit = (-mean).exp();
            let mut k = 0.0;
            let mut product = uniform(rng);
            while product > limit {
                k += 1.0;
                product *= uniform(rng);
            }
            return k;
        }
        let sqrt_mean = mean.sqrt();
        let ln_mean = mean.ln();
        let b = 0.931 + 2.53 * sqrt_mean;
        let a = -0.059 + 0.02483 * b;
        let inv_alpha = 1.1239 + 1.1328 / (b - 3.4);
        let v_r = 0.9277 - 3.6224 / (b - 2.0);
        loop {
            let u = uniform(rng) - 0.5;
            let v = uniform(rng);
            let us = 0.5 - u.abs();
            let k = ((2.0 * a / us + b) * u + mean + 0.43).floor();
            if us >= 0.07 && v <= v_r {
                return k;
            }
            if k < 0.0 || (us < 0.013 && v > us) {
                continue;
            }
            let lhs = v.ln() + inv_alpha.ln() - (a / (us * us) + b).ln();
            if lhs <= -mean + k * ln_mean - ln_factorial(k) {
                return k;
            }
        }
    }

    /// Lens falloff at film radius `r_mm` behind a lens of focal length `focal_mm`: the cos^4
    /// law, `cos^4(atan(r / f)) = 1 / (1 + (r / f)^2)^2`.
    pub fn cos4(r_mm: f64, focal_mm: f64) -> f64 {
        let t = r_mm / focal_mm;
        1.0 / ((1.0 + t * t) * (1.0 + t * t))
    }

    /// Electrons collected from camera radiance `radiance` (luminance units) through f-number
    /// `f_number` over `exposure_s`: `pi L / (4 N^2) x t x sensitivity`.
    pub fn signal_electrons(
        radiance: f64,
        f_number: f64,
        exposure_s: f64,
        sensitivity_e_per_lux_s: f64,
    ) -> f64 {
        std::f64::consts::PI * radiance / (4.0 * f_number * f_number)
            * exposure_s
            * sensitivity_e_per_lux_s
    }

    /// The ADC: `round(electrons x gain) + black`, clipped to `[0, max]`. Saturates on any
    /// input, NaN included (read as 0 electrons).
    pub fn adc(electrons: f64, dn_per_electron: f64, black: u16, max: u16) -> u16 {
        let dn = (electrons * dn_per_electron).round() + black as f64;
        if dn.is_nan() {
            black.min(max)
        } else {
            dn.clamp(0.0, max as f64) as u16
        }
    }
}

/// How a camera turns spectral radiance into its RGB.
#[derive(Debug, Clone, PartialEq)]
pub enum Response {
    /// Measured sensitivities (or the CIE 1931 observer) per band, `[band][channel]`.
    Spectral {
        /// The camera's name.
        name: String,
        /// Weights per band, normalised so constant radiance 1 gives green 1.
        weights: Box<[[f32; 3]; BANDS]>,
    },
    /// RGB scenes: camera RGB is the rendered linear sRGB.
    LinearSrgb,
}

/// Names [`Response::named`] knows: the cameras of [`CAMERAS`] and `cie1931`.
pub fn camera_names() -> Vec<&'static str> {
    let mut names: Vec<&str> = CAMERAS.iter().map(|c| c.0).collect();
    names.push("cie1931");
    names
}

impl Response {
    /// The response of a named camera (see [`camera_names`]).
    pub fn named(name: &str) -> Result<Response> {
        let (table, columns) = if name == "cie1931" {
            (Table::parse(CIE1931)?, ["x_bar", "y_bar", "z_bar"])
        } else {
            let text = CAMERAS
                .iter()
                .find(|c| c.0 == name)
                .ok_or_else(|| Error::Unknown {
                    kind: "camera",
                    name: name.to_owned(),
                    known: camera_names().iter().map(|n| n.to_string()).collect(),
                })?
                .1;
            (Table::parse(text)?, ["r", "g", "b"])
        };
        let mut bands = [[0.0f32; BANDS]; 3];
        for (c, col) in columns.iter().enumerate() {
            bands[c] = bands_from_grid(table.named("spectral column", col)?);
        }
        let green: f32 = bands[1].iter().sum();
        if green.is_nan() || green <= 0.0 {
            return Err(Error::Table {
                line: None,
                problem: format!("camera {name}: zero green sensitivity"),
            });
        }
        Ok(Response::Spectral {
            name: name.to_owned(),
            weights: Box::new(std::array::from_fn(|b| {
                std::array::from_fn(|c| bands[c][b] / green)
            })),
        })
    }

    /// The camera's name (`linear-srgb` for the RGB path).
    pub fn name(&self) -> &str {
        match self {
            Response::Spectral { name, .. } => name,
            Response::LinearSrgb => "linear-srgb",
        }
    }

    /// Camera RGB of a band spectrum ([`BANDS`] values).
    pub fn of_bands(&self, bands: &[f32]) -> [f32; 3] {
        match self {
            Response::Spectral { weights, .. } => {
                let mut rgb = [0.0f32; 3];
                for (v, w) in bands.iter().zip(weights.iter()) {
                    for c in 0..3 {
                        rgb[c] += v * w[c];
                    }
                }
                rgb
            }
            Response::LinearSrgb => {
                crate::spectra::bands_to_linear_srgb(bands, &crate::spectra::xyz_weights())
            }
        }
    }

    /// Camera RGB radiance of every pixel of a render, 3 per pixel: the spectral response for
    /// spectral renders, the linear sRGB for RGB ones (whatever the camera: an RGB scene has
    /// no spectra to weigh).
    pub fn camera_rgb(&self, bands: &[f32], rgb: &[f32]) -> Vec<f32> {
        if bands.is_empty() {
            return rgb.to_vec();
        }
        bands
            .chunks_exact(BANDS)
            .flat_map(|b| self.of_bands(b))
            .collect()
    }
}

/// Noise sources; zero or `false` is off.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct NoiseConfig {
    /// Photon shot noise (Poisson).
    pub shot: bool,
    /// Read noise, standard deviation in electrons.
    pub read_e: f64,
    /// Dark current, electrons per second (its charge is shot-noisy too when `shot` is on).
    pub dark_current_e_per_s: f64,
    /// Photo-response non-uniformity: standard deviation of the per-pixel gain (0.01 is 1 %).
    pub prnu: f64,
    /// Dark-signal non-uniformity: standard deviation of the per-pixel offset, electrons.
    pub dsnu_e: f64,
    /// Row noise: standard deviation of one offset per row per frame, electrons.
    pub row_e: f64,
    /// Column noise: standard deviation of one offset per column per frame, electrons.
    pub column_e: f64,
}

/// Defective pixels injected from the sensor's seed, counts per million pixels.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct DefectConfig {
    /// Hot pixels (read white).
    pub hot_per_million: f64,
    /// Dead pixels (read black).
    pub dead_per_million: f64,
    /// Stuck pixels (read a fixed mid value).
    pub stuck_per_million: f64,
}

/// Lens shading seen by the sensor.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ShadingConfig {
    /// Vignetting by the cos^4 law.
    pub cos4: bool,
    /// Extra loss per channel at the frame corner (fraction, growing as r^2): colour shading.
    pub colour: [f64; 3],
}

/// The sensor; see the module docs for what each field does.
#[derive(Debug, Clone, PartialEq)]
pub struct SensorConfig {
    /// Camera name for the spectral response (see [`camera_names`]).
    pub camera: String,
    /// CFA pattern.
    pub pattern: CfaPattern,
    /// ADC bits, 8..=16 (10, 12 and 14 are usual).
    pub adc_bits: u8,
    /// Black level in DN; `None`: `2^(bits - 4)`.
    pub black_level: Option<u16>,
    /// Full-well capacity, electrons.
    pub full_well_e: f64,
    /// ISO (analog gain relative to `base_iso`).
    pub iso: f64,
    /// The ISO at which a full well reaches white.
    pub base_iso: f64,
    /// Quantum-efficiency scale on the sensitivity.
    pub qe_scale: f64,
    /// Electrons per pixel per lux-second at the sensor (one luminance unit of green response).
    pub sensitivity_e_per_lux_s: f64,
    /// Exposure time in seconds; `None`: automatic, metered as a camera meters: the 99th
    /// percentile of the brightest channel at 80 % of white after the ISO gain (80 % of the
    /// full well at base ISO; a higher ISO shortens the exposure in proportion).
    pub exposure_s: Option<f64>,
    /// Noise sources.
    pub noise: NoiseConfig,
    /// Lens shading.
    pub shading: ShadingConfig,
    /// Defective pixels.
    pub defects: DefectConfig,
    /// An optical low-pass (anti-aliasing) filter in front of the sensor: a four-spot
    /// birefringent plate splitting each ray by one pixel pitch, which blurs the radiance by
    /// `[1 2 1] / 4` along each axis (reflect-101 at the frame's edges). Its response is zero
    /// at the Nyquist frequency, so an edge sharper than the CFA can sample does not alias into
    /// false colour after demosaicing. The truth is the radiance before it.
    pub olpf: bool,
    /// Seed of the sensor's fixed patterns (PRNU, DSNU, defects).
    pub seed: u64,
    /// Seed of this frame's temporal noise.
    pub frame_seed: u64,
}

/// What kind of defect a pixel has.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DefectKind {
    /// Reads white.
    Hot,
    /// Reads black.
    Dead,
    /// Reads a fixed mid value.
    Stuck,
}

impl SensorConfig {
    /// Every noise source, shading and defect off: a Nikon 5100 response, RGGB, 12-bit ADC,
    /// black 256, full well 20000 e-, ISO 100, automatic exposure.
    pub fn ideal() -> Self {
        Self {
            camera: "nikon-5100".into(),
            pattern: CfaPattern::Rggb,
            adc_bits: 12,
            black_level: None,
            full_well_e: 20000.0,
            iso: 100.0,
            base_iso: 100.0,
            qe_scale: 1.0,
            sensitivity_e_per_lux_s: 10000.0,
            exposure_s: None,
            noise: NoiseConfig::default(),
            shading: ShadingConfig::default(),
            defects: DefectConfig::default(),
            olpf: false,
            seed: 1,
            frame_seed: 1,
        }
    }

    /// [`Self::ideal`] with everything on at values typical of a small modern sensor: shot
    /// noise, 2.5 e- read noise, 5 e-/s dark current, 1 % PRNU, 1 e- DSNU, 0.5 e- row and
    /// column noise, cos^4 vignetting with colour shading (R loses 12 %, B 6 % more at the
    /// corner), 100 hot, 50 dead and 20 stuck pixels per million, and an optical low-pass
    /// filter.
    pub fn realistic() -> Self {
        Self {
            noise: NoiseConfig {
                shot: true,
                read_e: 2.5,
                dark_current_e_per_s: 5.0,
                prnu: 0.01,
                dsnu_e: 1.0,
                row_e: 0.5,
                column_e: 0.5,
            },
            shading: ShadingConfig {
                cos4: true,
                colour: [0.12, 0.0, 0.06],
            },
            defects: DefectConfig {
                hot_per_million: 100.0,
                dead_per_million: 50.0,
                stuck_per_million: 20.0,
            },
            olpf: true,
            ..Self::ideal()
        }
    }

    /// The largest ADC code.
    pub fn white_level(&self) -> u16 {
        ((1u32 << self.adc_bits.clamp(1, 16)) - 1) as u16
    }

    /// The black level in DN.
    pub fn black(&self) -> u16 {
        self.black_level
            .unwrap_or(1u16 << self.adc_bits.clamp(4, 16).saturating_sub(4))
    }

    /// Conversion gain in DN per electron.
    pub fn dn_per_electron(&self) -> f64 {
        (self.iso / self.base_iso) * (self.white_level() - self.black()) as f64 / self.full_well_e
    }

    /// The noise profile this sensor implies over an exposure of `exposure_s` (isp-core's
    /// [`NoiseProfile`], the DNG NoiseProfile tag): with `g` the conversion gain
    /// ([`Self::dn_per_electron`]) and `R = white - black`, a signal `x = g e / R` of `e`
    /// photo-electrons has variance `S x + O` with
    ///
    /// - `S = g / R` when shot noise is on (shot noise is Poisson, so its variance in
    ///   electrons is its mean), else 0;
    /// - `O = (g / R)^2 (read^2 + row^2 + column^2 + dark) + 1 / (12 R^2)`: read, row and
    ///   column noise in electrons, the dark charge's shot noise (`dark` electrons over the
    ///   exposure, with shot noise on; the clamp takes its mean away), and the ADC's rounding
    ///   (a uniform error of one DN).
    ///
    /// The same for every colour (one conversion gain). It describes temporal noise, what a
    /// photon-transfer measurement by differencing two frames sees: PRNU and DSNU are fixed
    /// patterns, and clipping at the full well or the ADC's ends is not modelled.
    pub fn noise_profile(&self, exposure_s: f64) -> Result<NoiseProfile> {
        self.validate()?;
        let range = f64::from(self.white_level() - self.black());
        let unit = self.dn_per_electron() / range;
        let n = &self.noise;
        let scale = if n.shot { unit } else { 0.0 };
        let dark = if n.shot {
            n.dark_current_e_per_s * exposure_s.max(0.0)
        } else {
            0.0
        };
        let electrons2 = n.read_e * n.read_e + n.row_e * n.row_e + n.column_e * n.column_e + dark;
        let offset = unit * unit * electrons2 + 1.0 / (12.0 * range * range);
        NoiseProfile::uniform(scale as f32, offset as f32).map_err(|source| Error::Isp {
            step: "the sensor's noise profile (a noise as large as the range?)",
            source,
        })
    }

    /// Checks every field; errors name it and the allowed range.
    pub fn validate(&self) -> Result<()> {
        let setting = |field: &'static str, value: String, allowed: String| {
            Err(Error::SensorSetting {
                field,
                value,
                allowed,
            })
        };
        let positive = |v: f64, name: &'static str| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                setting(name, v.to_string(), "a finite number > 0".into())
            }
        };
        let non_negative = |v: f64, name: &'static str| {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                setting(name, v.to_string(), "a finite number >= 0".into())
            }
        };
        if !(8..=16).contains(&self.adc_bits) {
            return setting(
                "adc_bits",
                self.adc_bits.to_string(),
                "8..=16 (10, 12, 14 are usual)".into(),
            );
        }
        if self.black() >= self.white_level() / 2 {
            return setting(
                "black_level",
                self.black().to_string(),
                format!("below half the ADC range ({})", self.white_level() / 2),
            );
        }
        positive(self.full_well_e, "full_well_e")?;
        positive(self.iso, "iso")?;
        positive(self.base_iso, "base_iso")?;
        positive(self.qe_scale, "qe_scale")?;
        positive(self.sensitivity_e_per_lux_s, "sensitivity_e_per_lux_s")?;
        if let Some(t) = self.exposure_s {
            positive(t, "exposure_s")?;
        }
        let n = &self.noise;
        for (v, name) in [
            (n.read_e, "read_e"),
            (n.dark_current_e_per_s, "dark_current_e_per_s"),
            (n.prnu, "prnu"),
            (n.dsnu_e, "dsnu_e"),
            (n.row_e, "row_e"),
            (n.column_e, "column_e"),
            (self.defects.hot_per_million, "hot_per_million"),
            (self.defects.dead_per_million, "dead_per_million"),
            (self.defects.stuck_per_million, "stuck_per_million"),
        ] {
            non_negative(v, name)?;
        }
        if self.shading.colour.iter().any(|c| !(0.0..1.0).contains(c)) {
            return setting(
                "colour shading",
                format!("{:?}", self.shading.colour),
                "each in [0, 1)".into(),
            );
        }
        Response::named(&self.camera).map(|_| ())
    }
}

/// The optics in front of the sensor, for exposure and vignetting.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LensGeometry {
    /// f-number.
    pub f_number: f64,
    /// Focal length, mm.
    pub focal_length_mm: f64,
    /// Sensor width and height, mm.
    pub sensor_mm: [f64; 2],
}

impl LensGeometry {
    /// A thin lens of focal length `focal_length_mm` and aperture radius `aperture_radius_mm`
    /// in front of a sensor `sensor_mm` across; a pinhole (radius 0) is taken as f/8.
    pub fn thin_lens(focal_length_mm: f64, aperture_radius_mm: f64, sensor_mm: [f64; 2]) -> Self {
        let (f, r) = (focal_length_mm, aperture_radius_mm);
        LensGeometry {
            f_number: if r > 0.0 { f / (2.0 * r) } else { 8.0 },
            focal_length_mm: f,
            sensor_mm,
        }
    }
}

/// A shading model evaluated per pixel: the product of cos^4 vignetting and colour shading.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Shading {
    config: ShadingConfig,
    lens: LensGeometry,
    width: usize,
    height: usize,
}

impl Shading {
    /// The fraction of light channel `c` keeps at pixel `(x, y)`.
    pub fn factor(&self, x: f64, y: f64, c: usize) -> f64 {
        let (w, h) = (self.width.max(1) as f64, self.height.max(1) as f64);
        let dx = ((x + 0.5) / w - 0.5) * self.lens.sensor_mm[0];
        let dy = ((y + 0.5) / h - 0.5) * self.lens.sensor_mm[1];
        let r2 = dx * dx + dy * dy;
        let corner2 = 0.25
            * (self.lens.sensor_mm[0] * self.lens.sensor_mm[0]
                + self.lens.sensor_mm[1] * self.lens.sensor_mm[1]);
        let vignette = if self.config.cos4 {
            pixel::cos4(r2.sqrt(), self.lens.focal_length_mm)
        } else {
            1.0
        };
        let colour = 1.0 - self.config.colour[c.min(2)] * (r2 / corner2.max(1e-12)).min(1.0);
        vignette * colour
    }

    /// Whether the model changes anything.
    pub fn is_active(&self) -> bool {
        self.config.cos4 || self.config.colour != [0.0; 3]
    }

    /// The lens-shading-correction grid that undoes this shading for isp-core's LSC stage:
    /// `grid_w x grid_h` nodes on the frame's corner pixels, four Q4.12 gains per node (one per
    /// CFA position), as [`isp_core::lsc::LensShading`] reads them.
    pub fn correction_grid(&self, grid_w: usize, grid_h: usize, pattern: CfaPattern) -> Vec<u16> {
        let mut gains = Vec::with_capacity(grid_w * grid_h * 4);
        for gy in 0..grid_h {
            for gx in 0..grid_w {
                let x = gx as f64 * (self.width.max(2) - 1) as f64 / (grid_w.max(2) - 1) as f64;
                let y = gy as f64 * (self.height.max(2) - 1) as f64 / (grid_h.max(2) - 1) as f64;
                for position in 0..4 {
                    let c = pattern.colour_at(position % 2, position / 2).index();
                    let g = 1.0 / self.factor(x, y, c).max(1.0 / 15.99);
                    gains.push((g * isp_core::lsc::ONE_Q12 as f64).round() as u16);
                }
            }
        }
        gains
    }
}

/// One captured frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Capture {
    /// The raw frame: the mosaic, its pattern, the ADC's bits, black level (the same at every
    /// CFA position) and white level (the ADC maximum).
    pub raw: RawImage,
    /// Noise-free camera RGB, 3 per pixel, in the ISP's linear units (fraction of
    /// `white - black`), without shading or defects: what a perfect ISP would recover before
    /// colour correction. May exceed 1 where the raw clipped.
    pub truth_camera: Vec<f32>,
    /// Exposure time used, s.
    pub exposure_s: f64,
    /// Linear units of [`Self::truth_camera`] per unit of camera radiance.
    pub units_per_radiance: f64,
    /// The injected defects, row-major.
    pub defects: Vec<(usize, usize, DefectKind)>,
    /// The shading the frame went through.
    pub shading: Shading,
    /// The temporal noise the sensor implies ([`SensorConfig::noise_profile`]).
    pub noise_profile: NoiseProfile,
}

#[allow(clippy::needless_range_loop)] // x and y index several arrays and the pattern
/// Simulates the sensor on a frame of camera RGB radiance (3 per pixel, from
/// [`Response::camera_rgb`]) seen through `lens`.
pub fn capture(
    camera_rgb: &[f32],
    width: usize,
    height: usize,
    lens: LensGeometry,
    config: &SensorConfig,
) -> Result<Capture> {
    config.validate()?;
    if width == 0 || height == 0 || camera_rgb.len() != width * height * 3 {
        return Err(Error::out_of_range(
            "sensor radiance values",
            camera_rgb.len(),
            format!("{width} x {height} x 3, at least 1 x 1"),
        ));
    }
    if !(lens.f_number.is_finite() && lens.f_number > 0.0 && lens.focal_length_mm > 0.0) {
        return Err(Error::out_of_range(
            "sensor lens f-number and focal length",
            format!("f/{} and {} mm", lens.f_number, lens.focal_length_mm),
            "> 0",
        ));
    }
    let shading = Shading {
        config: config.shading,
        lens,
        width,
        height,
    };
    let sensitivity = config.sensitivity_e_per_lux_s * config.qe_scale;
    let exposure_s = match config.exposure_s {
        Some(t) => t,
        None => auto_exposure(
            camera_rgb,
            width,
            &shading,
            lens.f_number,
            sensitivity,
            config,
        )?,
    };
    let e_per_radiance = pixel::signal_electrons(1.0, lens.f_number, exposure_s, sensitivity);
    let gain = config.dn_per_electron();
    let (black, white) = (config.black(), config.white_level());
    let range = (white - black) as f64;
    let units_per_radiance = e_per_radiance * gain / range;

    let noise = config.noise;
    let mut fixed = Rng::new(config.seed, 0x5e_4501);
    let mut temporal = Rng::new(config.frame_seed, 0x7e_4a01);
    let row_offsets: Vec<f64> = (0..height)
        .map(|_| noise.row_e * pixel::normal(&mut temporal))
        .collect();
    let column_offsets: Vec<f64> = (0..width)
        .map(|_| noise.column_e * pixel::normal(&mut temporal))
        .collect();
    let dark_e = noise.dark_current_e_per_s * exposure_s;

    let filtered = config.olpf.then(|| olpf(camera_rgb, width, height));
    let seen = filtered.as_deref().unwrap_or(camera_rgb);
    let mut raw = vec![0u16; width * height];
    let mut truth_camera = vec![0.0f32; width * height * 3];
    for y in 0..height {
        for x in 0..width {
            let i = y * width + x;
            let rgb = &seen[3 * i..3 * i + 3];
            for c in 0..3 {
                truth_camera[3 * i + c] = (rgb[c] as f64 * units_per_radiance) as f32;
            }
            let c = config.pattern.colour_at(x, y).index();
            let mut mean = rgb[c].max(0.0) as f64 * e_per_radiance;
            if shading.is_active() {
                mean *= shading.factor(x as f64, y as f64, c);
            }
            // Fixed patterns are drawn for every pixel whether on or off, so turning one on
            // does not reshuffle the others.
            let (prnu, dsnu) = (pixel::normal(&mut fixed), pixel::normal(&mut fixed));
            mean *= (1.0 + noise.prnu * prnu).max(0.0);
            mean += dark_e;
            let mut e = if noise.shot {
                pixel::poisson(&mut temporal, mean)
            } else {
                mean
            };
            e = e.min(config.full_well_e) - dark_e;
            if noise.read_e > 0.0 {
                e += noise.read_e * pixel::normal(&mut temporal);
            }
            e += noise.dsnu_e * dsnu + row_offsets[y] + column_offsets[x];
            raw[i] = pixel::adc(e, gain, black, white);
        }
    }
    let noise_profile = config.noise_profile(exposure_s)?;
    let defects = inject_defects(&mut raw, width, height, config, black, white);
    let raw = RawImage::new(
        width,
        height,
        config.pattern,
        config.adc_bits,
        [black; 4],
        white,
        raw,
    )?;
    Ok(Capture {
        raw,
        truth_camera,
        exposure_s,
        units_per_radiance,
        defects,
        shading,
        noise_profile,
    })
}

/// The optical low-pass filter ([`SensorConfig::olpf`]) on interleaved RGB (`3 * width *
/// height` values, linear): `[1 2 1] / 4` along rows, then along columns, reflect-101 at the
/// edges (a side of one pixel is left as it is along that axis). Linear and the same for each
/// channel, so it commutes with any colour matrix: the demo's truth in linear sRGB takes it
/// as the raw's camera RGB does.
pub fn olpf(rgb: &[f32], width: usize, height: usize) -> Vec<f32> {
    use isp_core::demosaic::reflect;
    let pass = |src: &[f32], step: usize, n: usize| -> Vec<f32> {
        let mut out = vec![0.0f32; src.len()];
        for (i, o) in out.iter_mut().enumerate() {
            let p = i / 3;
            let k = (p / step) % n; // position along the axis
            let base = p - k * step;
            let at = |j: isize| src[3 * (base + reflect(j, n) * step) + i % 3];
            let k = k as isize;
            *o = 0.25 * at(k - 1) + 0.5 * at(k) + 0.25 * at(k + 1);
        }
        out
    };
    let rows = pass(rgb, 1, width);
    pass(&rows, width, height)
}

/// The exposure time that puts the 99th percentile of the brightest channel (after shading)
/// at 80 % of white: 80 % of the full well times `base_iso / iso` (at most the full well).
fn auto_exposure(
    camera_rgb: &[f32],
    width: usize,
    shading: &Shading,
    f_number: f64,
    sensitivity: f64,
    config: &SensorConfig,
) -> Result<f64> {
    let mut peaks: Vec<f64> = camera_rgb
        .chunks_exact(3)
        .enumerate()
        .map(|(i, rgb)| {
            let (x, y) = ((i % width) as f64, (i / width) as f64);
            (0..3)
                .map(|c| rgb[c].max(0.0) as f64 * shading.factor(x, y, c))
                .fold(0.0, f64::max)
        })
        .collect();
    let k = (peaks.len() as f64 * 0.99) as usize;
    let k = k.min(peaks.len() - 1);
    let (_, p99, _) = peaks.select_nth_unstable_by(k, |a, b| a.total_cmp(b));
    let per_second = pixel::signal_electrons(*p99, f_number, 1.0, sensitivity);
    if !(per_second.is_finite() && per_second > 0.0) {
        return Err(Error::Sensor {
            problem: "the frame is black, so automatic exposure has nothing to meter; give an exposure time",
        });
    }
    let target_e = 0.8 * config.full_well_e * (config.base_iso / config.iso).min(1.0);
    Ok(target_e / per_second)
}

fn inject_defects(
    raw: &mut [u16],
    width: usize,
    height: usize,
    config: &SensorConfig,
    black: u16,
    white: u16,
) -> Vec<(usize, usize, DefectKind)> {
    let pixels = (width * height) as f64;
    let d = config.defects;
    let mut rng = Rng::new(config.seed, 0xdef_ec75);
    let mut out = Vec::new();
    let stuck = black + (white - black) / 3;
    for (per_million, kind, value) in [
        (d.hot_per_million, DefectKind::Hot, white),
        (d.dead_per_million, DefectKind::Dead, black),
        (d.stuck_per_million, DefectKind::Stuck, stuck),
    ] {
        let count = (per_million * pixels / 1e6).round() as usize;
        for _ in 0..count {
            let x = (pixel::uniform(&mut rng) * width as f64) as usize;
            let y = (pixel::uniform(&mut rng) * height as f64) as usize;
            let (x, y) = (x.min(width - 1), y.min(height - 1));
            if out.iter().any(|&(dx, dy, _)| (dx, dy) == (x, y)) {
                continue;
            }
            raw[y * width + x] = value;
            out.push((x, y, kind));
        }
    }
    out.sort_by_key(|&(x, y, _)| (y, x));
    out
}

#[cfg(test)]
mod tests {
    /// The low-pass filter keeps a flat field and the mean, takes out a pattern at the
    /// Nyquist frequency along either axis (alternate columns, alternate rows) entirely, and
    /// keeps each channel apart.
    #[test]
    fn olpf_removes_the_nyquist_frequency_and_keeps_flat_fields() {
        use super::olpf;
        let (w, h) = (6, 4);
        let flat = vec![0.3f32; 3 * w * h];
        assert!(olpf(&flat, w, h).iter().all(|v| (v - 0.3).abs() < 1e-6));
        for by_column in [true, false] {
            let stripes: Vec<f32> = (0..3 * w * h)
                .map(|i| {
                    let (x, y, c) = ((i / 3) % w, (i / 3) / w, i % 3);
                    let on = if by_column { x % 2 } else { y % 2 } == 1;
                    if on {
                        [1.0, 0.5, 0.0][c]
                    } else {
                        0.0
                    }
                })
                .collect();
            let out = olpf(&stripes, w, h);
            // Away from the frame's edges the stripes become their mean, per channel.
            for y in 1..h - 1 {
                for x in 1..w - 1 {
                    for c in 0..3 {
                        let v = out[3 * (y * w + x) + c];
                        assert!((v - [0.5, 0.25, 0.0][c]).abs() < 1e-6, "{x} {y} {c}: {v}");
                    }
                }
            }
        }
        // A single pixel is left as it is; two (reflect-101: each is the other's neighbour on
        // both sides) become their mean along that axis only.
        assert_eq!(olpf(&[0.1, 0.2, 0.3], 1, 1), vec![0.1, 0.2, 0.3]);
        let pair = [0.1f32, 0.2, 0.3, 0.4, 0.5, 0.6];
        for (w, h) in [(1, 2), (2, 1)] {
            let out = olpf(&pair, w, h);
            for (v, mean) in out.iter().zip([0.25, 0.35, 0.45, 0.25, 0.35, 0.45]) {
                assert!((v - mean).abs() < 1e-6, "{w}x{h}: {out:?}");
            }
        }
    }

    use super::*;
    use isp_core::CfaColour;

    #[test]
    fn poisson_mean_and_variance() {
        for mean in [0.5, 4.0, 30.0, 1000.0] {
            let mut rng = Rng::new(7, 1);
            let n = 200_000;
            let xs: Vec<f64> = (0..n).map(|_| pixel::poisson(&mut rng, mean)).collect();
            let m = xs.iter().sum::<f64>() / n as f64;
            let v = xs.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (n - 1) as f64;
            assert!((m / mean - 1.0).abs() < 0.01, "mean {mean}: {m}");
            assert!((v / mean - 1.0).abs() < 0.02, "mean {mean}: variance {v}");
            assert!(xs.iter().all(|x| *x >= 0.0 && x.fract() == 0.0));
        }
        let mut rng = Rng::new(1, 1);
        assert_eq!(pixel::poisson(&mut rng, f64::NAN), 0.0);
        assert_eq!(pixel::poisson(&mut rng, -1.0), 0.0);
    }

    #[test]
    fn ln_factorial_is_continuous_at_the_switch() {
        let exact: f64 = (2..=20).map(|i| (i as f64).ln()).sum();
        assert!((pixel::ln_factorial(20.0) - exact).abs() < 1e-10);
    }

    #[test]
    fn cameras_are_normalised_to_green() {
        for name in camera_names() {
            let r = Response::named(name).unwrap();
            let g = r.of_bands(&[1.0; BANDS])[1];
            assert!((g - 1.0).abs() < 1e-5, "{name}: {g}");
        }
        assert!(Response::named("nikon")
            .unwrap_err()
            .to_string()
            .contains("nikon-5100"));
    }

    /// The profile the sensor states matches the temporal variance measured on flat frames
    /// (half the variance of the difference of two frames of one sensor, which cancels PRNU and
    /// DSNU as a photon-transfer measurement does) within 10 %, from a dark frame to near
    /// white, at ISO 100 and 1600, short and long (dark-current) exposures, with every noise
    /// source on; the black clamp leaves a dark frame at black.
    #[test]
    fn noise_profile_matches_the_variance_of_flat_frames() {
        let lens = LensGeometry {
            f_number: 2.0,
            focal_length_mm: 35.0,
            sensor_mm: [36.0, 24.0],
        };
        let (w, h) = (128, 128);
        // A long exposure collects 20 dark electrons, whose shot noise outweighs read noise.
        for (iso, exposure_s) in [(100.0, 0.01), (1600.0, 0.01), (100.0, 4.0), (1600.0, 4.0)] {
            let mut config = SensorConfig::realistic();
            config.shading = ShadingConfig::default();
            config.iso = iso;
            config.exposure_s = Some(exposure_s);
            let profile = config.noise_profile(exposure_s).unwrap();
            let range = f64::from(config.white_level() - config.black());
            let e_per_radiance = pixel::signal_electrons(
                1.0,
                lens.f_number,
                exposure_s,
                config.sensitivity_e_per_lux_s * config.qe_scale,
            );
            for x in [0.0, 0.01, 0.05, 0.2, 0.5, 0.8] {
                let electrons = x * range / config.dn_per_electron();
                let radiance = (electrons / e_per_radiance) as f32;
                let mut frame = |frame_seed| {
                    config.frame_seed = frame_seed;
                    capture(&vec![radiance; w * h * 3], w, h, lens, &config).unwrap()
                };
                let (a, b) = (frame(11), frame(12));
                let defects: Vec<usize> = a.defects.iter().map(|d| d.1 * w + d.0).collect();
                let pairs: Vec<(f64, f64)> = (0..w * h)
                    .filter(|i| !defects.contains(i))
                    .map(|i| {
                        let black = f64::from(config.black());
                        let (p, q) = (a.raw.samples[i], b.raw.samples[i]);
                        (
                            (f64::from(p) - black) / range,
                            (f64::from(q) - black) / range,
                        )
                    })
                    .collect();
                let n = pairs.len() as f64;
                let mean = pairs.iter().map(|(p, q)| p + q).sum::<f64>() / (2.0 * n);
                if x == 0.0 {
                    assert!(mean.abs() < 0.2 / range, "dark frame mean {mean}");
                }
                let d_mean = pairs.iter().map(|(p, q)| p - q).sum::<f64>() / n;
                let measured = pairs
                    .iter()
                    .map(|(p, q)| (p - q - d_mean).powi(2))
                    .sum::<f64>()
                    / (2.0 * (n - 1.0));
                let stated = f64::from(profile.variance(CfaColour::Green, mean as f32));
                assert!(
                    (measured / stated - 1.0).abs() < 0.10,
                    "ISO {iso}, {exposure_s} s, x {x} (measured mean {mean:.4}): variance {measured:.3e}, profile {stated:.3e}"
                );
            }
        }
        // Without shot noise the profile has no signal term.
        let mut quiet = SensorConfig::realistic();
        quiet.noise.shot = false;
        assert_eq!(quiet.noise_profile(1.0).unwrap().scale(), [0.0; 3]);
    }

    #[test]
    fn correction_grid_undoes_shading() {
        let mut config = SensorConfig::realistic();
        config.noise = NoiseConfig::default();
        config.defects = DefectConfig::default();
        let lens = LensGeometry {
            f_number: 2.0,
            focal_length_mm: 35.0,
            sensor_mm: [36.0, 24.0],
        };
        let c = capture(&[1.0; 60 * 40 * 3], 60, 40, lens, &config).unwrap();
        let grid = c.shading.correction_grid(2, 2, CfaPattern::Rggb);
        // The corner R gain undoes the corner R loss.
        let loss = c.shading.factor(0.0, 0.0, 0);
        assert!(loss < 0.7, "{loss}");
        assert!((grid[0] as f64 / 4096.0 * loss - 1.0).abs() < 0.02);
    }
}

//! Optical media: air, a constant index, a model glass from its `nd` and `Vd`, or Sellmeier
//! coefficients (the catalogue's glasses, [`super::catalogue`]). Indices are relative to air
//! and wavelengths in air, as glass catalogues give them.

use crate::real::{finite, positive};
use crate::{OpticsError, Real, Result};

/// The Fraunhofer d line (helium), nm: where `nd` is given.
pub const LAMBDA_D_NM: f64 = 587.5618;
/// The Fraunhofer F line (hydrogen), nm.
pub const LAMBDA_F_NM: f64 = 486.1327;
/// The Fraunhofer C line (hydrogen), nm.
pub const LAMBDA_C_NM: f64 = 656.2725;

/// The wavelengths a medium is evaluated at, nm: the near ultraviolet to the short-wave
/// infrared, where the catalogue's Sellmeier fits hold.
pub const WAVELENGTH_RANGE_NM: [f64; 2] = [300.0, 2500.0];

/// A medium between two surfaces (or before the first, after the last).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Medium<T> {
    /// Air: index 1 at every wavelength (the reference the glasses' indices are given against).
    Air,
    /// One index at every wavelength (no dispersion), as pbrt's lens files give it.
    Constant {
        /// The index, at least 1.
        n: T,
    },
    /// A model glass: index `nd` at the d line and Abbe number `Vd = (nd - 1) / (nF - nC)`,
    /// dispersing as the two-term Cauchy formula `n = A + B / l^2` through those two figures.
    /// A stand-in where only `nd` and `Vd` are known; partial dispersion is not modelled.
    Model {
        /// Index at the d line (587.56 nm), 1 to 3.
        nd: T,
        /// Abbe number, 10 to 120.
        vd: T,
    },
    /// Sellmeier's formula `n^2 - 1 = sum B_i l^2 / (l^2 - C_i)`, `l` in micrometres.
    Sellmeier {
        /// `B_1..B_3`.
        b: [T; 3],
        /// `C_1..C_3`, square micrometres.
        c_um2: [T; 3],
    },
}

/// A glass of the catalogue: its name and Sellmeier coefficients.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CatalogueGlass {
    /// The maker's name, e.g. `N-BK7`.
    pub name: &'static str,
    /// `B_1..B_3`.
    pub b: [f64; 3],
    /// `C_1..C_3`, square micrometres.
    pub c_um2: [f64; 3],
    /// The wavelengths the fit is given for, nm.
    pub range_nm: [f64; 2],
}

impl CatalogueGlass {
    /// The glass as a [`Medium`].
    pub fn medium<T: Real>(&self) -> Medium<T> {
        Medium::Sellmeier {
            b: self.b.map(T::lit),
            c_um2: self.c_um2.map(T::lit),
        }
    }
}

/// The catalogue glass named `name` (case-insensitive), or an error naming what is accepted.
///
/// ```
/// use optics_core::prescription::glass::{catalogue_glass, Medium};
/// let bk7: Medium<f64> = catalogue_glass("n-bk7").unwrap().medium();
/// // SCHOTT's data sheet: nd = 1.51680.
/// assert!((bk7.index(587.5618).unwrap() - 1.5168).abs() < 1e-5);
/// ```
pub fn catalogue_glass(name: &str) -> Result<&'static CatalogueGlass> {
    super::catalogue::CATALOGUE
        .iter()
        .find(|g| g.name.eq_ignore_ascii_case(name))
        .ok_or(OpticsError::InvalidParameter {
            name: "glass",
            allowed: "a name of the catalogue (optics_core::prescription::catalogue::CATALOGUE)",
        })
}

impl<T: Real> Medium<T> {
    /// Checks the medium's parameters.
    pub fn validate(&self) -> Result<()> {
        match *self {
            Medium::Air => Ok(()),
            Medium::Constant { n } => {
                if n.is_finite() && n >= T::one() {
                    Ok(())
                } else {
                    Err(OpticsError::InvalidParameter {
                        name: "n",
                        allowed: "finite and >= 1",
                    })
                }
            }
            Medium::Model { nd, vd } => {
                if !(nd.is_finite() && nd >= T::one() && nd <= T::lit(3.0)) {
                    return Err(OpticsError::InvalidParameter {
                        name: "nd",
                        allowed: "1 to 3",
                    });
                }
                if !(vd >= T::lit(10.0) && vd <= T::lit(120.0)) {
                    return Err(OpticsError::InvalidParameter {
                        name: "vd",
                        allowed: "10 to 120",
                    });
                }
                Ok(())
            }
            Medium::Sellmeier { b, c_um2 } => {
                for v in b {
                    finite(v, "sellmeier b")?;
                }
                for v in c_um2 {
                    finite(v, "sellmeier c")?;
                }
                Ok(())
            }
        }
    }

    /// The index at `wavelength_nm` (in air, 300 to 2500 nm).
    ///
    /// ```
    /// use optics_core::prescription::glass::Medium;
    /// let g = Medium::Model { nd: 1.6_f64, vd: 40.0 };
    /// let (nf, nd, nc) = (g.index(486.1327).unwrap(), g.index(587.5618).unwrap(), g.index(656.2725).unwrap());
    /// assert!((nd - 1.6).abs() < 1e-12 && ((nd - 1.0) / (nf - nc) - 40.0).abs() < 1e-9);
    /// ```
    pub fn index(&self, wavelength_nm: T) -> Result<T> {
        positive(wavelength_nm, "wavelength_nm")?;
        if wavelength_nm < T::lit(WAVELENGTH_RANGE_NM[0])
            || wavelength_nm > T::lit(WAVELENGTH_RANGE_NM[1])
        {
            return Err(OpticsError::InvalidParameter {
                name: "wavelength_nm",
                allowed: "300 to 2500",
            });
        }
        self.validate()?;
        let n = match *self {
            Medium::Air => T::one(),
            Medium::Constant { n } => n,
            Medium::Model { nd, vd } => {
                let inv2 = |l: f64| T::lit(1e6 / (l * l));
                let b = (nd - T::one()) / (vd * (inv2(LAMBDA_F_NM) - inv2(LAMBDA_C_NM)));
                let l = wavelength_nm / T::lit(1000.0);
                let a = nd - b * inv2(LAMBDA_D_NM);
                a + b / (l * l)
            }
            Medium::Sellmeier { b, c_um2 } => {
                let l2 = (wavelength_nm / T::lit(1000.0)) * (wavelength_nm / T::lit(1000.0));
                let mut n2 = T::one();
                for k in 0..3 {
                    n2 = n2 + b[k] * l2 / (l2 - c_um2[k]);
                }
                if !(n2.is_finite() && n2 > T::zero()) {
                    return Err(OpticsError::InvalidParameter {
                        name: "wavelength_nm",
                        allowed: "away from the Sellmeier formula's poles (an index > 0)",
                    });
                }
                n2.sqrt()
            }
        };
        if n.is_finite() && n > T::zero() {
            Ok(n)
        } else {
            Err(OpticsError::Overflow)
        }
    }

    /// `nd` and the Abbe number `Vd` of this medium (Air: 1 and infinity is refused: `None`).
    pub fn nd_vd(&self) -> Result<Option<(T, T)>> {
        let nd = self.index(T::lit(LAMBDA_D_NM))?;
        let dn = self.index(T::lit(LAMBDA_F_NM))? - self.index(T::lit(LAMBDA_C_NM))?;
        Ok((dn != T::zero()).then(|| (nd, (nd - T::one()) / dn)))
    }
}

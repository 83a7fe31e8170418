use core::fmt;

/// Everything optics-core can refuse, each with what went wrong and what would be accepted.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OpticsError {
    /// A parameter is NaN, infinite where it may not be, or outside its allowed range.
    InvalidParameter {
        /// The parameter's name, as in the function's signature.
        name: &'static str,
        /// The allowed range, in words (e.g. "finite and > 0").
        allowed: &'static str,
    },
    /// The subject is exactly at the focal length: its image is at infinity.
    SubjectAtFocalLength,
    /// The subject is closer than the focal length: the image is virtual, no sensor can focus it.
    SubjectInsideFocalLength,
    /// The lens has zero power (afocal): it has no focal length.
    ZeroPower,
    /// The ray misses the surface or the aperture it was aimed at.
    RayMissesSurface,
    /// A caller-provided buffer is too small.
    BufferTooSmall {
        /// Elements needed.
        needed: usize,
        /// Elements provided.
        provided: usize,
    },
    /// A bitmap aperture mask has no open (non-zero) pixel.
    EmptyMask,
    /// An iterative inverse did not reach its tolerance within its iteration limit.
    DidNotConverge,
    /// The result does not fit the number type (float overflow or fixed-point range).
    Overflow,
    /// A lens prescription's surface cannot be used as given.
    BadSurface {
        /// The surface's index, 0 at the object side.
        surface: usize,
        /// What is wrong with it, in words.
        problem: &'static str,
    },
    /// A lens prescription as a whole cannot be used (no surfaces, no stop, two stops).
    BadPrescription {
        /// What is wrong, in words.
        problem: &'static str,
    },
    /// A pupil is at infinity (the lens is telecentric on that side): it has no position.
    PupilAtInfinity,
}

impl fmt::Display for OpticsError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::InvalidParameter { name, allowed } => {
                write!(f, "invalid {name}: must be {allowed}")
            }
            Self::SubjectAtFocalLength => {
                f.write_str("subject at the focal length: the image is at infinity")
            }
            Self::SubjectInsideFocalLength => f.write_str(
                "subject closer than the focal length: the image is virtual and cannot be focused",
            ),
            Self::ZeroPower => f.write_str("the lens has zero power: no focal length"),
            Self::RayMissesSurface => f.write_str("the ray misses the surface"),
            Self::BufferTooSmall { needed, provided } => {
                write!(
                    f,
                    "buffer too small: {needed} elements needed, {provided} provided"
                )
            }
            Self::EmptyMask => f.write_str("the aperture mask has no open pixel"),
            Self::DidNotConverge => f.write_str("the iteration did not converge"),
            Self::Overflow => f.write_str("the result is out of the number type's range"),
            Self::BadSurface { surface, problem } => write!(f, "surface {surface}: {problem}"),
            Self::BadPrescription { problem } => write!(f, "lens prescription: {problem}"),
            Self::PupilAtInfinity => {
                f.write_str("the pupil is at infinity (the lens is telecentric on that side)")
            }
        }
    }
}

impl core::error::Error for OpticsError {}

/// The result type of every fallible function in optics-core.
pub type Result<T> = core::result::Result<T, OpticsError>;

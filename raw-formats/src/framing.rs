//! How a developed image is framed: the crop a raw file recommends (DNG's DefaultCrop) and
//! which way is up (TIFF Orientation), applied to an [`Image`] after development, so the CFA
//! phase of the raw is never disturbed.

use crate::error::{FormatError, Result};
use crate::image::Image;

/// A rectangle of pixels: its top-left corner and size.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Crop {
    /// First column.
    pub left: usize,
    /// First row.
    pub top: usize,
    /// Columns.
    pub width: usize,
    /// Rows.
    pub height: usize,
}

impl Crop {
    /// Checks the rectangle is non-empty and inside a `width` x `height` image.
    pub fn check(&self, width: usize, height: usize) -> Result<()> {
        let fits = self.width > 0
            && self.height > 0
            && self
                .left
                .checked_add(self.width)
                .is_some_and(|r| r <= width)
            && self
                .top
                .checked_add(self.height)
                .is_some_and(|b| b <= height);
        if fits {
            Ok(())
        } else {
            Err(FormatError::OutOfRange {
                field: "crop",
                value: format!(
                    "{}x{} at ({}, {})",
                    self.width, self.height, self.left, self.top
                ),
                allowed: format!("a non-empty rectangle inside {width}x{height}"),
            })
        }
    }
}

/// Which way the stored image is turned (TIFF tag 274): where its first row and first column
/// belong when displayed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Orientation {
    /// 1: row 0 at the top, column 0 at the left (as stored).
    #[default]
    Normal,
    /// 2: mirrored left to right.
    MirrorHorizontal,
    /// 3: turned half a turn.
    Rotate180,
    /// 4: mirrored top to bottom.
    MirrorVertical,
    /// 5: rows and columns swapped (mirrored about the main diagonal).
    Transpose,
    /// 6: displayed after a quarter turn clockwise.
    Rotate90,
    /// 7: swapped about the other diagonal.
    Transverse,
    /// 8: displayed after a quarter turn counter-clockwise.
    Rotate270,
}

impl Orientation {
    /// From the TIFF value 1..=8.
    pub fn from_tiff(value: u32) -> Result<Self> {
        Ok(match value {
            1 => Self::Normal,
            2 => Self::MirrorHorizontal,
            3 => Self::Rotate180,
            4 => Self::MirrorVertical,
            5 => Self::Transpose,
            6 => Self::Rotate90,
            7 => Self::Transverse,
            8 => Self::Rotate270,
            v => {
                return Err(FormatError::OutOfRange {
                    field: "Orientation",
                    value: v.to_string(),
                    allowed: "1..=8".into(),
                })
            }
        })
    }

    /// The TIFF value 1..=8.
    pub fn to_tiff(self) -> u16 {
        self as u16 + 1
    }

    /// Whether width and height swap.
    pub fn swaps_axes(self) -> bool {
        self.to_tiff() >= 5
    }

    /// The stored pixel shown at display position (`x`, `y`) of a stored `width` x `height`
    /// image.
    fn source(self, x: usize, y: usize, width: usize, height: usize) -> (usize, usize) {
        match self {
            Self::Normal => (x, y),
            Self::MirrorHorizontal => (width - 1 - x, y),
            Self::Rotate180 => (width - 1 - x, height - 1 - y),
            Self::MirrorVertical => (x, height - 1 - y),
            Self::Transpose => (y, x),
            Self::Rotate90 => (y, height - 1 - x),
            Self::Transverse => (width - 1 - y, height - 1 - x),
            Self::Rotate270 => (width - 1 - y, x),
        }
    }
}

/// The samples inside `crop` of a `width`-wide image of `channels` samples per pixel, row by
/// row (for any sample type: the Python package frames `u8`, `u16` and `f32` output alike).
pub fn crop_samples<T: Copy>(
    data: &[T],
    width: usize,
    channels: usize,
    crop: Crop,
) -> Result<Vec<T>> {
    let height = data.len() / (width * channels).max(1);
    crop.check(width, height)?;
    let c = channels;
    let mut out = Vec::with_capacity(crop.width * crop.height * c);
    for row in data
        .chunks_exact(width * c)
        .skip(crop.top)
        .take(crop.height)
    {
        out.extend_from_slice(&row[crop.left * c..(crop.left + crop.width) * c]);
    }
    Ok(out)
}

/// The samples of a stored `width` x `height` image of `channels` samples per pixel as
/// displayed: turned or mirrored as `orientation` says (width and height swap where
/// [`Orientation::swaps_axes`]).
pub fn orient_samples<T: Copy>(
    data: &[T],
    width: usize,
    height: usize,
    channels: usize,
    orientation: Orientation,
) -> Vec<T> {
    if orientation == Orientation::Normal {
        return data.to_vec();
    }
    let (w, h, c) = (width, height, channels);
    let (out_w, out_h) = if orientation.swaps_axes() {
        (h, w)
    } else {
        (w, h)
    };
    let mut out = Vec::with_capacity(data.len());
    for y in 0..out_h {
        for x in 0..out_w {
            let (sx, sy) = orientation.source(x, y, w, h);
            let at = (sy * w + sx) * c;
            out.extend_from_slice(&data[at..at + c]);
        }
    }
    out
}

impl Image {
    /// The pixels inside `crop`.
    pub fn cropped(&self, crop: Crop) -> Result<Image> {
        Ok(Image {
            width: crop.width,
            height: crop.height,
            data: crop_samples(&self.data, self.width, self.channels, crop)?,
            ..*self
        })
    }

    /// The image as displayed: turned or mirrored as `orientation` says.
    pub fn oriented(&self, orientation: Orientation) -> Image {
        let (out_w, out_h) = if orientation.swaps_axes() {
            (self.height, self.width)
        } else {
            (self.width, self.height)
        };
        Image {
            width: out_w,
            height: out_h,
            data: orient_samples(
                &self.data,
                self.width,
                self.height,
                self.channels,
                orientation,
            ),
            ..*self
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(width: usize, height: usize) -> Image {
        Image {
            width,
            height,
            channels: 1,
            bits: 8,
            data: (0..(width * height) as u16).collect(),
        }
    }

    #[test]
    fn orientations_match_their_tiff_meaning() {
        // Stored 3 x 2:  0 1 2 / 3 4 5.
        let stored = image(3, 2);
        let shown = |o: u32| stored.oriented(Orientation::from_tiff(o).unwrap()).data;
        assert_eq!(shown(1), [0, 1, 2, 3, 4, 5]);
        assert_eq!(shown(2), [2, 1, 0, 5, 4, 3]);
        assert_eq!(shown(3), [5, 4, 3, 2, 1, 0]);
        assert_eq!(shown(4), [3, 4, 5, 0, 1, 2]);
        // Displayed 2 wide, 3 tall from here on.
        assert_eq!(shown(5), [0, 3, 1, 4, 2, 5]);
        // 6: a quarter turn clockwise brings row 0 to the right-hand column.
        assert_eq!(shown(6), [3, 0, 4, 1, 5, 2]);
        assert_eq!(shown(7), [5, 2, 4, 1, 3, 0]);
        // 8: a quarter turn counter-clockwise brings row 0 to the left-hand column.
        assert_eq!(shown(8), [2, 5, 1, 4, 0, 3]);
        for o in 1..=8 {
            let o = Orientation::from_tiff(o).unwrap();
            assert_eq!(Orientation::from_tiff(o.to_tiff().into()).unwrap(), o);
            let out = stored.oriented(o);
            assert_eq!((out.width, out.height).0 * out.height, 6);
            assert_eq!(out.width, if o.swaps_axes() { 2 } else { 3 });
        }
        assert!(Orientation::from_tiff(0).is_err());
        assert!(Orientation::from_tiff(9).is_err());
    }

    #[test]
    fn crops_inside_the_image_only() {
        let stored = image(4, 3);
        let crop = Crop {
            left: 1,
            top: 1,
            width: 2,
            height: 2,
        };
        assert_eq!(stored.cropped(crop).unwrap().data, [5, 6, 9, 10]);
        for bad in [
            (3, 0, 2, 1),
            (0, 0, 0, 1),
            (0, 2, 1, 2),
            (usize::MAX, 0, 2, 1),
        ] {
            let crop = Crop {
                left: bad.0,
                top: bad.1,
                width: bad.2,
                height: bad.3,
            };
            assert!(stored.cropped(crop).is_err(), "{bad:?}");
        }
    }
}

//! The TIFF container under a DNG: byte order, IFDs and their entries' values, every offset
//! checked against the file.

use super::tags::*;
use crate::error::{FormatError, Result};

pub(super) fn type_size(t: u16) -> Option<usize> {
    match t {
        1 | 2 | 6 | 7 => Some(1),
        3 | 8 => Some(2),
        4 | 9 | 11 | 13 => Some(4),
        5 | 10 | 12 => Some(8),
        _ => None,
    }
}

/// A parsed IFD: entries as (tag, type, count, value-or-offset field position).
#[derive(Debug, Clone)]
pub(super) struct Ifd {
    pub(super) entries: Vec<(u16, u16, u32, usize)>,
}

impl Ifd {
    pub(super) fn get(&self, tag: u16) -> Option<(u16, u32, usize)> {
        self.entries
            .iter()
            .find(|e| e.0 == tag)
            .map(|&(_, t, c, p)| (t, c, p))
    }
}

pub(super) struct Tiff<'a> {
    pub(super) data: &'a [u8],
    pub(super) little: bool,
}

impl<'a> Tiff<'a> {
    pub(super) fn new(data: &'a [u8]) -> Result<Self> {
        let little = match data.get(..4) {
            Some(b"II*\0") => true,
            Some(b"MM\0*") => false,
            _ => {
                return Err(FormatError::NotFormat {
                    format: "TIFF/DNG",
                    reason: "bad header",
                })
            }
        };
        Ok(Self { data, little })
    }

    pub(super) fn bytes(&self, at: usize, n: usize) -> Result<&'a [u8]> {
        at.checked_add(n)
            .and_then(|end| self.data.get(at..end))
            .ok_or(FormatError::Truncated { offset: at, len: n })
    }

    pub(super) fn array<const N: usize>(&self, at: usize) -> Result<[u8; N]> {
        let mut b = [0u8; N];
        b.copy_from_slice(self.bytes(at, N)?);
        Ok(b)
    }

    pub(super) fn u16_at(&self, at: usize) -> Result<u16> {
        let b: [u8; 2] = self.array(at)?;
        Ok(if self.little {
            u16::from_le_bytes(b)
        } else {
            u16::from_be_bytes(b)
        })
    }

    pub(super) fn u32_at(&self, at: usize) -> Result<u32> {
        let b: [u8; 4] = self.array(at)?;
        Ok(if self.little {
            u32::from_le_bytes(b)
        } else {
            u32::from_be_bytes(b)
        })
    }

    pub(super) fn ifd(&self, at: usize) -> Result<Ifd> {
        let n = self.u16_at(at)? as usize;
        let mut entries = Vec::with_capacity(n);
        for i in 0..n {
            let p = at + 2 + 12 * i;
            entries.push((
                self.u16_at(p)?,
                self.u16_at(p + 2)?,
                self.u32_at(p + 4)?,
                p + 8,
            ));
        }
        Ok(Ifd { entries })
    }

    /// Where an entry's values start.
    pub(super) fn value_offset(
        &self,
        kind: u16,
        count: u32,
        field: usize,
    ) -> Result<(usize, usize)> {
        let size = type_size(kind).ok_or(FormatError::FieldType { field_type: kind })?;
        let len = size
            .checked_mul(count as usize)
            .ok_or(FormatError::FieldTooLong { count })?;
        let at = if len <= 4 {
            field
        } else {
            self.u32_at(field)? as usize
        };
        self.bytes(at, len)?;
        Ok((at, size))
    }

    /// An entry's values as numbers (integers; rationals as numerator/denominator).
    pub(super) fn numbers(&self, entry: (u16, u32, usize)) -> Result<Vec<f64>> {
        let (kind, count, field) = entry;
        if count > 1 << 24 {
            return Err(FormatError::FieldTooLong { count });
        }
        let (at, size) = self.value_offset(kind, count, field)?;
        (0..count as usize)
            .map(|i| {
                let p = at + i * size;
                Ok(match kind {
                    BYTE | 7 => self.data[p] as f64,
                    6 => self.data[p] as i8 as f64,
                    SHORT => self.u16_at(p)? as f64,
                    8 => self.u16_at(p)? as i16 as f64,
                    LONG | 13 => self.u32_at(p)? as f64,
                    9 => self.u32_at(p)? as i32 as f64,
                    RATIONAL => self.u32_at(p)? as f64 / self.u32_at(p + 4)? as f64,
                    SRATIONAL => self.u32_at(p)? as i32 as f64 / self.u32_at(p + 4)? as i32 as f64,
                    11 => f32::from_bits(self.u32_at(p)?) as f64,
                    DOUBLE => {
                        let b: [u8; 8] = self.array(p)?;
                        if self.little {
                            f64::from_le_bytes(b)
                        } else {
                            f64::from_be_bytes(b)
                        }
                    }
                    _ => return Err(FormatError::FieldType { field_type: kind }),
                })
            })
            .collect()
    }

    pub(super) fn values(&self, entry: (u16, u32, usize)) -> Result<Vec<u32>> {
        Ok(self
            .numbers(entry)?
            .into_iter()
            .map(|v| v.clamp(0.0, u32::MAX as f64) as u32)
            .collect())
    }

    pub(super) fn one(&self, ifd: &Ifd, tag: u16, name: &'static str) -> Result<u32> {
        let missing = FormatError::Missing {
            field: name,
            tag: Some(tag),
        };
        let entry = ifd.get(tag).ok_or(missing)?;
        self.values(entry)?
            .first()
            .copied()
            .ok_or(FormatError::Missing {
                field: name,
                tag: Some(tag),
            })
    }

    /// The entry `tag`, which must be present.
    pub(super) fn required(ifd: &Ifd, tag: u16, name: &'static str) -> Result<(u16, u32, usize)> {
        ifd.get(tag).ok_or(FormatError::Missing {
            field: name,
            tag: Some(tag),
        })
    }

    /// An entry's bytes as stored (for BYTE and UNDEFINED values such as opcode lists).
    pub(super) fn raw_bytes(&self, entry: (u16, u32, usize)) -> Result<&'a [u8]> {
        let (kind, count, field) = entry;
        let (at, size) = self.value_offset(kind, count, field)?;
        self.bytes(at, size * count as usize)
    }

    pub(super) fn text(&self, ifd: &Ifd, tag: u16) -> Option<String> {
        let (kind, count, field) = ifd.get(tag)?;
        if kind != ASCII {
            return None;
        }
        let (at, _) = self.value_offset(kind, count, field).ok()?;
        let b = &self.data[at..at + count as usize];
        let end = b.iter().position(|c| *c == 0).unwrap_or(b.len());
        Some(String::from_utf8_lossy(&b[..end]).into_owned())
    }

    pub(super) fn is_raw_image(&self, ifd: &Ifd) -> Result<bool> {
        let subfile = ifd
            .get(NEW_SUBFILE_TYPE)
            .map(|e| self.values(e))
            .transpose()?
            .and_then(|v| v.first().copied())
            .unwrap_or(0);
        let photometric = ifd
            .get(PHOTOMETRIC)
            .map(|e| self.values(e))
            .transpose()?
            .and_then(|v| v.first().copied());
        Ok(subfile == 0 && matches!(photometric, Some(CFA_PHOTOMETRIC | LINEAR_RAW_PHOTOMETRIC)))
    }
}

//! Reading `.npy` files (NumPy's array format): the header (type, order, shape) and
//! float64 arrays in C order, the whole rows a file holds. The frames' writer
//! (`output::npy`) and the grid bodies (`bodies::grid_sdf`) read through it.

use crate::error::{Error, Result};
use std::fs::File;
use std::io::{Read, Seek, SeekFrom};
use std::path::Path;

/// The npy magic string.
pub(crate) const MAGIC: &[u8; 6] = b"\x93NUMPY";
/// Preamble of a version 1.0 file: magic, two version bytes, u16 header length.
pub(crate) const PREAMBLE: usize = 10;

/// An I/O error on `path`.
fn io_error(path: &Path, source: std::io::Error) -> Error {
    Error::Io {
        path: path.display().to_string(),
        source,
    }
}

/// A file that is not what it should be.
pub(crate) fn bad_file(path: &Path, message: impl Into<String>) -> Error {
    io_error(
        path,
        std::io::Error::new(std::io::ErrorKind::InvalidData, message.into()),
    )
}

/// Read a little-endian float64 `.npy` file (as `output::npy` and `output::nodes` write):
/// its shape and its values in C order. Only the whole rows its header counts are read
/// (a run stopped mid-frame leaves the next row partly written).
pub fn read_f64(path: &Path) -> Result<(Vec<u64>, Vec<f64>)> {
    let mut file = File::open(path).map_err(|e| io_error(path, e))?;
    let header = read_header(&mut file, path)?;
    if header.descr != "<f8" || header.fortran_order {
        return Err(bad_file(
            path,
            format!(
                "expected little-endian float64 in C order, the header says '{}'{}",
                header.descr,
                if header.fortran_order {
                    " in Fortran order"
                } else {
                    ""
                }
            ),
        ));
    }
    let len = file.metadata().map_err(|e| io_error(path, e))?.len();
    let row: u64 = header.shape.iter().skip(1).product();
    let rows = rows_present(&header, len, 8 * row);
    let mut bytes = vec![0u8; rows * 8 * row as usize];
    file.seek(SeekFrom::Start(header.data_start))
        .and_then(|_| file.read_exact(&mut bytes))
        .map_err(|e| io_error(path, e))?;
    let mut shape = header.shape;
    if let Some(first) = shape.first_mut() {
        *first = rows as u64;
    }
    let values = bytes
        .chunks_exact(8)
        .map(|c| f64::from_le_bytes([c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]]))
        .collect();
    Ok((shape, values))
}

/// A parsed `.npy` header.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct NpyHeader {
    pub(crate) descr: String,
    pub(crate) fortran_order: bool,
    pub(crate) shape: Vec<u64>,
    /// Offset of the data.
    pub(crate) data_start: u64,
}

/// Parse the header of an open `.npy` file.
pub(crate) fn read_header(file: &mut File, path: &Path) -> Result<NpyHeader> {
    let mut pre = [0u8; PREAMBLE];
    file.read_exact(&mut pre)
        .map_err(|_| bad_file(path, "not an .npy file (shorter than its preamble)"))?;
    if &pre[..6] != MAGIC {
        return Err(bad_file(path, "not an .npy file (no \\x93NUMPY magic)"));
    }
    let (len, start) = match pre[6] {
        1 => (u16::from_le_bytes([pre[8], pre[9]]) as usize, PREAMBLE),
        2 | 3 => {
            let mut more = [0u8; 2];
            file.read_exact(&mut more).map_err(|e| io_error(path, e))?;
            (
                u32::from_le_bytes([pre[8], pre[9], more[0], more[1]]) as usize,
                PREAMBLE + 2,
            )
        }
        v => return Err(bad_file(path, format!("unsupported .npy version {v}"))),
    };
    let mut dict = vec![0u8; len];
    file.read_exact(&mut dict)
        .map_err(|_| bad_file(path, "truncated .npy header"))?;
    let dict = String::from_utf8_lossy(&dict);
    let descr = dict_value(&dict, "descr")
        .and_then(|v| v.strip_prefix('\'').and_then(|v| v.split('\'').next()))
        .ok_or_else(|| bad_file(path, "the .npy header has no 'descr'"))?
        .to_string();
    let fortran_order = match dict_value(&dict, "fortran_order") {
        Some(v) if v.starts_with("False") => false,
        Some(v) if v.starts_with("True") => true,
        _ => return Err(bad_file(path, "the .npy header has no 'fortran_order'")),
    };
    let shape = dict_value(&dict, "shape")
        .and_then(|v| v.strip_prefix('('))
        .and_then(|v| v.split(')').next())
        .ok_or_else(|| bad_file(path, "the .npy header has no 'shape'"))?
        .split(',')
        .map(str::trim)
        .filter(|d| !d.is_empty())
        .map(|d| d.parse::<u64>())
        .collect::<std::result::Result<Vec<_>, _>>()
        .map_err(|_| bad_file(path, "the .npy header's 'shape' is not a tuple of integers"))?;
    Ok(NpyHeader {
        descr,
        fortran_order,
        shape,
        data_start: (start + len) as u64,
    })
}

/// The text after `'key':` in a header dict, leading spaces removed.
fn dict_value<'a>(dict: &'a str, key: &str) -> Option<&'a str> {
    let pattern = format!("'{key}':");
    let at = dict.find(&pattern)? + pattern.len();
    Some(dict[at..].trim_start())
}

/// Number of whole rows of `row_bytes` after the header of `header` in a file of `len`
/// bytes, at most the header's count.
pub(crate) fn rows_present(header: &NpyHeader, len: u64, row_bytes: u64) -> usize {
    let whole = len.saturating_sub(header.data_start) / row_bytes.max(1);
    header.shape.first().copied().unwrap_or(0).min(whole) as usize
}

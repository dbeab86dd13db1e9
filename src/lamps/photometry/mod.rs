//! Far-field photometry: the intensity tables luminaire makers publish, read into one
//! [`Goniometric`] type.
//!
//! - [`ies`]: IES LM-63 files (`.ies`; 1986, 1991, 1995, 2002 and 2019 headers).
//! - [`ldt`]: EULUMDAT files (`.ldt`).
//! - [`goniometric`]: the shared table, its symmetries, bilinear lookup and flux integral.
//!
//! No maintained MIT/Apache reader fitted: `eulumdat` is AGPL; `lidrs` (MIT) has not changed
//! since 2022, converts only type C, does not read LM-63-2019 and reports errors without the line
//! or field. These readers are small and check every count, angle and value, naming the file,
//! line and field of the first problem.

pub mod goniometric;
pub mod ies;
pub mod ldt;
#[cfg(test)]
mod tests;

pub use goniometric::{Goniometric, PhotometricType, Symmetry, TableError};
pub use ies::IesFile;
pub use ldt::LdtFile;

use std::path::{Path, PathBuf};

/// Largest number of angles or values a reader accepts in one list (a corrupt count must not
/// allocate gigabytes).
pub(crate) const MAX_LIST_LEN: usize = 100_000;

/// Errors reading IES and EULUMDAT files. Every message starts with the file.
#[derive(Debug, thiserror::Error)]
pub enum PhotometryError {
    /// The file could not be read.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// A field has a value that is not a number, out of range, or inconsistent with others.
    #[error("{}:{line}: {field}: {message}", path.display())]
    Field {
        /// The file.
        path: PathBuf,
        /// 1-based line of the field.
        line: usize,
        /// The field (as the format's specification names it).
        field: String,
        /// What is wrong.
        message: String,
    },
    /// The file ends before a field.
    #[error("{}: the file ends after line {line}, before {field}", path.display())]
    Truncated {
        /// The file.
        path: PathBuf,
        /// The last line read.
        line: usize,
        /// The first missing field.
        field: String,
    },
}

impl PhotometryError {
    pub(crate) fn field(path: &Path, line: usize, field: &str, message: impl Into<String>) -> Self {
        Self::Field { path: path.to_owned(), line, field: field.to_owned(), message: message.into() }
    }
}

/// Reads a text file (Latin-1 bytes that are not UTF-8 are kept as `char`s, as old photometry
/// files are often Windows-1252).
pub(crate) fn read_text(path: &Path) -> Result<String, PhotometryError> {
    let bytes = std::fs::read(path).map_err(|source| PhotometryError::Io { path: path.to_owned(), source })?;
    Ok(match String::from_utf8(bytes) {
        Ok(s) => s,
        Err(e) => e.into_bytes().iter().map(|&b| b as char).collect(),
    })
}

/// Parses one number of a field; `,` as the decimal mark is accepted (EULUMDAT files from
/// German-locale tools). NaN and infinities are errors.
pub(crate) fn parse_number(path: &Path, line: usize, field: &str, token: &str) -> Result<f64, PhotometryError> {
    let t = token.trim();
    let v: f64 = t.replace(',', ".").parse().map_err(|_| PhotometryError::field(path, line, field, format!("'{t}' is not a number")))?;
    if !v.is_finite() {
        return Err(PhotometryError::field(path, line, field, format!("'{t}' is not finite")));
    }
    Ok(v)
}

/// A count field: a whole number in `[min, MAX_LIST_LEN]` (written as `5` or `5.0`).
pub(crate) fn parse_count(path: &Path, line: usize, field: &str, token: &str, min: usize) -> Result<usize, PhotometryError> {
    let v = parse_number(path, line, field, token)?;
    if v.fract() != 0.0 || v < min as f64 || v > MAX_LIST_LEN as f64 {
        return Err(PhotometryError::field(path, line, field, format!("{v} is not a whole number in [{min}, {MAX_LIST_LEN}]")));
    }
    Ok(v as usize)
}

//! Errors of baking and of the texture layout. Every variant names the file
//! (or the position and parameter) and says what was expected.

use matscan_scan::{Param, ScanError};
use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum BakeError {
    /// Reading or writing a bundle file failed.
    #[error(transparent)]
    Scan(#[from] ScanError),
    /// A map that breaks its parameter's rules.
    #[error(transparent)]
    Map(#[from] matscan_scan::estimate_maps::MapError),
    /// The operating system refused a read or write outside the scan crate.
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A file is not what the texture layout says it should be.
    #[error("{path}: {message}")]
    Format { path: PathBuf, message: String },
    /// The mesh has no texture coordinates, so there is no UV space to bake
    /// into.
    #[error(
        "{mesh}: the mesh has no texture coordinates (UVs); baking needs a UV atlas. \
         Unwrap it in Blender (Edit Mode, UV > Smart UV Project), export it with UVs \
         as PLY or OBJ and put it back as the scan's geometry file"
    )]
    NoUvs { mesh: PathBuf },
    /// A texture whose size differs from the others of its set.
    #[error(
        "{param} texture is {found_width}x{found_height} texels, expected \
         {expected_width}x{expected_height} (the size of the set's coverage map)"
    )]
    SizeMismatch {
        param: String,
        expected_width: u32,
        expected_height: u32,
        found_width: u32,
        found_height: u32,
    },
    /// A texture that is not allowed where it was given (basecolor as a
    /// scalar, a scalar as basecolor).
    #[error("{param}: {message}")]
    WrongParam { param: Param, message: String },
    /// Nothing to bake: no position has maps, or the options ask for nothing.
    #[error("{path}: {message}")]
    NothingToBake { path: PathBuf, message: String },
    /// An option out of its range.
    #[error("{what}: {message}")]
    InvalidOption { what: &'static str, message: String },
}

impl BakeError {
    pub(crate) fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        BakeError::Io {
            path: path.into(),
            source,
        }
    }

    pub(crate) fn format(path: impl Into<PathBuf>, message: impl Into<String>) -> Self {
        BakeError::Format {
            path: path.into(),
            message: message.into(),
        }
    }
}

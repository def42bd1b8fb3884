//! Errors of the scene loaders: what went wrong, in which file, and where in it.

use std::fmt;
use std::path::{Path, PathBuf};

/// Where in a file a problem was found.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Location {
    /// 1-based line of a text file.
    Line(u64),
    /// 0-based index of an element (`"vertex"`, `"face"`, …) of a binary file.
    Element(&'static str, u64),
    /// No finer location is known.
    File,
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Line(l) => write!(f, "line {l}"),
            Self::Element(kind, i) => write!(f, "{kind} {i}"),
            Self::File => f.write_str("file"),
        }
    }
}

/// Why a scene file could not be loaded.
#[non_exhaustive]
#[derive(Debug, thiserror::Error)]
pub enum SceneLoadError {
    /// The file could not be read.
    #[error("{}: cannot read: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
    /// The extension is none of `.obj`, `.ply`, `.toml`.
    #[error("{}: unsupported scene format (expected .obj, .ply or .toml)", path.display())]
    UnsupportedFormat {
        /// The file.
        path: PathBuf,
    },
    /// The file is syntactically malformed.
    #[error("{}:{at}: {reason}", path.display())]
    Malformed {
        /// The file.
        path: PathBuf,
        /// Where.
        at: Location,
        /// What is wrong.
        reason: String,
    },
    /// A vertex coordinate is NaN or infinite.
    #[error("{}:{at}: vertex coordinate is NaN or infinite", path.display())]
    NonFinite {
        /// The file.
        path: PathBuf,
        /// Where.
        at: Location,
    },
    /// A face names a vertex that does not exist.
    #[error("{}:{at}: face vertex index {index} out of range (the file has {vertex_count} vertices so far)", path.display())]
    IndexOutOfRange {
        /// The file.
        path: PathBuf,
        /// Where.
        at: Location,
        /// The index as written in the file.
        index: i64,
        /// Vertices available.
        vertex_count: u64,
    },
    /// No triangle with non-zero area remains.
    #[error("{}: mesh is empty ({dropped} zero-area triangles dropped)", path.display())]
    EmptyMesh {
        /// The file.
        path: PathBuf,
        /// Zero-area triangles that were dropped.
        dropped: u64,
    },
    /// `tobj` rejected the file for a reason the pre-scan did not locate.
    #[error("{}: OBJ load failed: {source}", path.display())]
    Obj {
        /// The file.
        path: PathBuf,
        /// The tobj error.
        #[source]
        source: tobj::LoadError,
    },
}

/// Reads a whole file, naming it in the error.
pub(super) fn read_file(path: &Path) -> Result<Vec<u8>, SceneLoadError> {
    std::fs::read(path).map_err(|source| SceneLoadError::Io { path: path.to_path_buf(), source })
}

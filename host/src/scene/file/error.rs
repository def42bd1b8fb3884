//! Why a scene file was rejected, and where: [`Ctx`] turns a table span and a field name into
//! the line the field is written on.

use std::path::{Path, PathBuf};

use crate::scene::error::SceneLoadError;

/// Why a scene file was rejected.
#[derive(Debug, thiserror::Error)]
pub enum SceneFileError {
    /// The file could not be read.
    #[error("{}: cannot read: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// Cause.
        #[source]
        source: std::io::Error,
    },
    /// TOML syntax or a field of the wrong type / unknown field (toml's message has the line,
    /// column and the text).
    #[error("{}: {message}", path.display())]
    Syntax {
        /// The file.
        path: PathBuf,
        /// toml's message.
        message: String,
    },
    /// A field value that is well-typed but invalid.
    #[error("{}:line {line}: {table}: field `{field}`: {reason}", path.display())]
    Field {
        /// The file.
        path: PathBuf,
        /// 1-based line of the table holding the field.
        line: usize,
        /// Which table (`materials.red`, `objects[2]`, …).
        table: String,
        /// The field.
        field: String,
        /// What is wrong.
        reason: String,
    },
    /// A mesh referenced by the file failed to load.
    #[error("{}:line {line}: {table}: mesh: {source}", path.display())]
    Mesh {
        /// The scene file.
        path: PathBuf,
        /// Line of the object.
        line: usize,
        /// Which object.
        table: String,
        /// The loader error.
        #[source]
        source: Box<SceneLoadError>,
    },
}

/// Line (1-based) of byte offset `at` in `text`.
pub(super) fn line_of(text: &str, at: usize) -> usize {
    text.as_bytes().get(..at.min(text.len())).map_or(0, |b| b.iter().filter(|&&c| c == b'\n').count()) + 1
}

pub(super) struct Ctx<'a> {
    pub(super) path: &'a Path,
    pub(super) text: &'a str,
}

impl Ctx<'_> {
    /// An error at `field` of the table spanning `span`: the line of `field = …` inside the
    /// table if it is written there, else the table's first line.
    pub(super) fn field(
        &self,
        span: std::ops::Range<usize>,
        table: impl Into<String>,
        field: &str,
        reason: impl Into<String>,
    ) -> SceneFileError {
        // The table runs from its span to the next table header.
        let body = self.text.get(span.start..).unwrap_or("");
        let mut at = span.start;
        let mut offset = 0;
        for (k, l) in body.split_inclusive('\n').enumerate() {
            let key = l.trim_start();
            if k > 0 && key.starts_with('[') {
                break;
            }
            if key.strip_prefix(field).is_some_and(|r| r.trim_start().starts_with('=')) {
                at = span.start + offset;
                break;
            }
            offset += l.len();
        }
        SceneFileError::Field {
            path: self.path.to_path_buf(),
            line: line_of(self.text, at),
            table: table.into(),
            field: field.to_string(),
            reason: reason.into(),
        }
    }
}

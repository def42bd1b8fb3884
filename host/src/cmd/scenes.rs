//! The bundled scenes (`tests/scenes/`), built into the binary so that the benches run from
//! any folder: [`Bundled::extract`] writes them to a temporary folder (OBJ beside its MTL,
//! as the loaders expect) that is removed when the value is dropped.

use std::path::{Path, PathBuf};

use anyhow::Context;

/// Name and bytes of every bundled scene file the benches use.
pub const FILES: [(&str, &[u8]); 7] = [
    ("bun_zipper_res4.obj", include_bytes!("../../../tests/scenes/bun_zipper_res4.obj")),
    ("stanford-bunny.obj", include_bytes!("../../../tests/scenes/stanford-bunny.obj")),
    ("teapot.obj", include_bytes!("../../../tests/scenes/teapot.obj")),
    ("suzanne.obj", include_bytes!("../../../tests/scenes/suzanne.obj")),
    ("cornell_box.obj", include_bytes!("../../../tests/scenes/cornell_box.obj")),
    ("cornell_box.mtl", include_bytes!("../../../tests/scenes/cornell_box.mtl")),
    ("viray_demo.toml", include_bytes!("../../../tests/scenes/viray_demo.toml")),
];

/// A folder holding the bundled scenes: a temporary copy, or a folder the user named.
#[derive(Debug)]
pub struct Bundled {
    dir: PathBuf,
    temporary: bool,
}

impl Bundled {
    /// `dir` when given (the user's scenes), else a temporary copy of the bundled ones.
    pub fn or_extract(dir: Option<&Path>) -> anyhow::Result<Self> {
        match dir {
            Some(d) => Ok(Self { dir: d.to_path_buf(), temporary: false }),
            None => Self::extract(),
        }
    }

    /// Writes the bundled scenes to a new temporary folder.
    pub fn extract() -> anyhow::Result<Self> {
        let nanos = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.subsec_nanos());
        let dir = std::env::temp_dir().join(format!("gridrt-scenes-{}-{nanos}", std::process::id()));
        std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
        let me = Self { dir, temporary: true };
        for (name, bytes) in FILES {
            let path = me.dir.join(name);
            std::fs::write(&path, bytes).with_context(|| format!("writing {}", path.display()))?;
        }
        Ok(me)
    }

    /// The folder.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// `name` in the folder.
    pub fn join(&self, name: &str) -> PathBuf {
        self.dir.join(name)
    }
}

impl Drop for Bundled {
    fn drop(&mut self) {
        if self.temporary {
            let _ = std::fs::remove_dir_all(&self.dir);
        }
    }
}

//! Output files: checked before any work (not a folder, a format the writer has, a folder
//! that takes a new file) and written through a temporary file beside them, renamed into
//! place, so a failure never leaves an empty or half-written file behind.

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::Context;

/// Checks that `path` (given as `flag`) can be written as a file: not a folder, its folder
/// exists (it is created) and takes a new file, and an existing file there can be written.
pub fn check_file(path: &Path, flag: &str) -> anyhow::Result<()> {
    if path.as_os_str().is_empty() {
        anyhow::bail!("{flag}: an empty path");
    }
    if path.is_dir() {
        anyhow::bail!("{flag} {}: is a folder; give a file name", path.display());
    }
    let dir = folder_of(path);
    if let Some(file) = dir.ancestors().find(|a| a.exists() && !a.is_dir()) {
        anyhow::bail!("{flag} {}: {} is a file, not a folder", path.display(), file.display());
    }
    std::fs::create_dir_all(&dir).with_context(|| format!("{flag} {}: creating its folder", path.display()))?;
    if path.exists() {
        std::fs::OpenOptions::new()
            .append(true)
            .open(path)
            .with_context(|| format!("{flag} {}: cannot be written", path.display()))?;
    }
    let probe = temp_beside(path);
    std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&probe)
        .with_context(|| format!("{flag} {}: its folder does not take new files", path.display()))?;
    let _ = std::fs::remove_file(&probe);
    Ok(())
}

/// Checks that `dir` (given as `flag`) is a folder that takes new files: created when
/// missing, refused when it is a file or cannot be written.
pub fn check_dir(dir: &Path, flag: &str) -> anyhow::Result<()> {
    if dir.as_os_str().is_empty() {
        anyhow::bail!("{flag}: an empty path");
    }
    if let Some(file) = dir.ancestors().find(|a| a.exists() && !a.is_dir()) {
        anyhow::bail!("{flag} {}: {} is a file, not a folder", dir.display(), file.display());
    }
    std::fs::create_dir_all(dir).with_context(|| format!("{flag} {}: creating the folder", dir.display()))?;
    let probe = dir.join(format!(".gridrt-probe.{}.tmp", std::process::id()));
    std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&probe)
        .with_context(|| format!("{flag} {}: the folder does not take new files", dir.display()))?;
    let _ = std::fs::remove_file(&probe);
    Ok(())
}

/// [`check_file`] for an image: also an extension the image writer supports.
pub fn check_image(path: &Path, flag: &str) -> anyhow::Result<image::ImageFormat> {
    if path.is_dir() {
        anyhow::bail!("{flag} {}: is a folder; give a file name", path.display());
    }
    let format = image_format(path, flag)?;
    check_file(path, flag)?;
    Ok(format)
}

/// The image format of `path`'s extension, if this build can write it.
pub fn image_format(path: &Path, flag: &str) -> anyhow::Result<image::ImageFormat> {
    let supported = || {
        image::ImageFormat::all()
            .filter(|f| f.writing_enabled())
            .flat_map(|f| f.extensions_str().first().copied())
            .collect::<Vec<_>>()
            .join(", ")
    };
    match image::ImageFormat::from_path(path) {
        Ok(f) if f.writing_enabled() => Ok(f),
        _ => anyhow::bail!("{flag} {}: cannot write this format (supported: {})", path.display(), supported()),
    }
}

/// The folder `path` is in (`.` for a bare file name).
fn folder_of(path: &Path) -> PathBuf {
    match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// A temporary name beside `path`.
fn temp_beside(path: &Path) -> PathBuf {
    let name = path.file_name().map_or_else(|| "out".into(), |n| n.to_string_lossy().into_owned());
    folder_of(path).join(format!(".{name}.{}.tmp", std::process::id()))
}

/// Writes `path` through `write` on a temporary file beside it, renamed into place when
/// `write` succeeds (removed when it fails).
pub fn write_with(
    path: &Path,
    write: impl FnOnce(&mut std::io::BufWriter<std::fs::File>) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    let tmp = temp_beside(path);
    let result = (|| {
        let file = std::fs::File::create(&tmp).with_context(|| format!("writing {}", path.display()))?;
        let mut w = std::io::BufWriter::new(file);
        write(&mut w)?;
        w.flush().with_context(|| format!("writing {}", path.display()))?;
        drop(w);
        std::fs::rename(&tmp, path).with_context(|| format!("writing {}", path.display()))
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// Writes `bytes` to `path` (through a temporary file).
pub fn write_bytes(path: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    write_with(path, |w| w.write_all(bytes).with_context(|| format!("writing {}", path.display())))
}

/// Writes an RGB image to `path` in the format of its extension (through a temporary file).
pub fn write_rgb(path: &Path, w: u16, h: u16, rgb: Vec<u8>) -> anyhow::Result<()> {
    let format = image_format(path, "output")?;
    let img = image::RgbImage::from_raw(w as u32, h as u32, rgb).context("image buffer has the wrong size")?;
    write_with(path, |out| img.write_to(out, format).with_context(|| format!("writing {}", path.display())))
}

/// An APNG frame delay for `fps` frames a second: whole milliseconds, 1..=65 535.
pub fn apng_delay(fps: f64) -> (u16, u16) {
    let ms = if fps.is_finite() && fps > 0.0 { (1000.0 / fps).round() } else { 1000.0 };
    (ms.clamp(1.0, 65_535.0) as u16, 1000)
}

/// Writes the PNGs `frames` (one size) as one animated PNG at `path`, each frame shown `delay`
/// (numerator, denominator seconds), looping forever (through a temporary file).
pub fn write_apng(path: &Path, frames: &[PathBuf], delay: (u16, u16)) -> anyhow::Result<()> {
    let read = |p: &PathBuf| -> anyhow::Result<image::RgbImage> {
        Ok(image::open(p).with_context(|| format!("reading {}", p.display()))?.to_rgb8())
    };
    let first = read(frames.first().context("no frames to animate")?)?;
    let (w, h) = first.dimensions();
    let n = u32::try_from(frames.len()).context("too many frames")?;
    let err = |e: png::EncodingError| anyhow::anyhow!("writing {}: {e}", path.display());
    write_with(path, |out| {
        let mut enc = png::Encoder::new(out, w, h);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        enc.set_animated(n, 0).map_err(err)?;
        enc.set_frame_delay(delay.0, delay.1).map_err(err)?;
        let mut writer = enc.write_header().map_err(err)?;
        writer.write_image_data(first.as_raw()).map_err(err)?;
        for p in &frames[1..] {
            let img = read(p)?;
            anyhow::ensure!(img.dimensions() == (w, h), "{}: not the size of the first frame", p.display());
            writer.write_image_data(img.as_raw()).map_err(err)?;
        }
        writer.finish().map_err(err)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn folders_unknown_formats_and_impossible_paths_are_refused_and_nothing_is_left() {
        let dir = std::env::temp_dir().join(format!("gridrt-output-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        assert!(check_image(&dir, "--out").unwrap_err().to_string().contains("is a folder"));
        assert!(check_image(&dir.join("x.jpg"), "--out").unwrap_err().to_string().contains("cannot write"));
        let file = dir.join("plain");
        std::fs::write(&file, b"x").unwrap();
        assert!(check_image(&file.join("x.png"), "--out").is_err(), "a path under a file");
        check_image(&dir.join("sub/x.png"), "--out").unwrap();
        write_rgb(&dir.join("sub/x.png"), 1, 1, vec![1, 2, 3]).unwrap();
        assert!(write_rgb(&dir.join("sub/y.png"), 2, 2, vec![1, 2, 3]).is_err());
        let mut left: Vec<_> = std::fs::read_dir(dir.join("sub")).unwrap().map(|e| e.unwrap().file_name()).collect();
        left.sort();
        assert_eq!(left, ["x.png"]);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn apng_delays_are_whole_milliseconds_within_the_field() {
        assert_eq!(apng_delay(25.0), (40, 1000));
        assert_eq!(apng_delay(22.92), (44, 1000));
        assert_eq!(apng_delay(0.001), (65_535, 1000));
        assert_eq!(apng_delay(1e6), (1, 1000));
        assert_eq!(apng_delay(0.0), (1000, 1000));
    }
}

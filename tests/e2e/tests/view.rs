//! The live view (`gridrt render --view`) in a real browser: Debian's headless Chromium loads
//! the page while a simulated stream runs (`--sim --sim-paced`, slow enough to be caught in
//! the act) and the test reads the page's two canvases back from the DOM (`--dump-dom`; the
//! page stores each canvas's PNG data URL in `data-png`). The last complete frame must be, pixel
//! for pixel, the PNG the stream wrote for it; the frame being received must hold exactly the
//! rows that had arrived, equal to that frame's PNG, and nothing below them.
//!
//! A missing `chromium` fails the test unless `GRIDRT_SKIP_TOOLS=chromium` opts out.

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use gridrt_e2e::builds::{gridrt, repo_root};
use gridrt_e2e::tools::{require, Tool};

/// Kills a helper process when the test ends, however it ends.
struct KillOnDrop(Child);

impl Drop for KillOnDrop {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn base64(text: &str) -> Vec<u8> {
    let val = |c: u8| match c {
        b'A'..=b'Z' => c - b'A',
        b'a'..=b'z' => c - b'a' + 26,
        b'0'..=b'9' => c - b'0' + 52,
        b'+' => 62,
        b'/' => 63,
        _ => panic!("not base64: {c}"),
    };
    let digits: Vec<u8> = text.bytes().filter(|&c| c != b'=').map(val).collect();
    let mut out = Vec::new();
    for c in digits.chunks(4) {
        let n = c.iter().enumerate().fold(0u32, |n, (i, &d)| n | u32::from(d) << (18 - 6 * i));
        out.extend(&n.to_be_bytes()[1..c.len()]);
    }
    out
}

/// The value of attribute `name` of the element with `id` in `dom`.
fn attr(dom: &str, id: &str, name: &str) -> String {
    let at = dom.find(&format!("id=\"{id}\"")).unwrap_or_else(|| panic!("no #{id} in the page:\n{dom}"));
    let tag = &dom[dom[..at].rfind('<').unwrap()..];
    let tag = &tag[..tag.find('>').unwrap()];
    let key = format!(" {name}=\"");
    let start = tag.find(&key).unwrap_or_else(|| panic!("#{id} has no {name}: {tag:.300}")) + key.len();
    tag[start..start + tag[start..].find('"').unwrap()].to_string()
}

/// RGBA pixels of a canvas's PNG data URL.
fn canvas(dom: &str, id: &str) -> image::RgbaImage {
    let url = attr(dom, id, "data-png");
    let b64 = url.strip_prefix("data:image/png;base64,").expect("a PNG data URL");
    image::load_from_memory(&base64(b64)).unwrap().to_rgba8()
}

fn wait_for(path: &Path, child: &mut Child) {
    while !path.exists() {
        assert!(child.try_wait().unwrap().is_none(), "gridrt ended before {} was written", path.display());
        std::thread::sleep(Duration::from_millis(50));
    }
    // Renamed into place when complete.
    std::thread::sleep(Duration::from_millis(50));
}

#[test]
fn view_page_shows_the_stream() {
    if !require("view_page_shows_the_stream", Tool::Chromium) {
        return;
    }
    let dir = std::env::temp_dir().join(format!("gridrt-e2e-view-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let out_dir = dir.join("frames");
    let out = out_dir.display().to_string();
    // 64×48 Rle frames of a few kB at 9600 baud (960 B/s): seconds per frame.
    let mut child = KillOnDrop(
        Command::new(gridrt())
            .args(["render", "--sim", "--sim-paced", "--baud", "9600", "--scene", "tests/scenes/bun_zipper_res4.obj"])
            .args(["--width", "64", "--height", "48", "--encoding", "rle", "--frames", "500", "--orbit", "360"])
            .args(["--out-dir", &out, "--view"])
            .current_dir(repo_root())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap(),
    );
    let stderr = child.0.stderr.take().unwrap();
    let mut lines = BufReader::new(stderr).lines();
    let url = loop {
        let line = lines.next().expect("gridrt printed no view URL").unwrap();
        if let Some(u) = line.strip_prefix("view       ") {
            break u.trim().to_string();
        }
    };
    assert!(url.starts_with("http://127.0.0.1:"), "{url}");
    // Keep draining stderr so the stream never blocks on a full pipe.
    std::thread::spawn(move || for _ in lines {});
    wait_for(&out_dir.join("frame-0000.png"), &mut child.0);

    let profile = dir.join("chromium-profile");
    let start = Instant::now();
    let page = Command::new("chromium")
        .args(["--headless", "--no-sandbox", "--disable-gpu", "--no-first-run", "--disable-extensions"])
        .arg(format!("--user-data-dir={}", profile.display()))
        .args(["--dump-dom", &url])
        .output()
        .unwrap();
    assert!(page.status.success(), "chromium failed: {}", String::from_utf8_lossy(&page.stderr));
    let dom = String::from_utf8_lossy(&page.stdout).into_owned();
    eprintln!("chromium took {:.1} s", start.elapsed().as_secs_f64());
    assert!(
        child.0.try_wait().unwrap().is_none() && dom.contains(">streaming<"),
        "the page was loaded during the stream"
    );

    // The last complete frame: the PNG the stream wrote for it, pixel for pixel.
    let last = attr(&dom, "last", "data-frame").parse::<u32>().unwrap();
    let shown = canvas(&dom, "last");
    let file = out_dir.join(format!("frame-{last:04}.png"));
    wait_for(&file, &mut child.0);
    let written = image::open(&file).unwrap().to_rgba8();
    assert_eq!(shown.dimensions(), (64, 48));
    assert!(shown == written, "the page's last frame {last} differs from {}", file.display());

    // The frame being received: its rows so far, then nothing.
    let live = attr(&dom, "live", "data-frame").parse::<u32>().unwrap();
    let rows = attr(&dom, "live", "data-rows").parse::<u32>().unwrap();
    let filling = canvas(&dom, "live");
    assert_eq!(filling.dimensions(), (64, 48));
    let file = out_dir.join(format!("frame-{live:04}.png"));
    wait_for(&file, &mut child.0);
    let final_frame = image::open(&file).unwrap().to_rgba8();
    for y in 0..48 {
        for x in 0..64 {
            let got = filling.get_pixel(x, y);
            if y < rows {
                assert_eq!(got, final_frame.get_pixel(x, y), "frame {live}, row {y} (in), pixel {x}");
            } else {
                assert_eq!(got.0[3], 0, "frame {live}, row {y} has not arrived yet, pixel {x} is drawn");
            }
        }
    }
    eprintln!("page: last frame {last}, frame {live} with {rows} rows in");
    drop(child);
    let _ = std::fs::remove_dir_all(&dir);
}

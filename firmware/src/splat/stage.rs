//! The splat stage: the FPGA's role in the point-splatting design, as a word-at-a-time machine that a
//! hardware block could replace one for one. It decodes codewords, keeps the 128-entry
//! material table and the ambient register, computes each splat's colour, and depth-tests
//! the splat's rows into a 16-line ring of 512-pixel lines (8 active, 8 imported ahead);
//! every line that a `shift` moves out of the active stripe is finished and handed to the
//! caller.
//!
//! Depth test: a pixel takes the splat when `(z, rgb) < (z_old, rgb_old)` (lexicographic;
//! the seed writes when `z ≤ z_old`). Breaking depth ties by colour makes every pixel the
//! minimum over all splats that cover it, independent of their order, so boards that each
//! render a random subset composite to exactly the one-board image (sort-last, SPEC.md §6.4).
//!
//! Words are processed in the order the code generator sends them; malformed words (a load
//! word outside a load, a command inside one, a bad depth word) stop the frame with an error.

#![deny(clippy::indexing_slicing, clippy::arithmetic_side_effects)]

use gridrt_shared::splat::{is_command, shade, Command, DepthWord, MaterialTerm, SplatWord, MAX_PIXEL_DEPTH};

/// Lines in the ring.
pub const RING_LINES: usize = 16;
/// Lines of the active stripe.
pub const ACTIVE_LINES: u32 = 8;
/// Pixels per line (9-bit X).
pub const LINE_PIXELS: usize = 512;
/// Visible columns of a tile: 512 minus 4 guard columns each side, rounded to whole boxes.
pub const TILE_COLUMNS: u16 = 504;
/// Materials in the table (7-bit index).
pub const MATERIALS: usize = 128;
/// Depth of a pixel no splat covered.
pub const BACKGROUND_DEPTH: u16 = u16::MAX;

/// Why the stage stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StageError {
    /// A command or load word broke the rules (SPEC.md §6.2).
    BadWord(u64),
    /// More than 128 materials were loaded.
    MaterialOverflow,
}

/// The splat stage's state for one tile of one frame.
pub struct SplatStage {
    colour: [[u32; LINE_PIXELS]; RING_LINES],
    depth: [[u16; LINE_PIXELS]; RING_LINES],
    materials: [[MaterialTerm; 3]; MATERIALS],
    ambient: u8,
    /// Word index inside a material load, `None` outside one.
    loading: Option<u16>,
    /// A splat waiting for its depth word (per-pixel depth mode).
    pending: Option<SplatWord>,
    pixel_depth: bool,
    background: u32,
    columns: u16,
    /// First line of the active stripe.
    top: u32,
    /// Box pixels depth-tested.
    pub fragments: u64,
}

impl SplatStage {
    /// A stage with an empty material table.
    pub const fn new() -> Self {
        Self {
            colour: [[0; LINE_PIXELS]; RING_LINES],
            depth: [[BACKGROUND_DEPTH; LINE_PIXELS]; RING_LINES],
            materials: [[MaterialTerm([0; 3]); 3]; MATERIALS],
            ambient: 0,
            loading: None,
            pending: None,
            pixel_depth: false,
            background: 0,
            columns: 0,
            top: 0,
            fragments: 0,
        }
    }

    /// Starts a tile: `columns` (≤ 504) visible columns, every line background
    /// (`0x00RRGGBB`) at [`BACKGROUND_DEPTH`], the active stripe at line 0.
    pub fn begin(&mut self, columns: u16, background: u32, pixel_depth: bool) {
        self.columns = columns.min(TILE_COLUMNS);
        self.background = background;
        self.pixel_depth = pixel_depth;
        self.top = 0;
        self.loading = None;
        self.pending = None;
        for line in self.colour.iter_mut() {
            line.fill(background);
        }
        for line in self.depth.iter_mut() {
            line.fill(BACKGROUND_DEPTH);
        }
    }

    /// First line of the active stripe.
    pub fn top(&self) -> u32 {
        self.top
    }

    /// Consumes one word; `line(y, colours, depths)` receives each finished line (its index
    /// and its first `columns` pixels) as a shift moves it out.
    pub fn push<E>(
        &mut self,
        word: u64,
        line: &mut impl FnMut(u32, &[u32], &[u16]) -> Result<(), E>,
    ) -> Result<(), Result<StageError, E>> {
        if let Some(s) = self.pending.take() {
            let d = DepthWord::unpack(word).map_err(|_| Ok(StageError::BadWord(word)))?;
            self.draw(&s, Some(d));
            return Ok(());
        }
        if let Some(i) = self.loading {
            if is_command(word) {
                return match Command::unpack(word) {
                    Ok(Command::EndLoad) => {
                        self.loading = None;
                        Ok(())
                    }
                    _ => Err(Ok(StageError::BadWord(word))),
                };
            }
            let t = MaterialTerm::unpack(word).map_err(|_| Ok(StageError::BadWord(word)))?;
            let (m, term) = ((i / 3) as usize, (i % 3) as usize);
            let slot =
                self.materials.get_mut(m).and_then(|e| e.get_mut(term)).ok_or(Ok(StageError::MaterialOverflow))?;
            *slot = t;
            self.loading = Some(i.wrapping_add(1));
            return Ok(());
        }
        if !is_command(word) {
            let s = SplatWord::unpack(word);
            if self.pixel_depth {
                self.pending = Some(s);
            } else {
                self.draw(&s, None);
            }
            return Ok(());
        }
        match Command::unpack(word).map_err(|_| Ok(StageError::BadWord(word)))? {
            Command::StartLoad => self.loading = Some(0),
            Command::EndLoad => return Err(Ok(StageError::BadWord(word))),
            Command::Ambient(a) => self.ambient = a,
            Command::Shift(n) => {
                for _ in 0..n {
                    self.shift_one(line).map_err(Err)?;
                }
            }
        }
        Ok(())
    }

    /// Moves the stripe down one line: the top line is finished (exported), its slot becomes
    /// line top + 16 (imported as background).
    fn shift_one<E>(&mut self, line: &mut impl FnMut(u32, &[u32], &[u16]) -> Result<(), E>) -> Result<(), E> {
        let slot = (self.top as usize) % RING_LINES;
        let n = self.columns as usize;
        if let (Some(c), Some(d)) = (self.colour.get_mut(slot), self.depth.get_mut(slot)) {
            line(self.top, c.get(..n).unwrap_or(&[]), d.get(..n).unwrap_or(&[]))?;
            c.fill(self.background);
            d.fill(BACKGROUND_DEPTH);
        }
        self.top = self.top.wrapping_add(1);
        Ok(())
    }

    /// Writes a splat into the active stripe: row r of its box is line top + r.
    fn draw(&mut self, s: &SplatWord, depth: Option<DepthWord>) {
        let terms = self.materials.get(s.material as usize).copied().unwrap_or([MaterialTerm([0; 3]); 3]);
        let [r, g, b] = shade(&terms, self.ambient, s.diffuse, s.specular);
        let rgb = (r as u32) << 16 | (g as u32) << 8 | b as u32;
        // Box column c is tile column x − 8 + c (X carries 4 guard columns each side).
        let left = (s.x as i32).wrapping_sub(8);
        for (row, run) in s.rows().iter().enumerate() {
            let Some((a, b)) = *run else { continue };
            let slot = (self.top as usize).wrapping_add(row) % RING_LINES;
            let (Some(cl), Some(dl)) = (self.colour.get_mut(slot), self.depth.get_mut(slot)) else { continue };
            for c in a..=b {
                let x = left.wrapping_add(c as i32);
                if x < 0 || x >= self.columns as i32 {
                    continue;
                }
                self.fragments = self.fragments.wrapping_add(1);
                let z = match depth {
                    Some(d) => d.at(c, row as u8),
                    None => s.z,
                };
                let (Some(pc), Some(pd)) = (cl.get_mut(x as usize), dl.get_mut(x as usize)) else { continue };
                if (z, rgb) < (*pd, *pc) {
                    *pd = z.min(MAX_PIXEL_DEPTH);
                    *pc = rgb;
                }
            }
        }
    }
}

impl Default for SplatStage {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
#[allow(clippy::indexing_slicing, clippy::arithmetic_side_effects)]
mod tests {
    use super::*;
    use gridrt_shared::splat::{Mode, RowCode};

    fn full_box(x: u16, z: u16, material: u8) -> u64 {
        SplatWord {
            mode: Mode::Symmetric,
            scans: [RowCode { start: 0, length: 7 }; 4],
            diffuse: 127,
            specular: 0,
            material,
            x,
            z,
        }
        .pack()
    }

    fn run(words: &[u64], pixel_depth: bool) -> Vec<(u32, Vec<u32>, Vec<u16>)> {
        let mut st = Box::new(SplatStage::new());
        st.begin(16, 0x000010, pixel_depth);
        let mut lines = Vec::new();
        for &w in words {
            st.push::<()>(w, &mut |y, c, d| {
                lines.push((y, c.to_vec(), d.to_vec()));
                Ok(())
            })
            .unwrap();
        }
        lines
    }

    fn load(terms: &[[u16; 3]]) -> Vec<u64> {
        let mut v = vec![Command::StartLoad.pack()];
        v.extend(terms.iter().map(|t| MaterialTerm(*t).pack()));
        v.push(Command::EndLoad.pack());
        v
    }

    #[test]
    fn nearer_splat_wins_whatever_the_order_and_ties_go_to_the_smaller_colour() {
        // Material 0 red, material 1 green (k_d only).
        let mut head = load(&[[0; 3], [514, 0, 0], [0; 3], [0; 3], [0, 514, 0], [0; 3]]);
        head.push(Command::Ambient(0).pack());
        let near_red = full_box(8, 10, 0);
        let far_green = full_box(12, 20, 1);
        for order in [[near_red, far_green], [far_green, near_red]] {
            let mut w = head.clone();
            w.extend(order);
            w.push(Command::Shift(8).pack());
            let lines = run(&w, false);
            assert_eq!(lines.len(), 8);
            let (_, c, d) = &lines[3];
            // Red covers columns 0..8 at z 10, green 4..12 at z 20: the overlap is red.
            assert_eq!(c[0..8], [0xFF0000; 8]);
            assert_eq!(c[8..12], [0x00FF00; 4]);
            assert_eq!(c[12..16], [0x000010; 4]);
            assert_eq!((d[0], d[9], d[13]), (10, 20, BACKGROUND_DEPTH));
        }
        // Equal depth: the smaller packed colour (green) wins, in either order.
        let green_same_z = full_box(8, 10, 1);
        for order in [[near_red, green_same_z], [green_same_z, near_red]] {
            let mut w = head.clone();
            w.extend(order);
            w.push(Command::Shift(1).pack());
            assert_eq!(run(&w, false)[0].1[0..8], [0x00FF00; 8]);
        }
    }

    #[test]
    fn shift_exports_lines_in_order_and_clears_them() {
        let mut w = load(&[[0; 3], [514; 3], [0; 3]]);
        w.push(full_box(8, 5, 0));
        w.push(Command::Shift(3).pack());
        // Rows 3.. of the box are still active; a second splat at the new top.
        w.push(full_box(16, 5, 0));
        w.push(Command::Shift(20).pack());
        let lines = run(&w, false);
        assert_eq!(lines.iter().map(|l| l.0).collect::<Vec<_>>(), (0..23).collect::<Vec<_>>());
        // Line 2: only the first splat (columns 0..8); line 5: both; line 9: the second only.
        assert_eq!(lines[2].1[..8], [0xFFFFFF; 8]);
        assert_eq!(lines[2].1[8..16], [0x000010; 8]);
        assert_eq!(lines[5].1[..16], [0xFFFFFF; 16]);
        assert_eq!(lines[9].1[..8], [0x000010; 8]);
        assert_eq!(lines[9].1[8..16], [0xFFFFFF; 8]);
        // Line 18 was never written: background at background depth.
        assert_eq!(lines[18].2, vec![BACKGROUND_DEPTH; 16]);
    }

    #[test]
    fn per_pixel_depth_uses_the_depth_word_slopes() {
        let mut w = load(&[[0; 3], [514; 3], [0; 3], [0; 3], [0, 0, 514], [0; 3]]);
        // White splat, depth 100 at its centre, rising to the right.
        w.push(full_box(8, 0, 0));
        w.push(DepthWord { z: 100, dzdx: 64, dzdy: 0 }.pack());
        // Blue splat at constant depth 100: in front on the right half, behind on the left.
        w.push(full_box(8, 0, 1));
        w.push(DepthWord { z: 100, dzdx: 0, dzdy: 0 }.pack());
        w.push(Command::Shift(1).pack());
        let (_, c, d) = &run(&w, true)[0];
        // Column c: 100 + (64·(2c − 7)) >> 5 = 100 + 2·(2c − 7)... = 86, 90, 94, 98, 102, …
        assert_eq!(d[..8], [86, 90, 94, 98, 100, 100, 100, 100]);
        assert_eq!(c[..4], [0xFFFFFF; 4]);
        assert_eq!(c[4..8], [0x0000FF; 4]);
    }

    #[test]
    fn malformed_words_stop_the_stage() {
        let mut st = Box::new(SplatStage::new());
        st.begin(16, 0, false);
        let mut sink = |_: u32, _: &[u32], _: &[u16]| Ok::<(), ()>(());
        assert_eq!(st.push(Command::EndLoad.pack(), &mut sink), Err(Ok(StageError::BadWord(Command::EndLoad.pack()))));
        st.push(Command::StartLoad.pack(), &mut sink).unwrap();
        assert!(st.push(Command::Shift(1).pack(), &mut sink).is_err());
        st.begin(16, 0, false);
        st.push(Command::StartLoad.pack(), &mut sink).unwrap();
        for _ in 0..3 * MATERIALS {
            st.push(0, &mut sink).unwrap();
        }
        assert_eq!(st.push(0, &mut sink), Err(Ok(StageError::MaterialOverflow)));
        st.begin(16, 0, true);
        st.push(full_box(8, 0, 0), &mut sink).unwrap();
        assert!(st.push(u64::MAX, &mut sink).is_err(), "a depth word with reserved bits set");
    }
}

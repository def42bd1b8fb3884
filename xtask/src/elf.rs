//! Section sizes of a built image, read with the `object` crate (no target binutils needed).

use anyhow::{Context, Result};
use object::{Object, ObjectSection, SectionFlags, SectionKind};
use std::path::Path;

/// Prints every section that occupies target memory, then the berkeley-style totals
/// (`text` = code + read-only data, `data` = initialised RAM, `bss` = zeroed RAM).
pub fn print_sections(path: &Path) -> Result<()> {
    let bytes = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
    let file = object::File::parse(&*bytes).with_context(|| format!("parsing {}", path.display()))?;

    println!("{:<14} {:>10} {:>10}", "section", "address", "size");
    let (mut text, mut data, mut bss) = (0u64, 0u64, 0u64);
    for section in file.sections() {
        // SHF_ALLOC: the section occupies target memory (debug info does not).
        let alloc = matches!(section.flags(),
            SectionFlags::Elf { sh_flags, .. } if sh_flags.contains(object::elf::SHF_ALLOC));
        if !alloc || name_is_placeholder(&section) {
            continue;
        }
        let name = section.name().unwrap_or("?");
        let size = section.size();
        println!("{:<14} {:#010x} {:>10}", name, section.address(), size);
        // .heap and .stack are riscv-rt's placeholders for free RAM, not program data.
        if matches!(name, ".heap" | ".stack") {
            continue;
        }
        match section.kind() {
            SectionKind::Text | SectionKind::ReadOnlyData | SectionKind::ReadOnlyString => text += size,
            SectionKind::UninitializedData | SectionKind::UninitializedTls => bss += size,
            SectionKind::Data | SectionKind::Tls => data += size,
            // e.g. .eh_frame: loaded, read-only.
            _ => text += size,
        }
    }
    println!("text {text} B, data {data} B, bss {bss} B; loaded image {} B", text + data);
    Ok(())
}

/// riscv-rt's `.text.dummy` only positions `_stext`; it never holds anything.
fn name_is_placeholder(section: &object::Section<'_, '_>) -> bool {
    section.name() == Ok(".text.dummy")
}

/// The loadable bytes of an ELF as a memory image: `(address of the first byte, bytes)`,
/// from the lowest to the highest physical address of its `PT_LOAD` segments with file
/// data, gaps zero-filled (as `gridrt flash` sends them; a ROM image the same way).
pub fn load_image(path: &Path) -> Result<(u64, Vec<u8>)> {
    use object::read::elf::{ElfFile32, ProgramHeader};
    let bytes = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
    let file =
        ElfFile32::<object::Endianness>::parse(&*bytes).with_context(|| format!("parsing {}", path.display()))?;
    let endian = file.endian();
    let mut segments = vec![];
    for ph in file.elf_program_headers() {
        if ph.p_type(endian) != object::elf::PT_LOAD || ph.p_filesz(endian) == 0 {
            continue;
        }
        let data =
            ph.data(endian, &*bytes).map_err(|()| anyhow::anyhow!("{}: segment outside the file", path.display()))?;
        segments.push((u64::from(ph.p_paddr(endian)), data));
    }
    let base = segments.iter().map(|s| s.0).min().with_context(|| format!("{}: nothing to load", path.display()))?;
    let end = segments.iter().map(|s| s.0 + s.1.len() as u64).max().unwrap_or(base);
    let mut image = vec![0u8; usize::try_from(end - base)?];
    for (addr, data) in segments {
        let off = usize::try_from(addr - base)?;
        image[off..off + data.len()].copy_from_slice(data);
    }
    Ok((base, image))
}

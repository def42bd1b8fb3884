//! The bootloader image: receives an application image over the console UART
//! (SPEC.md §3.11, logic in `gridrt_firmware::boot`), writes it into the application region
//! (`board::app_region`, from boards/<board>-bootloader.x), verifies its CRC-32 from memory,
//! and jumps to its entry point. A refused image is answered with an `Error` message and
//! the bootloader keeps serving.
#![no_std]
#![no_main]
#![deny(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use core::fmt::Write as _;
use embedded_io::Write as _;
use gridrt_firmware::boot::Bootloader;
use gridrt_firmware::bsp::UartWriter;
use gridrt_firmware_image::serve::{self, read_some, RX_BATCH};
use gridrt_firmware_image::{board, VERSION};
use gridrt_shared::msg::DeviceInfo;

#[riscv_rt::entry]
fn main() -> ! {
    // Before anything can touch main RAM (the application region is there).
    let main_ram = board::init_main_ram();
    // SAFETY: the only console owner; trap/panic reports alias it only once we stop.
    let mut console = unsafe { board::take_console() };
    let (start, end) = board::app_region();
    let _ = write!(
        UartWriter(&mut console),
        "gridrt bootloader {VERSION} on {}: main RAM {}; application region {start:#010x}..{end:#010x}; send SPEC.md 3.11 frames\r\n",
        board::NAME,
        board::MAIN_RAM
    );
    if let Err(at) = main_ram {
        // Images still get their read-back check, which then refuses them with `BadCrc`.
        let _ = write!(UartWriter(&mut console), "main RAM FAILED its check at {at:#010x}\r\n");
    }
    // Ends the text for a frame decoder (it becomes one bad frame, which hosts ignore).
    let _ = console.write_all(&[0]);

    // SAFETY: the application region is RAM that the bootloader's own sections, stack
    // included, never use (its memory map puts them below `start`); nothing else aliases it.
    let region = unsafe { core::slice::from_raw_parts_mut(start as *mut u8, end.saturating_sub(start)) };
    let info = DeviceInfo {
        protocol: 0, // filled in by Bootloader::new, like the rest
        firmware: serve::firmware_version(),
        board: board::BOARD_ID,
        max_payload: 0,
        pe_count: 0,
        voxel_capacity: 0,
        pe_mem_words: 0,
        features: 0,
    };
    let mut boot = Bootloader::new(start as u32, region, info);
    // The LiteX UART holds 64 bytes, and writing a data frame to main RAM takes longer than
    // that many bytes on a 3 Mbaud line: one frame in flight, so that the line drops none.
    #[cfg(feature = "board-litex")]
    boot.set_window((gridrt_shared::frame::MAX_PAYLOAD - 4) as u16);
    let mut buf = [0u8; RX_BATCH];
    loop {
        let n = read_some(&mut console, &mut buf);
        let Some(bytes) = buf.get(..n).filter(|b| !b.is_empty()) else {
            continue;
        };
        if let Some(entry) = boot.feed(bytes, &mut console) {
            // Let the Booting acknowledgement leave before the app re-initialises the UART.
            let _ = console.flush();
            // SAFETY: the image at `entry` was written, read back and CRC-checked; it is a
            // riscv-rt image linked for this region, whose `_start` sets up everything.
            unsafe { jump(entry as usize) }
        }
    }
}

/// Makes the written instructions visible to instruction fetch, then jumps to `entry` with
/// interrupts off (as after reset; nothing was enabled).
///
/// # Safety
///
/// `entry` must be the start of valid code that never returns.
unsafe fn jump(entry: usize) -> ! {
    // SAFETY: forwarded. `fence.i` (encoded as a word: not every assembler profile enables
    // Zifencei) orders the stores above before later instruction fetches.
    unsafe {
        core::arch::asm!(
            "fence rw, rw",
            ".4byte 0x0000100f",
            "jr {0}",
            in(reg) entry,
            options(noreturn)
        )
    }
}

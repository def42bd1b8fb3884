//! Last-resort reports: panics, unhandled exceptions and interrupts print what is known
//! over the console, then the hart halts (it never returns into broken state). On QEMU
//! `virt` the emulation then ends with exit status 1 (trap) or 2 (panic) through the SiFive
//! test device, so a crash is never mistaken for a slow device.
//!
//! The report lines start with `PANIC:` / `TRAP:` so host tools can spot them.

use crate::{board, halt};
use embedded_io::Write as _;
use gridrt_firmware::bsp::UartWriter;
use gridrt_firmware::text::TextOut;
use riscv::register::{mcause, mepc, mtval};

/// Names of the standard exception codes (privileged spec, table "mcause values").
fn exception_name(code: usize) -> &'static str {
    match code {
        0 => "instruction address misaligned",
        1 => "instruction access fault",
        2 => "illegal instruction",
        3 => "breakpoint",
        4 => "load address misaligned",
        5 => "load access fault",
        6 => "store/AMO address misaligned",
        7 => "store/AMO access fault",
        8 => "environment call from U-mode",
        9 => "environment call from S-mode",
        11 => "environment call from M-mode",
        12 => "instruction page fault",
        13 => "load page fault",
        15 => "store/AMO page fault",
        _ => "reserved/custom",
    }
}

fn report(kind: &str) -> ! {
    let cause = mcause::read();
    // SAFETY: the interrupted code never runs again, so aliasing its console is harmless.
    // The UART is not re-initialised: that could cut a byte being sent.
    let mut console = unsafe { board::console_unchecked() };
    let name = if cause.is_interrupt() { "interrupt" } else { exception_name(cause.code()) };
    // Best effort: nothing is left to report a console error to. Formatted as
    // "\r\nTRAP: {kind} mcause={:#010x} ({name}) mepc={:#010x} mtval={:#010x}; halted\n"
    // without core::fmt (`TextOut`: the soft-core's code budget).
    let mut w = UartWriter(&mut console);
    for s in ["\r\nTRAP: ", kind, " mcause="] {
        w.put(s);
    }
    w.put_hex(cause.bits() as u32, 8);
    for s in [" (", name, ") mepc="] {
        w.put(s);
    }
    w.put_hex(mepc::read() as u32, 8);
    w.put(" mtval=");
    w.put_hex(mtval::read() as u32, 8);
    w.put("; halted\n");
    let _ = console.flush();
    board::exit_failure(1);
    halt()
}

/// riscv-rt calls this (C ABI, see riscv-macros `pac_enum`) for every exception without a
/// dedicated handler, replacing its
/// default, `abort`, which spins silently.
#[export_name = "ExceptionHandler"]
extern "C" fn exception_handler(_frame: &riscv_rt::TrapFrame) -> ! {
    report("exception")
}

/// riscv-rt calls this for every interrupt without a handler; we enable none, so one
/// arriving is a bug worth a report.
#[export_name = "DefaultHandler"]
extern "C" fn default_handler() -> ! {
    report("unexpected interrupt")
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo<'_>) -> ! {
    // SAFETY: as in `report`: the panicking code never resumes.
    let mut console = unsafe { board::console_unchecked() };
    // "\r\nPANIC: {info}; halted\n" without core::fmt (`TextOut`: the soft-core's code
    // budget): the location, and the message when it is a plain string (`panic!("text")`); a
    // message with arguments (e.g. an index out of bounds) is not formatted.
    let mut w = UartWriter(&mut console);
    w.put("\r\nPANIC: panicked at ");
    if let Some(loc) = info.location() {
        w.put(loc.file());
        w.put(":");
        w.put_dec(loc.line() as u64);
        w.put(":");
        w.put_dec(loc.column() as u64);
    }
    w.put(":\n");
    w.put(info.message().as_str().unwrap_or("(message with arguments, not formatted on the device)"));
    w.put("; halted\n");
    let _ = console.flush();
    board::exit_failure(2);
    halt()
}

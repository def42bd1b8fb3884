//! Serial ports: opening one for a session, and listing what the machine has.
//!
//! [`open`] configures 8N1 raw mode with `TCSANOW` and does **not** flush: QEMU's `-serial pty`
//! (and `cargo xtask qemu`, which holds the pty so early output is kept) leaves the device's
//! banner and any early frames in the tty buffer, and a flush on open (`TCSAFLUSH`,
//! `tcflush`) would throw them away. serialport 4 on Linux does not flush on open; this
//! module keeps it that way and never calls `clear()`.
//!
//! The returned port's reads block for at most `timeout`, then fail with `TimedOut`: the
//! transport contract of [`crate::session`] and [`crate::flash`].

use std::time::Duration;

/// Read timeout suited to [`crate::session::Session`] and [`crate::flash`]: short, so their
/// own per-stage timeouts stay responsive.
pub const DEFAULT_READ_TIMEOUT: Duration = Duration::from_millis(50);

/// Why a port could not be opened or listed.
#[derive(Debug, thiserror::Error)]
pub enum SerialError {
    /// Opening `path` failed.
    #[error("opening serial port {path}: {source}")]
    Open {
        /// The port.
        path: String,
        /// What serialport said.
        source: serialport::Error,
    },
    /// Enumerating ports failed.
    #[error("listing serial ports: {0}")]
    List(serialport::Error),
}

/// Opens `path` at `baud` (8N1, no flow control) with read timeout `timeout`, without
/// flushing pending input.
pub fn open(path: &str, baud: u32, timeout: Duration) -> Result<Box<dyn serialport::SerialPort>, SerialError> {
    serialport::new(path, baud)
        .timeout(timeout)
        .data_bits(serialport::DataBits::Eight)
        .parity(serialport::Parity::None)
        .stop_bits(serialport::StopBits::One)
        .flow_control(serialport::FlowControl::None)
        .open()
        .map_err(|source| SerialError::Open { path: path.to_string(), source })
}

/// One port found on the machine.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PortEntry {
    /// Device path, e.g. `/dev/ttyUSB0`.
    pub path: String,
    /// What it is: `usb 0403:6010 FTDI Dual RS232-HS (serial FT1234)`, `pci`, `bluetooth`,
    /// `unknown`.
    pub description: String,
}

/// The serial ports the OS reports (USB adapters, on-board UARTs). Pseudo-terminals such
/// as QEMU's are not listed: `cargo xtask qemu` prints its pty path.
pub fn list() -> Result<Vec<PortEntry>, SerialError> {
    let mut ports = serialport::available_ports().map_err(SerialError::List)?;
    ports.sort_by(|a, b| a.port_name.cmp(&b.port_name));
    Ok(ports.into_iter().map(|p| PortEntry { description: describe(&p.port_type), path: p.port_name }).collect())
}

fn describe(t: &serialport::SerialPortType) -> String {
    match t {
        serialport::SerialPortType::UsbPort(u) => {
            let mut s = format!("usb {:04x}:{:04x}", u.vid, u.pid);
            for part in [&u.manufacturer, &u.product].into_iter().flatten() {
                s.push(' ');
                s.push_str(part);
            }
            if let Some(sn) = &u.serial_number {
                s.push_str(&format!(" (serial {sn})"));
            }
            s
        }
        serialport::SerialPortType::PciPort => "pci".into(),
        serialport::SerialPortType::BluetoothPort => "bluetooth".into(),
        serialport::SerialPortType::Unknown => "unknown".into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn opening_a_missing_port_names_it() {
        let e = open("/dev/gridrt-no-such-port", 115_200, DEFAULT_READ_TIMEOUT).err().unwrap();
        assert!(e.to_string().contains("/dev/gridrt-no-such-port"), "{e}");
    }

    #[test]
    fn listing_does_not_fail_on_this_machine() {
        // Containers may have no ports at all; the call itself must still work.
        let ports = list().unwrap();
        assert!(ports.iter().all(|p| !p.path.is_empty()));
    }
}

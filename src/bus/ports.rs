//! Serial ports on this machine, and the USB latency setting that decides how fast reads are.

use std::fmt;
use std::path::Path;

/// A serial port and what the system says about it.
#[derive(Debug, Clone, PartialEq)]
pub struct PortInfo {
    /// The device path (`/dev/ttyUSB0`).
    pub path: String,
    /// The USB adapter behind it, for a USB serial port.
    pub usb: Option<UsbInfo>,
}

/// What a USB serial adapter says about itself.
#[derive(Debug, Clone, PartialEq)]
pub struct UsbInfo {
    /// USB vendor id.
    pub vid: u16,
    /// USB product id.
    pub pid: u16,
    /// The manufacturer string, if it gives one.
    pub manufacturer: Option<String>,
    /// The product string, if it gives one.
    pub product: Option<String>,
    /// The serial number, if it gives one.
    pub serial_number: Option<String>,
}

impl UsbInfo {
    /// The adapter family, from its USB vendor and product ids.
    pub fn adapter(&self) -> Option<&'static str> {
        match (self.vid, self.pid) {
            (0x0403, 0x6014) => Some("FTDI FT232H (ROBOTIS U2D2)"),
            (0x0403, _) => Some("FTDI"),
            (0x1a86, 0x7523) => Some("WCH CH340"),
            (0x1a86, 0x55d3) => Some("WCH CH343 (Feetech / Waveshare bus servo adapter)"),
            (0x1a86, _) => Some("WCH"),
            (0x10c4, _) => Some("Silicon Labs CP210x"),
            _ => None,
        }
    }
}

impl fmt::Display for PortInfo {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.path)?;
        if let Some(usb) = &self.usb {
            write!(f, "  USB {:04x}:{:04x}", usb.vid, usb.pid)?;
            if let Some(adapter) = usb.adapter() {
                write!(f, " {adapter}")?;
            }
            for part in [&usb.manufacturer, &usb.product, &usb.serial_number]
                .into_iter()
                .flatten()
            {
                write!(f, " | {part}")?;
            }
        }
        Ok(())
    }
}

/// Serial ports, USB ones first. Without libudev, `serialport` scans /sys/class/tty.
pub fn list_ports() -> Vec<PortInfo> {
    let Ok(ports) = std::panic::catch_unwind(serialport::available_ports) else {
        // serialport panics when /sys/class/tty is missing (containers); no ports then.
        return Vec::new();
    };
    let mut list: Vec<PortInfo> = ports
        .unwrap_or_default()
        .into_iter()
        .map(|p| PortInfo {
            path: p.port_name,
            usb: match p.port_type {
                serialport::SerialPortType::UsbPort(u) => Some(UsbInfo {
                    vid: u.vid,
                    pid: u.pid,
                    manufacturer: u.manufacturer,
                    product: u.product,
                    serial_number: u.serial_number,
                }),
                _ => None,
            },
        })
        .collect();
    list.sort_by_key(|p| (p.usb.is_none(), p.path.clone()));
    list
}

/// (device, milliseconds) of every FTDI adapter's latency timer. The ftdi_sio driver batches
/// received bytes for this long (16 ms by default), which caps a read-back loop at ~60 Hz.
pub fn latency_timers() -> Vec<(String, u32)> {
    read_latency_timers(Path::new("/sys/bus/usb-serial/devices"))
}

fn read_latency_timers(dir: &Path) -> Vec<(String, u32)> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    let mut timers: Vec<(String, u32)> = entries
        .flatten()
        .filter_map(|entry| {
            let text = std::fs::read_to_string(entry.path().join("latency_timer")).ok()?;
            let ms = text.trim().parse().ok()?;
            Some((entry.file_name().to_string_lossy().into_owned(), ms))
        })
        .collect();
    timers.sort();
    timers
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn latency_timers_are_read_from_sysfs_layout() {
        // The sysfs layout of an FTDI adapter, written by hand: a real file tree, read by the
        // same code as /sys.
        let dir = tempfile::tempdir().unwrap();
        for (name, value) in [("ttyUSB0", "16\n"), ("ttyUSB1", "1\n")] {
            std::fs::create_dir(dir.path().join(name)).unwrap();
            std::fs::write(dir.path().join(name).join("latency_timer"), value).unwrap();
        }
        std::fs::create_dir(dir.path().join("ttyACM0")).unwrap();
        assert_eq!(
            read_latency_timers(dir.path()),
            [("ttyUSB0".to_string(), 16), ("ttyUSB1".to_string(), 1)]
        );
    }
}

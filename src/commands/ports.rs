//! `keypose ports`: the serial ports of this machine.

use super::{write_output, CommandError, Verdict};
use keypose::bus;

/// `keypose ports`: the serial ports of this machine, with USB adapter details.
pub fn run() -> Result<Verdict, CommandError> {
    let ports = bus::list_ports();
    if ports.is_empty() {
        eprintln!("no serial ports found");
    }
    let text: String = ports.iter().map(|p| format!("{p}\n")).collect();
    write_output(None, &text)?;
    Ok(Verdict::Pass)
}

//! `keypose doctor`: what keypose finds on this machine, and what to fix.

use super::{write_output, CommandError, Verdict};
use keypose::bus;

/// `keypose doctor`: what keypose finds on this machine, and what to fix.
pub fn run() -> Result<Verdict, CommandError> {
    let mut out = ports_report();
    out.push_str(&latency_report());
    out.push_str(&scheduling_report());
    out.push_str(&cpu_frequency_report());
    out.push_str("python (vendor SDK bridge, dataset reader, simulation):\n");
    out.push_str(&keypose::python::doctor_report());
    out.push_str(&simulation_report());
    write_output(None, &out)?;
    Ok(Verdict::Pass)
}

fn ports_report() -> String {
    let mut out = String::from("serial ports:\n");
    let ports = bus::list_ports();
    if ports.is_empty() {
        out.push_str("  none found\n");
    }
    for p in &ports {
        out.push_str(&format!("  {p}\n"));
    }
    out
}

/// The udev rule that sets every FTDI adapter's latency timer to 1 ms when it is plugged in.
const LATENCY_UDEV_RULE: &str =
    "ACTION==\"add\", SUBSYSTEM==\"usb-serial\", DRIVER==\"ftdi_sio\", ATTR{latency_timer}=\"1\"";

/// FTDI adapters buffer reads for their latency timer (16 ms by default), which alone would
/// make a 100 Hz loop miss its deadlines.
fn latency_report() -> String {
    let mut out = String::from("USB latency timers:\n");
    let timers = bus::latency_timers();
    if timers.is_empty() {
        out.push_str(&format!(
            "  no FTDI USB-serial adapters (for one, set its latency timer to 1 ms with the udev \
             rule\n    {LATENCY_UDEV_RULE}\n    in /etc/udev/rules.d/99-keypose-ftdi.rules)\n"
        ));
    }
    for (device, ms) in timers {
        if ms >= 16 {
            out.push_str(&format!(
                "  WARNING {device}: latency_timer is {ms} ms, which adds up to {ms} ms to every read.\n    \
                 Lower it: echo 1 | sudo tee /sys/bus/usb-serial/devices/{device}/latency_timer\n    \
                 (permanently: the udev rule {LATENCY_UDEV_RULE}\n    in /etc/udev/rules.d/99-keypose-ftdi.rules)\n"
            ));
        } else {
            out.push_str(&format!("  {device}: latency_timer {ms} ms (ok)\n"));
        }
    }
    out
}

/// What `--realtime` would get: the rtprio and memlock limits and whether SCHED_FIFO is granted.
fn scheduling_report() -> String {
    use keypose::pacing::realtime;
    let limit = |value: Option<u64>, scale: u64, unit: &str| match value {
        Some(realtime::UNLIMITED) => "unlimited".to_string(),
        Some(v) => format!("{}{unit}", v / scale),
        None => "unknown".to_string(),
    };
    let mut out = format!(
        "scheduling (--realtime):\n  rtprio limit {}, memlock limit {}\n",
        limit(realtime::rtprio_limit(), 1, ""),
        limit(realtime::memlock_limit(), 1024, " KiB"),
    );
    match realtime::fifo_permitted() {
        Ok(priority) => out.push_str(&format!("  SCHED_FIFO: permitted (priority {priority})\n")),
        Err(e) => out.push_str(&format!(
            "  SCHED_FIFO: refused ({e}); --realtime falls back to the ordinary scheduler.\n    \
             Allow it: `@plugdev - rtprio 95` and `@plugdev - memlock unlimited` in \
             /etc/security/limits.conf (then log in again), or run with CAP_SYS_NICE\n"
        )),
    }
    out
}

/// CPU frequency scaling: a governor that idles the clock makes every cycle start slow.
fn cpu_frequency_report() -> String {
    let mut out = String::from("CPU frequency scaling:\n");
    let governors = keypose::pacing::machine::cpu_governors();
    if governors.is_empty() {
        out.push_str(&format!(
            "  not exposed ({}/cpu*/cpufreq/scaling_governor absent: a virtual machine, or no cpufreq)\n",
            keypose::pacing::machine::CPU_SYSFS
        ));
    }
    for (cpu, governor) in &governors {
        let advice = if governor == "performance" {
            " (ok)".to_string()
        } else {
            ": the clock slows when idle; for steady cycles: sudo cpupower frequency-set -g \
             performance"
                .to_string()
        };
        out.push_str(&format!("  {cpu}: scaling_governor {governor}{advice}\n"));
    }
    out
}

/// What the simulation harness reports when it starts: MuJoCo's version and the GL backend.
/// Never builds the environment (that is for the first `sim`).
fn simulation_report() -> String {
    use keypose::error::Report;
    use keypose::python::{Harness, HarnessOptions, PyConfig};
    let config = match PyConfig::from_env() {
        Ok(c) => c,
        Err(e) => return format!("  simulation: {}\n", Report(&e)),
    };
    let python = match config.find_python() {
        Ok(Some(env)) => env.python,
        Ok(None) => {
            return "  simulation: the environment is built on the first `keypose sim`\n".into()
        }
        Err(e) => return format!("  simulation: {}\n", Report(&e)),
    };
    let started = config
        .script_path(keypose::sim::HARNESS_SCRIPT)
        .map_err(|e| Report(&e).to_string())
        .and_then(|script| {
            Harness::spawn(&python, &script, HarnessOptions::default())
                .map_err(|e| Report(&e).to_string())
        });
    match started {
        Ok(harness) => {
            let ready = harness.ready();
            let field = |name: &str| ready[name].as_str().unwrap_or("?").to_string();
            format!(
                "  {}: ready: mujoco {}, numpy {}, MUJOCO_GL {}\n",
                keypose::sim::HARNESS_SCRIPT,
                field("mujoco"),
                field("numpy"),
                ready["gl"]
                    .as_str()
                    .unwrap_or("not set (egl is tried first, then osmesa)")
            )
        }
        Err(e) => format!("  {}: does not start: {e}\n", keypose::sim::HARNESS_SCRIPT),
    }
}

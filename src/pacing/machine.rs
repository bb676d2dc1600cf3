//! What the machine does to a control loop's timing: CPU frequency scaling, and how busy it is.
//!
//! A CPU that lowers its clock while idle (the `powersave`, `ondemand` or `schedutil`
//! governors) takes time to speed up again when the control thread wakes, which shows as
//! lateness at the start of every cycle; the `performance` governor keeps the clock up.

use std::path::Path;

/// Where Linux exposes each CPU's frequency governor (`cpuN/cpufreq/scaling_governor`).
pub const CPU_SYSFS: &str = "/sys/devices/system/cpu";

/// (cpu, governor) of every CPU that exposes frequency scaling, in CPU order; empty when none
/// does (a virtual machine, or a kernel without cpufreq).
pub fn cpu_governors() -> Vec<(String, String)> {
    read_cpu_governors(Path::new(CPU_SYSFS))
}

fn read_cpu_governors(dir: &Path) -> Vec<(String, String)> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    let mut governors: Vec<(u32, String, String)> = entries
        .flatten()
        .filter_map(|entry| {
            let name = entry.file_name().to_string_lossy().into_owned();
            let index: u32 = name.strip_prefix("cpu")?.parse().ok()?;
            let path = entry.path().join("cpufreq").join("scaling_governor");
            let governor = std::fs::read_to_string(path).ok()?.trim().to_string();
            Some((index, name, governor))
        })
        .collect();
    governors.sort();
    governors
        .into_iter()
        .map(|(_, cpu, governor)| (cpu, governor))
        .collect()
}

/// How busy the machine is: Linux's one-minute load average (`/proc/loadavg`, the runnable
/// threads averaged) and the CPUs there are to run them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Load {
    /// Runnable threads, averaged over the last minute.
    pub average: f64,
    /// CPUs available to this process.
    pub cpus: usize,
}

impl Load {
    /// The machine's load now; `None` where the kernel does not say (not Linux).
    pub fn now() -> Option<Load> {
        let text = std::fs::read_to_string("/proc/loadavg").ok()?;
        let average = parse_load_average(&text)?;
        let cpus = std::thread::available_parallelism().map_or(1, |n| n.get());
        Some(Load { average, cpus })
    }

    /// Whether more threads want to run than there are CPUs to run them.
    pub fn overloaded(&self) -> bool {
        self.average > self.cpus as f64
    }
}

/// The one-minute average, the first field of `/proc/loadavg` ("0.52 0.58 0.59 1/467 1234").
fn parse_load_average(text: &str) -> Option<f64> {
    text.split_whitespace()
        .next()?
        .parse()
        .ok()
        .filter(|x: &f64| x.is_finite())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn governors_are_read_per_cpu_in_numeric_order_from_the_sysfs_layout() {
        // The sysfs layout written by hand: cpu10 sorts after cpu2; "cpufreq" and "cpuidle"
        // directories beside the CPUs are not CPUs; a CPU without cpufreq is left out.
        let dir = tempfile::tempdir().unwrap();
        for (cpu, governor) in [
            ("cpu0", "powersave\n"),
            ("cpu2", "performance\n"),
            ("cpu10", "schedutil\n"),
        ] {
            let freq = dir.path().join(cpu).join("cpufreq");
            std::fs::create_dir_all(&freq).unwrap();
            std::fs::write(freq.join("scaling_governor"), governor).unwrap();
        }
        std::fs::create_dir_all(dir.path().join("cpu1")).unwrap();
        std::fs::create_dir_all(dir.path().join("cpufreq")).unwrap();
        std::fs::create_dir_all(dir.path().join("cpuidle")).unwrap();
        assert_eq!(
            read_cpu_governors(dir.path()),
            [
                ("cpu0".to_string(), "powersave".to_string()),
                ("cpu2".to_string(), "performance".to_string()),
                ("cpu10".to_string(), "schedutil".to_string()),
            ]
        );
    }

    #[test]
    fn the_load_average_is_the_first_field_of_proc_loadavg() {
        assert_eq!(
            parse_load_average("7.25 3.10 1.02 9/467 1234\n"),
            Some(7.25)
        );
        assert_eq!(parse_load_average(""), None);
        assert_eq!(parse_load_average("nan 1 1 1/1 1"), None);
        let load = Load {
            average: 7.25,
            cpus: 2,
        };
        assert!(load.overloaded());
    }
}

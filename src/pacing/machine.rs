//! What the machine does to a control loop's timing: CPU frequency scaling.
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
}

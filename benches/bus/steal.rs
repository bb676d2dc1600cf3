//! CPU steal: time the hypervisor gave this machine's CPUs to someone else, printed beside the
//! figures it can spoil.

/// Cumulative (total, steal) CPU time from the first line of /proc/stat, in clock ticks.
/// Steal is time the hypervisor gave this machine's CPUs to someone else: on a shared virtual
/// machine it is what turns a 100 µs bus cycle into a 10 ms one now and then.
pub fn cpu_ticks() -> Option<(u64, u64)> {
    let text = std::fs::read_to_string("/proc/stat").ok()?;
    let fields: Vec<u64> = text
        .lines()
        .next()?
        .split_whitespace()
        .skip(1)
        .filter_map(|f| f.parse().ok())
        .collect();
    // user nice system idle iowait irq softirq steal (guest time is already inside user).
    let total = fields.iter().take(8).sum();
    Some((total, *fields.get(7)?))
}

/// Steal as a share of all CPU time since `since`, as text ("12 %", or "?" without /proc).
pub fn steal_since(since: Option<(u64, u64)>) -> String {
    match (since, cpu_ticks()) {
        (Some((total0, steal0)), Some((total1, steal1))) if total1 > total0 => format!(
            "{:.0} %",
            100.0 * (steal1 - steal0) as f64 / (total1 - total0) as f64
        ),
        _ => "?".into(),
    }
}

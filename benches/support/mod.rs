//! What the benches measure besides wall time: the process's CPU seconds, its peak resident
//! memory and the machine's load (shared by the benches that include it as `mod support;`).

#![allow(dead_code)]

/// CPU time of the whole process so far (user + system, every thread, s): on a machine
/// shared with other work, CPU seconds over the cores used estimate the wall time alone.
pub fn cpu_seconds() -> f64 {
    // SAFETY: getrusage writes one rusage through a valid pointer.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    unsafe { libc::getrusage(libc::RUSAGE_SELF, &mut usage) };
    let seconds = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
    seconds(usage.ru_utime) + seconds(usage.ru_stime)
}

/// Reset the peak resident memory (VmHWM) of this process to its current size.
pub fn reset_peak() {
    let _ = std::fs::write("/proc/self/clear_refs", "5");
}

/// Peak resident memory (MB) since the last [`reset_peak`] (NaN where /proc does not say).
pub fn peak_mb() -> f64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmHWM:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<f64>().ok())
        .map_or(f64::NAN, |kb| kb / 1e3)
}

/// The 1-minute load average (NaN where /proc does not say).
pub fn load() -> f64 {
    std::fs::read_to_string("/proc/loadavg")
        .ok()
        .and_then(|s| s.split_whitespace().next()?.parse().ok())
        .unwrap_or(f64::NAN)
}

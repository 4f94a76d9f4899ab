//! Memory of a benchmark case: the process's resident memory now and its
//! high-water mark, reset before the case (Linux `/proc`; elsewhere none).

/// Resets the high-water mark of resident memory to the current use.
pub fn reset_peak() {
    // Writing 5 to clear_refs resets VmHWM (Linux 4.0+); without it the
    // peak is the run's so far, which only overstates a later case.
    let _ = std::fs::write("/proc/self/clear_refs", "5");
}

/// Peak resident memory since the last [`reset_peak`], MiB.
pub fn peak_mib() -> Option<f64> {
    status_mib("VmHWM:")
}

/// Resident memory now, MiB.
pub fn resident_mib() -> Option<f64> {
    status_mib("VmRSS:")
}

/// The `/proc/self/status` field `name` (a size in KiB), MiB.
fn status_mib(name: &str) -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with(name))?;
    let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib / 1024.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_large_allocation_raises_the_peak() {
        reset_peak();
        let Some(before) = peak_mib() else { return }; // not Linux
        // Touched pages only count: fill 64 MiB, and keep the optimiser from
        // removing it.
        let block = std::hint::black_box(vec![1u8; 64 << 20]);
        let after = peak_mib().unwrap();
        assert!(after >= before + 60.0, "{before} -> {after} MiB ({} bytes)", block.len());
    }
}

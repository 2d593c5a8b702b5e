//! Memory figures of this process for the benchmarks' per-vehicle reports.

/// Resident set size, bytes (Linux; 0 elsewhere). Includes what the allocator
/// keeps in reserve (per-thread arenas, freed pages not yet returned), so a
/// difference of two readings moves with allocator state, not only with data.
pub fn resident_bytes() -> u64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmRSS:"))
                .and_then(|l| l.split_whitespace().nth(1)?.parse::<u64>().ok())
        })
        .map_or(0, |kib| kib * 1024)
}

/// Bytes handed out by the allocator and not yet freed, over every arena and
/// the blocks it maps on its own: the data itself, without the reserve that
/// [`resident_bytes`] also counts. `None` where glibc's `mallinfo2` is missing.
pub fn heap_bytes() -> Option<u64> {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    {
        // SAFETY: mallinfo2 takes no arguments and only reads the allocator's
        // own statistics under its locks.
        let info = unsafe { libc::mallinfo2() };
        Some((info.uordblks + info.hblkhd) as u64)
    }
    #[cfg(not(all(target_os = "linux", target_env = "gnu")))]
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn heap_bytes_follow_a_live_allocation() {
        let Some(before) = heap_bytes() else {
            return;
        };
        // black_box: an allocation nothing reads may otherwise be left out.
        let block = std::hint::black_box(vec![1u8; 8 << 20]);
        let during = heap_bytes().expect("available once");
        assert!(
            during >= before + (8 << 20),
            "8 MiB live: {before} -> {during}"
        );
        drop(block);
        let after = heap_bytes().expect("available once");
        assert!(
            after + (8 << 20) <= during,
            "8 MiB freed: {during} -> {after}"
        );
    }
}

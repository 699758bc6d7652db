//! Peak resident memory of this process, for `linkgi solve` and `bench`.
//!
//! Linux: `VmHWM` ("high water mark" of the resident set) from
//! `/proc/self/status`, reset by writing `5` to `/proc/self/clear_refs`, so
//! each benchmarked scene gets its own peak. Elsewhere both report nothing.
//! Units: bytes.

/// Resets the peak to the current resident size; false where that is not possible.
pub fn reset_peak() -> bool {
    std::fs::write("/proc/self/clear_refs", "5").is_ok()
}

/// Peak resident memory since the start or the last [`reset_peak`], bytes.
pub fn peak_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn peak_grows_with_a_large_allocation_and_resets() {
        let Some(before) = peak_bytes() else { return }; // not Linux
        let big = std::hint::black_box(vec![1u8; 64 << 20]); // not optimized away in release
        let after = peak_bytes().unwrap();
        assert!(after >= before.max(64 << 20), "peak {after} after touching 64 MiB (before {before})");
        drop(big);
        if reset_peak() {
            assert!(peak_bytes().unwrap() < after, "the peak did not reset after freeing 64 MiB");
        }
    }
}

//! The memory this process may still take, from the real resources: the address-space limit
//! (`RLIMIT_AS`, as `ulimit -v`, containers and batch systems set it), the cgroup's memory limit and
//! the physical RAM, less what the process already holds (the scene, its textures, a reference image).
//!
//! An allocation past `RLIMIT_AS` does not fail politely: Rust's allocator aborts. So whatever is large
//! and sized by user input — an image, a texture, a photon or cache file — is measured against
//! [`address_space_left`] before it is allocated, and refused with both numbers instead.
//!
//! This is an FFI module (`getrlimit`); its one `unsafe` call reads a struct the kernel fills.

/// Address space kept back from the estimates for what no estimate counts: the allocator's per-thread
/// arenas and the threads' stacks (per thread).
pub const RESERVE_PER_THREAD: u64 = 64 << 20;

/// The process's address-space limit in bytes (`RLIMIT_AS`, soft), `None` when unlimited.
pub fn address_space_limit() -> Option<u64> {
    let mut lim = libc::rlimit {
        rlim_cur: 0,
        rlim_max: 0,
    };
    // SAFETY: `lim` is a valid, writable rlimit for the duration of the call.
    let rc = unsafe { libc::getrlimit(libc::RLIMIT_AS, &mut lim) };
    #[allow(clippy::unnecessary_cast)] // rlim_t is u64 here, not on every target
    let soft = lim.rlim_cur as u64;
    (rc == 0 && lim.rlim_cur != libc::RLIM_INFINITY).then_some(soft)
}

/// A `Vm…:` line of /proc/self/status, in bytes.
fn own_status(key: &str) -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let kib: u64 = status
        .lines()
        .find(|l| l.starts_with(key))?
        .split_whitespace()
        .nth(1)?
        .parse()
        .ok()?;
    Some(kib.saturating_mul(1024))
}

/// Bytes the process holds in RAM now (`VmRSS`; 0 when unknown).
pub fn resident() -> u64 {
    own_status("VmRSS:").unwrap_or(0)
}

/// Address space the process may still map: `RLIMIT_AS` less what is mapped now (`VmSize`) and a
/// reserve of [`RESERVE_PER_THREAD`] per worker thread; `None` when there is no limit.
pub fn address_space_left() -> Option<u64> {
    let limit = address_space_limit()?;
    let mapped = own_status("VmSize:").unwrap_or(0);
    let reserve = RESERVE_PER_THREAD * rayon::current_num_threads() as u64;
    Some(limit.saturating_sub(mapped).saturating_sub(reserve))
}

/// The physical RAM (`MemTotal`), or the cgroup's memory limit when smaller (v2 `memory.max`, v1
/// `memory.limit_in_bytes`); `None` when /proc/meminfo cannot be read.
pub fn physical_memory() -> Option<u64> {
    let meminfo = std::fs::read_to_string("/proc/meminfo").ok()?;
    let kib: u64 = meminfo
        .lines()
        .find(|l| l.starts_with("MemTotal:"))?
        .split_whitespace()
        .nth(1)?
        .parse()
        .ok()?;
    let ram = kib.saturating_mul(1024);
    Some(cgroup_limit().map_or(ram, |c| c.min(ram)))
}

/// The memory limit of the cgroup the process runs in ("max" reads as none).
fn cgroup_limit() -> Option<u64> {
    [
        "/sys/fs/cgroup/memory.max",
        "/sys/fs/cgroup/memory/memory.limit_in_bytes",
    ]
    .iter()
    .filter_map(|p| std::fs::read_to_string(p).ok()?.trim().parse::<u64>().ok())
    .min()
}

/// Refuses `bytes` more for `what` when they do not fit in the address space left (with both numbers
/// and the way to raise the limit); `Ok` when there is no limit.
pub fn check_address_space(what: &str, bytes: u64) -> Result<(), String> {
    match address_space_left() {
        Some(left) if bytes > left => Err(format!(
            "{what} needs about {}, more than the {} of address space left under the process's \
             limit of {} (ulimit -v)",
            human(bytes),
            human(left),
            human(address_space_limit().unwrap_or(0))
        )),
        _ => Ok(()),
    }
}

pub fn human(bytes: u64) -> String {
    let b = bytes as f64;
    match bytes {
        0..=1_048_575 => format!("{:.0} KiB", b / 1024.0),
        1_048_576..=1_073_741_823 => format!("{:.0} MiB", b / 1_048_576.0),
        _ => format!("{:.1} GiB", b / 1_073_741_824.0),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_process_reads_its_own_memory() {
        assert!(resident() > 0);
        assert!(physical_memory().is_some_and(|b| b > 0));
        if let Some(limit) = address_space_limit() {
            assert!(address_space_left().unwrap() < limit);
        }
    }
}

//! One memory budget for everything a process holds: what inputs decode
//! into (textures, environment maps, EXR images, meshes) and what a render
//! will hold (film, tiles, output buffers). Sizes are checked when they are
//! declared, before they are allocated, so a 64 KB PNG that declares
//! 23000×23000 texels is refused with a message instead of aborting the
//! process in an allocator.
//!
//! The budget is `--max-memory` where given, else the least of what the
//! process may still use when it starts: the memory the system reports
//! available, the address space under `ulimit -v` (RLIMIT_AS), and what
//! its cgroup's `memory.max` leaves (containers, Slurm). Loading a scene tallies what
//! its inputs hold on the loading thread ([`tallying`]), so that a thousand
//! textures that each fit cannot add up to more than the budget.

use std::cell::Cell;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::OnceLock;

/// `--max-memory`, in bytes; 0 when not given.
static LIMIT: AtomicU64 = AtomicU64::new(0);

/// Where no figure for available memory can be had (no /proc/meminfo).
const FALLBACK_LIMIT: u64 = 16 << 30;

thread_local! {
    /// While `tallying`: the budget and what is held against it so far.
    static TALLY: Cell<Option<(u64, u64)>> = const { Cell::new(None) };
    /// While `tallying`: the most held at once, counting what `check`
    /// allowed briefly on top (decoders' buffers).
    static PEAK: Cell<u64> = const { Cell::new(0) };
}

/// Lets the process's threads share two of glibc's malloc arenas. Each
/// thread that meets a busy arena otherwise makes one more, and each
/// reserves 64 MiB of address space that `ulimit -v` counts, though a
/// render allocates nothing per ray (its threads allocate at the start of
/// tiles and subtrees): a 16-thread render could reserve a gigabyte it
/// never uses. Elsewhere a no-op.
pub fn share_allocator_arenas() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: mallopt only changes a setting of the allocator; it is
    // called before any thread but the main one exists.
    unsafe {
        libc::mallopt(libc::M_ARENA_MAX, 2);
    }
}

/// Sets the budget for the rest of the process (`--max-memory`).
pub fn set_limit(bytes: u64) {
    LIMIT.store(bytes.max(1), Ordering::Relaxed);
}

/// The budget in bytes, and where it comes from (for messages).
pub fn limit() -> (u64, &'static str) {
    match LIMIT.load(Ordering::Relaxed) {
        0 => available().unwrap_or((FALLBACK_LIMIT, "the memory available")),
        set => (set, "--max-memory"),
    }
}

/// The least of the limits the process lives under, with its name: read
/// once, when first asked, so that the process's own allocations do not
/// shrink it.
fn available() -> Option<(u64, &'static str)> {
    static AVAILABLE: OnceLock<Option<(u64, &'static str)>> = OnceLock::new();
    *AVAILABLE.get_or_init(|| {
        [
            mem_available().map(|b| (b, "the memory available")),
            address_space_left().map(|b| (b, "the address space left under `ulimit -v`")),
            cgroup_left().map(|b| (b, "what the cgroup's memory.max leaves")),
        ]
        .into_iter()
        .flatten()
        .min_by_key(|&(bytes, _)| bytes)
    })
}

/// MemAvailable of /proc/meminfo.
fn mem_available() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// Address space each worker thread reserves without touching it: its
/// stack, and the allocator arena glibc maps for it (64 MiB).
const RESERVED_PER_THREAD: u64 = 72 << 20;

/// RLIMIT_AS (`ulimit -v`) less the address space mapped now and what the
/// worker threads will reserve; None when unlimited.
fn address_space_left() -> Option<u64> {
    let limits = std::fs::read_to_string("/proc/self/limits").ok()?;
    let line = limits
        .lines()
        .find(|l| l.starts_with("Max address space"))?;
    let soft: u64 = line.split_whitespace().nth(3)?.parse().ok()?;
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let mapped_kib: u64 = status
        .lines()
        .find(|l| l.starts_with("VmSize:"))?
        .split_whitespace()
        .nth(1)?
        .parse()
        .ok()?;
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get()) as u64;
    Some(
        soft.saturating_sub(mapped_kib * 1024)
            .saturating_sub(threads * RESERVED_PER_THREAD),
    )
}

/// The least that `memory.max` less `memory.current` leaves over the
/// process's cgroup and its ancestors (cgroup v2), or the v1 memory
/// controller's limit less its usage; None without a limit.
fn cgroup_left() -> Option<u64> {
    let cgroups = std::fs::read_to_string("/proc/self/cgroup").ok()?;
    let left = |dir: &std::path::Path, max: &str, current: &str| -> Option<u64> {
        let read = |f: &str| std::fs::read_to_string(dir.join(f)).ok();
        let max: u64 = read(max)?.trim().parse().ok()?; // "max": no limit
        let current: u64 = read(current)?.trim().parse().ok()?;
        // v1 writes "no limit" as a number near 2⁶³.
        (max < 1 << 60).then(|| max.saturating_sub(current))
    };
    let mut least: Option<u64> = None;
    for line in cgroups.lines() {
        let mut fields = line.splitn(3, ':');
        let (_, controllers, path) = (fields.next()?, fields.next()?, fields.next()?);
        let (root, max, current) = match controllers {
            "" => ("/sys/fs/cgroup", "memory.max", "memory.current"),
            c if c.split(',').any(|c| c == "memory") => (
                "/sys/fs/cgroup/memory",
                "memory.limit_in_bytes",
                "memory.usage_in_bytes",
            ),
            _ => continue,
        };
        let mut dir = std::path::PathBuf::from(root);
        dir.push(path.trim_start_matches('/'));
        // The group and each ancestor up to the hierarchy's root.
        for ancestor in dir.ancestors().take_while(|d| d.starts_with(root)) {
            if let Some(l) = left(ancestor, max, current) {
                least = Some(least.map_or(l, |m| m.min(l)));
            }
        }
    }
    least
}

/// Runs `f` with a fresh tally against `budget`; where None, against what
/// the enclosing tally has left, or else the process's budget. Returns
/// `f`'s result and the bytes it declared it holds (which the enclosing
/// tally then holds too).
pub fn tallying<T>(budget: Option<u64>, f: impl FnOnce() -> T) -> (T, u64) {
    let outer = TALLY.with(Cell::get);
    let limit = budget.unwrap_or_else(|| match outer {
        Some((limit, held)) => limit.saturating_sub(held),
        None => limit().0,
    });
    TALLY.with(|t| t.set(Some((limit, 0))));
    let outer_peak = PEAK.with(|p| p.replace(0));
    let result = f();
    PEAK.with(|p| p.set(outer_peak.max(p.get())));
    let (_, held) = TALLY.with(|t| t.replace(outer)).expect("tally set above");
    TALLY.with(|t| {
        if let Some((limit, outer_held)) = outer {
            t.set(Some((limit, outer_held.saturating_add(held))));
        }
    });
    (result, held)
}

/// The most the current tally has held at once, with what `check` let
/// callers use briefly on top.
pub fn peak() -> u64 {
    PEAK.with(Cell::get).max(held())
}

/// What the current tally holds (0 outside one).
pub fn held() -> u64 {
    TALLY.with(Cell::get).map_or(0, |(_, held)| held)
}

/// Records that `what` will hold `bytes` from now on; refuses (before the
/// caller allocates) if that takes the tally over the budget.
pub fn hold(what: &str, bytes: u64) -> Result<(), String> {
    check(what, bytes)?;
    TALLY.with(|t| {
        if let Some((limit, held)) = t.get() {
            t.set(Some((limit, held.saturating_add(bytes))));
        }
    });
    Ok(())
}

/// Checks that `what` may briefly use `bytes` on top of what is held
/// (decoding buffers, conversions), without recording it.
pub fn check(what: &str, bytes: u64) -> Result<(), String> {
    let (process_limit, source) = limit();
    let (limit, held) = TALLY.with(Cell::get).unwrap_or((process_limit, 0));
    if held.saturating_add(bytes) <= limit {
        PEAK.with(|p| p.set(p.get().max(held.saturating_add(bytes))));
        return Ok(());
    }
    let already = if held > 0 {
        format!(" on top of the {} already loaded", for_people(held))
    } else {
        String::new()
    };
    Err(format!(
        "{what} would need {}{already}, more than the memory budget ({source}) of {}",
        for_people(bytes),
        for_people(limit)
    ))
}

/// A byte count for people: KiB, MiB or GiB.
pub fn for_people(bytes: u64) -> String {
    let b = bytes as f64;
    if b < (1 << 20) as f64 {
        format!("{:.1} KiB", b / 1024.0)
    } else if b < (1 << 30) as f64 {
        format!("{:.1} MiB", b / (1 << 20) as f64)
    } else {
        format!("{:.2} GiB", b / (1 << 30) as f64)
    }
}

/// Parses a size for people: `512M`, `8G`, `1.5GiB`, `2000000` (bytes).
pub fn parse_size(text: &str) -> Result<u64, String> {
    let t = text.trim();
    let split = t
        .find(|c: char| !(c.is_ascii_digit() || c == '.'))
        .unwrap_or(t.len());
    let (number, unit) = t.split_at(split);
    let value: f64 = number
        .parse()
        .map_err(|_| format!("expected a size such as 512M or 8G, found `{text}`"))?;
    let scale = match unit.trim().to_ascii_lowercase().as_str() {
        "" | "b" => 1u64,
        "k" | "kb" | "kib" => 1 << 10,
        "m" | "mb" | "mib" => 1 << 20,
        "g" | "gb" | "gib" => 1 << 30,
        "t" | "tb" | "tib" => 1 << 40,
        _ => return Err(format!("unknown unit in `{text}`: use K, M, G or T")),
    };
    let bytes = value * scale as f64;
    if !(bytes >= 1.0 && bytes < u64::MAX as f64) {
        return Err(format!("`{text}` is not a usable memory size"));
    }
    Ok(bytes as u64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse() {
        assert_eq!(parse_size("512M"), Ok(512 << 20));
        assert_eq!(parse_size("1.5GiB"), Ok(3 << 29));
        assert_eq!(parse_size("2000"), Ok(2000));
        assert!(parse_size("lots").is_err());
        assert!(parse_size("0").is_err());
        assert!(parse_size("3X").is_err());
    }

    #[test]
    fn a_tally_refuses_what_adds_up_past_its_limit() {
        let ((first, second, third), held) = tallying(Some(1000), || {
            (hold("a", 600), hold("b", 600), hold("c", 400))
        });
        assert!(first.is_ok() && third.is_ok());
        let e = second.unwrap_err();
        assert!(e.starts_with("b would need 0.6 KiB"), "{e}");
        assert!(e.contains("already loaded"), "{e}");
        assert_eq!(held, 1000);
        // Outside the tally, nothing is held.
        assert!(check("d", 1000).is_ok());
        // A tally inside another gets what the outer one has left.
        let ((inner, held_inner), held) = tallying(Some(1000), || {
            hold("a", 300).unwrap();
            tallying(None, || hold("b", 800))
        });
        let e = inner.unwrap_err();
        assert!(e.contains(") of 0.7 KiB"), "{e}");
        assert_eq!((held_inner, held), (0, 300));
    }
}

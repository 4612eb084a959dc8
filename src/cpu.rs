//! The CPU features the binary was compiled for (`.cargo/config.toml` asks
//! for x86-64-v3 on x86-64) against those of the CPU it runs on: compiled
//! code may use any of them anywhere, so a CPU without one would stop at
//! the first such instruction with SIGILL. `refuse_if_missing` runs the
//! embedded baseline build instead, or says so and exits, before any of
//! that code runs.
//!
//! The CPU is asked with CPUID itself: `is_x86_feature_detected!` answers
//! `true` without asking for a feature the build enables.
//!
//! `cargo build --release` compiles the whole program for x86-64-v3 and,
//! in `build.rs`, a second time for baseline x86-64, which it embeds:
//! `refuse_if_missing` runs that one on a CPU without AVX2, so the binary
//! runs on any x86-64 CPU.

use std::io::Write;

/// The instruction set the whole program was compiled for: on x86-64,
/// x86-64-v3 (AVX2, `.cargo/config.toml`) or, in the build `build.rs`
/// embeds for older CPUs, baseline x86-64.
pub const COMPILED_FOR: &str = if cfg!(not(target_arch = "x86_64")) {
    std::env::consts::ARCH
} else if IS_BASELINE_BUILD {
    "x86-64"
} else {
    "x86-64-v3"
};

/// This is the baseline x86-64 build (the one `build.rs` embeds), not the
/// x86-64-v3 build that carries it.
pub const IS_BASELINE_BUILD: bool = cfg!(target_arch = "x86_64") && !cfg!(target_feature = "avx2");

/// A feature: its name (as `target_feature` spells it), whether this build
/// uses it, and whether the running CPU (and its OS) has it.
#[derive(Clone, Copy, Debug)]
pub struct Feature {
    pub name: &'static str,
    pub compiled: bool,
    pub present: bool,
}

impl Feature {
    /// Compiled in, but the CPU lacks it.
    pub fn missing(&self) -> bool {
        self.compiled && !self.present
    }
}

/// The features of x86-64-v2/v3 (and AVX-512F) this build may use.
#[cfg(target_arch = "x86_64")]
pub fn features() -> [Feature; 14] {
    use std::arch::x86_64::{__cpuid, __cpuid_count};
    // SAFETY: every x86-64 CPU has CPUID; the leaves asked are below the
    // maxima it reports, and XGETBV is run only where OSXSAVE says the OS
    // enabled it.
    #[allow(unused_unsafe)]
    let (l1, l7, ext, xcr0) = unsafe {
        let max = __cpuid(0).eax;
        let l1 = __cpuid(1);
        let l7 = if max >= 7 {
            Some(__cpuid_count(7, 0))
        } else {
            None
        };
        let ext = if __cpuid(0x8000_0000).eax >= 0x8000_0001 {
            Some(__cpuid(0x8000_0001))
        } else {
            None
        };
        let osxsave = l1.ecx & (1 << 27) != 0;
        let xcr0 = if osxsave { xgetbv0() } else { 0 };
        (l1, l7, ext, xcr0)
    };
    let bit = |reg: u32, b: u32| reg & (1 << b) != 0;
    // The OS saves the SSE and AVX registers (XCR0 bits 1, 2), and those of
    // AVX-512 (bits 5–7), across context switches.
    let os_avx = xcr0 & 0b110 == 0b110;
    let os_avx512 = os_avx && xcr0 & 0b1110_0000 == 0b1110_0000;
    let (b7, c_ext) = (l7.map_or(0, |r| r.ebx), ext.map_or(0, |r| r.ecx));
    let f = |name, compiled, present| Feature {
        name,
        compiled,
        present,
    };
    [
        f("sse3", cfg!(target_feature = "sse3"), bit(l1.ecx, 0)),
        f("ssse3", cfg!(target_feature = "ssse3"), bit(l1.ecx, 9)),
        f("sse4.1", cfg!(target_feature = "sse4.1"), bit(l1.ecx, 19)),
        f("sse4.2", cfg!(target_feature = "sse4.2"), bit(l1.ecx, 20)),
        f("popcnt", cfg!(target_feature = "popcnt"), bit(l1.ecx, 23)),
        f("movbe", cfg!(target_feature = "movbe"), bit(l1.ecx, 22)),
        f("lzcnt", cfg!(target_feature = "lzcnt"), bit(c_ext, 5)),
        f("bmi1", cfg!(target_feature = "bmi1"), bit(b7, 3)),
        f("bmi2", cfg!(target_feature = "bmi2"), bit(b7, 8)),
        f(
            "avx",
            cfg!(target_feature = "avx"),
            bit(l1.ecx, 28) && os_avx,
        ),
        f(
            "f16c",
            cfg!(target_feature = "f16c"),
            bit(l1.ecx, 29) && os_avx,
        ),
        f(
            "fma",
            cfg!(target_feature = "fma"),
            bit(l1.ecx, 12) && os_avx,
        ),
        f("avx2", cfg!(target_feature = "avx2"), bit(b7, 5) && os_avx),
        f(
            "avx512f",
            cfg!(target_feature = "avx512f"),
            bit(b7, 16) && os_avx512,
        ),
    ]
}

/// XCR0, the register of the state components the OS saves.
#[cfg(target_arch = "x86_64")]
#[cfg(target_feature = "xsave")]
unsafe fn xgetbv0() -> u64 {
    // SAFETY: the caller checked OSXSAVE.
    unsafe { std::arch::x86_64::_xgetbv(0) }
}

/// XCR0 read by hand where the build does not enable XSAVE.
#[cfg(target_arch = "x86_64")]
#[cfg(not(target_feature = "xsave"))]
unsafe fn xgetbv0() -> u64 {
    let (eax, edx): (u32, u32);
    // SAFETY: the caller checked OSXSAVE; XGETBV only reads XCR0.
    unsafe {
        std::arch::asm!("xgetbv", in("ecx") 0, out("eax") eax, out("edx") edx,
            options(nomem, nostack, preserves_flags));
    }
    (edx as u64) << 32 | eax as u64
}

#[cfg(not(target_arch = "x86_64"))]
pub fn features() -> [Feature; 0] {
    []
}

/// Writes why the binary cannot run here, if it cannot: plain writes of
/// static text (no formatting), as little compiled code as can be.
pub fn write_refusal(features: &[Feature], out: &mut impl Write) -> bool {
    let mut missing = features.iter().filter(|f| f.missing());
    let Some(first) = missing.next() else {
        return false;
    };
    let _ = out.write_all(b"error: this CPU lacks ");
    let _ = out.write_all(first.name.as_bytes());
    for f in missing {
        let _ = out.write_all(b", ");
        let _ = out.write_all(f.name.as_bytes());
    }
    let _ = out.write_all(
        b", which this build of prism was compiled to use everywhere (RUSTFLAGS \
          -C target-cpu or target-feature); build it with plain cargo build --release, \
          which runs on any x86-64 CPU, or with RUSTFLAGS=\"-C target-cpu=native\" on this one\n",
    );
    true
}

/// Where the CPU lacks a feature the build uses, runs the embedded baseline
/// build in this process's place, or, where there is none or it cannot be
/// started, exits with status 1 and the message of `write_refusal`. Call it
/// first in `main`.
#[inline(never)]
pub fn refuse_if_missing() {
    let features = features();
    if !features.iter().any(Feature::missing) {
        return;
    }
    if BASELINE_EMBEDDED {
        let _ = exec_baseline();
        let _ = std::io::stderr().write_all(b"error: the embedded baseline build did not start\n");
    }
    if write_refusal(&features, &mut std::io::stderr()) {
        std::process::exit(1);
    }
}

/// Whether this binary carries a build of itself for baseline x86-64
/// (build.rs: release builds for x86-64 Linux).
pub const BASELINE_EMBEDDED: bool = cfg!(prism_baseline_embedded);

/// Replaces this process with the embedded baseline build, with the same
/// arguments and environment. Returns only where that fails.
#[cfg(prism_baseline_embedded)]
pub fn exec_baseline() -> std::io::Error {
    static BINARY: &[u8] = include_bytes!(env!("PRISM_BASELINE_BINARY"));
    let (argv, envp) = startup::arguments();
    if argv.is_null() || envp.is_null() {
        return std::io::Error::other("no arguments from the C runtime");
    }
    // SAFETY: plain system calls on a file this function creates; argv
    // and envp are the C runtime's, null-terminated and never freed.
    unsafe {
        let fd = libc::memfd_create(c"prism-x86-64".as_ptr(), libc::MFD_CLOEXEC);
        if fd < 0 {
            return std::io::Error::last_os_error();
        }
        let mut rest = BINARY;
        while !rest.is_empty() {
            let n = libc::write(fd, rest.as_ptr().cast(), rest.len());
            if n <= 0 {
                return std::io::Error::last_os_error();
            }
            rest = &rest[n as usize..];
        }
        libc::fexecve(fd, argv, envp);
    }
    std::io::Error::last_os_error()
}

#[cfg(not(prism_baseline_embedded))]
pub fn exec_baseline() -> std::io::Error {
    std::io::Error::other("this build of prism carries no baseline build")
}

/// The arguments and environment as the C runtime passed them, before
/// anything ran: glibc calls each function of `.init_array` with argc,
/// argv and envp. Kept as the C runtime's pointers, so that running the
/// baseline build needs no allocation and no code that may use
/// instructions the CPU lacks.
#[cfg(prism_baseline_embedded)]
mod startup {
    use std::ffi::{c_char, c_int};
    use std::sync::atomic::{AtomicPtr, Ordering};

    static ARGV: AtomicPtr<*const c_char> = AtomicPtr::new(std::ptr::null_mut());
    static ENVP: AtomicPtr<*const c_char> = AtomicPtr::new(std::ptr::null_mut());

    #[used]
    #[link_section = ".init_array"]
    static CAPTURE: extern "C" fn(c_int, *const *const c_char, *const *const c_char) = capture;

    extern "C" fn capture(_argc: c_int, argv: *const *const c_char, envp: *const *const c_char) {
        ARGV.store(argv.cast_mut(), Ordering::Relaxed);
        ENVP.store(envp.cast_mut(), Ordering::Relaxed);
    }

    pub fn arguments() -> (*const *const c_char, *const *const c_char) {
        (
            ARGV.load(Ordering::Relaxed).cast_const(),
            ENVP.load(Ordering::Relaxed).cast_const(),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn feature(name: &'static str, compiled: bool, present: bool) -> Feature {
        Feature {
            name,
            compiled,
            present,
        }
    }

    #[test]
    fn a_cpu_without_a_compiled_feature_is_refused_with_the_way_to_rebuild() {
        let mut out = Vec::new();
        let ok = [
            feature("avx2", true, true),
            feature("avx512f", false, false),
        ];
        assert!(!write_refusal(&ok, &mut out));
        assert!(out.is_empty());
        let old = [
            feature("sse4.2", true, true),
            feature("avx2", true, false),
            feature("fma", true, false),
            feature("avx512f", false, false),
        ];
        assert!(write_refusal(&old, &mut out));
        let message = String::from_utf8(out).unwrap();
        assert!(
            message.starts_with("error: this CPU lacks avx2, fma, which"),
            "{message}"
        );
        assert!(message.contains("target-cpu=native"), "{message}");
    }

    /// CPUID agrees with std's detection for every feature the build does
    /// not enable (std answers `true` without asking for the others), and
    /// the machine running the tests has every feature the build enables.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn cpuid_agrees_with_std_and_this_machine_has_the_build_features() {
        macro_rules! detected {
            ($name:expr, $($feature:tt),*) => {
                match $name { $($feature => std::arch::is_x86_feature_detected!($feature),)* _ => unreachable!() }
            };
        }
        for f in features() {
            let std_says = detected!(
                f.name, "sse3", "ssse3", "sse4.1", "sse4.2", "popcnt", "movbe", "lzcnt", "bmi1",
                "bmi2", "avx", "f16c", "fma", "avx2", "avx512f"
            );
            if !f.compiled {
                assert_eq!(f.present, std_says, "{}", f.name);
            } else {
                assert!(f.present, "{} is compiled in but CPUID lacks it", f.name);
            }
        }
    }
}

//! The CPU features the binary was compiled for (`.cargo/config.toml` asks
//! for x86-64-v3 on x86-64) against those of the CPU it runs on: compiled
//! code may use any of them anywhere, so a CPU without one would stop at the
//! first such instruction with SIGILL. `missing_features` lets `main` say so
//! before any of that code runs.

/// The features this binary was compiled to use that the running CPU lacks.
pub fn missing_features() -> Vec<&'static str> {
    #[allow(unused_mut)]
    let mut missing = Vec::new();
    #[cfg(target_arch = "x86_64")]
    {
        macro_rules! check {
            ($($feature:tt),*) => {$(
                if cfg!(target_feature = $feature) && !std::arch::is_x86_feature_detected!($feature) {
                    missing.push($feature);
                }
            )*};
        }
        check!(
            "sse3", "ssse3", "sse4.1", "sse4.2", "popcnt", "avx", "avx2", "fma", "bmi1", "bmi2",
            "lzcnt", "f16c", "movbe", "avx512f"
        );
    }
    missing
}

/// What `main` prints and exits with when the CPU lacks `missing`.
pub fn refusal(missing: &[&str]) -> Option<String> {
    if missing.is_empty() {
        return None;
    }
    Some(format!(
        "this CPU lacks {}, which this build of prism uses (x86-64-v3, set in \
         .cargo/config.toml); build it for this CPU with \
         RUSTFLAGS=\"-C target-cpu=native\" cargo build --release",
        missing.join(", ")
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_cpu_without_a_compiled_feature_is_refused_with_the_way_to_rebuild() {
        assert_eq!(refusal(&[]), None);
        let message = refusal(&["avx2", "fma"]).unwrap();
        assert!(message.contains("lacks avx2, fma"), "{message}");
        assert!(message.contains("target-cpu=native"), "{message}");
        // The machine running the tests runs them, so it has every feature.
        assert_eq!(missing_features(), Vec::<&str>::new());
    }
}

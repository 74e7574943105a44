//! Test support shared by the modules' unit tests (compiled for tests only).

/// Uniform numbers in [0, 1) from a fixed 64-bit LCG (Knuth's MMIX constants) seeded by `seed`:
/// reproducible inputs for accuracy tests against naive references, the same on every machine.
pub fn lcg_uniform(seed: u64) -> impl FnMut() -> f64 {
    let mut s = seed;
    move || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (s >> 11) as f64 / (1u64 << 53) as f64
    }
}

//! See `benches/kernels.rs`.

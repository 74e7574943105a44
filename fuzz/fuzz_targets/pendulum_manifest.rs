//! Fuzzes `bikeproc::fuzzing::pendulum_manifest`: see that module.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| bikeproc::fuzzing::pendulum_manifest(data));

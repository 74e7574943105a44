//! Fuzzes `bikeproc::fuzzing::ride_manifest`: see that module.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| bikeproc::fuzzing::ride_manifest(data));

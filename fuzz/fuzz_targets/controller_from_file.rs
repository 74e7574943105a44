//! Fuzzes `bikeproc::fuzzing::controller_from_file`: see that module.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| bikeproc::fuzzing::controller_from_file(data));

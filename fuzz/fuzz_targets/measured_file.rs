//! Fuzzes `bikeproc::fuzzing::measured_file`: see that module.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| bikeproc::fuzzing::measured_file(data));

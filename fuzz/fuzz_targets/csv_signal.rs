//! Fuzzes `bikeproc::fuzzing::csv_signal`: see that module.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| bikeproc::fuzzing::csv_signal(data));

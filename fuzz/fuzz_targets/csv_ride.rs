//! Fuzzes `bikeproc::fuzzing::csv_ride`: see that module.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| bikeproc::fuzzing::csv_ride(data));

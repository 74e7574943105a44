//! Fuzzes `bikeproc::fuzzing::lab_bike`: see that module.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| bikeproc::fuzzing::lab_bike(data));

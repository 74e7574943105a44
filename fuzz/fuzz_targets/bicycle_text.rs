//! Fuzzes `bikeproc::fuzzing::bicycle_text`: see that module.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| bikeproc::fuzzing::bicycle_text(data));

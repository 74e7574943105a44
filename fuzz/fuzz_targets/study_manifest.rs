//! Fuzzes `bikeproc::fuzzing::study_manifest`: see that module.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| bikeproc::fuzzing::study_manifest(data));

#![no_main]
// See tests/src/fuzz.rs for what this target checks.
libfuzzer_sys::fuzz_target!(|data: &[u8]| farm_tests::fuzz::image(data));

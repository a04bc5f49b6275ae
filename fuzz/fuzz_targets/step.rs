//! cargo-fuzz target: see `diffosi_fuzz::check_step`.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| diffosi_fuzz::check_step(data));

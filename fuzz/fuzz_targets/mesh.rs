//! cargo-fuzz target: see `diffosi_fuzz::check_mesh`.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| diffosi_fuzz::check_mesh(data));

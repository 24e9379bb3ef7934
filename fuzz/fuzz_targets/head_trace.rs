#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| optica_fuzz::head_trace(data));

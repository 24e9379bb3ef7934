#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| optica_fuzz::cave_datagram(data));

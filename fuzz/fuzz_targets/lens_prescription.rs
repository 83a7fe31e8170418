#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| camsim_tests::fuzz_bodies::lens_prescription(data));

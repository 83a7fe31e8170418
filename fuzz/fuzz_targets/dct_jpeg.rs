#![no_main]

// Depends on raw-formats alone: no tracer, no command line.
libfuzzer_sys::fuzz_target!(|data: &[u8]| raw_formats::fuzzing::dct_jpeg_decode(data));

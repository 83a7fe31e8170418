//! Bodies of this crate's fuzz targets. `fuzz/` runs them under libFuzzer (so the DNG target
//! depends on this crate alone) and the test suite runs them on random bytes and on the
//! committed corpus; each panics only if the decoder broke its contract.

use crate::dng::Dng;

/// DNG files: any bytes are a frame or an error (never a panic or a huge allocation); a frame
/// that decodes is consistent (as many samples as pixels, black below white) and encodes back to
/// bytes that decode to the same frame.
pub fn dng_decode(data: &[u8]) {
    if let Ok(dng) = Dng::decode(data) {
        let image = &dng.image;
        assert_eq!(image.samples.len(), image.width * image.height);
        assert!(image.black_level.iter().all(|b| *b < image.white_level));
        // The writer refuses only what it cannot express (e.g. a neutral below 1e-6).
        if let Ok(bytes) = dng.encode() {
            let back = Dng::decode(&bytes).expect("the writer's output decodes");
            assert_eq!(back.image, dng.image);
        }
    }
}

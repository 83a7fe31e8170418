//! The board's memory map for cortex-m-rt's `link.x`, by target: QEMU's mps2-an386 for the
//! Cortex-M4F (thumbv7em), mps2-an505 for the Cortex-M33 (thumbv8m.main), whose secure-state
//! reset reads the vector table at 0x1000_0000 and whose secure SRAM alias is at 0x3800_0000.
//! Also links with cortex-m-rt's script here rather than in `.cargo/config.toml`, where a
//! `RUSTFLAGS` in the environment (`-D warnings` in CI) would replace it.
use std::path::PathBuf;

fn main() {
    let target = std::env::var("TARGET").unwrap_or_default();
    let memory = if target.starts_with("thumbv8m.main") {
        "MEMORY\n{\n  FLASH : ORIGIN = 0x10000000, LENGTH = 4M\n  RAM : ORIGIN = 0x38000000, LENGTH = 2M\n}\n"
    } else {
        "MEMORY\n{\n  FLASH : ORIGIN = 0x00000000, LENGTH = 4M\n  RAM : ORIGIN = 0x20000000, LENGTH = 4M\n}\n"
    };
    let out = PathBuf::from(std::env::var("OUT_DIR").expect("cargo sets OUT_DIR"));
    std::fs::write(out.join("memory.x"), memory).expect("OUT_DIR is writable");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rustc-link-arg-bins=-Tlink.x");
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-env-changed=TARGET");
    println!("cargo:rerun-if-env-changed=CAMSIM_FIRMWARE_ONLY");
}

//! The link script for QEMU's `virt` board: RAM from 0x4000_0000 (128 MiB by default), the
//! image a little above its start (QEMU may put the device tree at the very start), the stack
//! at its top.
use std::path::PathBuf;

const LINK_SCRIPT: &str = "
ENTRY(_start)
MEMORY { RAM : ORIGIN = 0x40080000, LENGTH = 0x7F80000 }
SECTIONS
{
  .text : { KEEP(*(.text.boot)) *(.text .text.*) } > RAM
  .rodata : ALIGN(16) { *(.rodata .rodata.*) } > RAM
  .data : ALIGN(16) { *(.data .data.*) } > RAM
  .bss (NOLOAD) : ALIGN(16) { __bss_start = .; *(.bss .bss.* COMMON) . = ALIGN(16); __bss_end = .; } > RAM
  __stack_top = ORIGIN(RAM) + LENGTH(RAM);
  /DISCARD/ : { *(.ARM.exidx*) *(.eh_frame*) }
}
";

fn main() {
    let out = PathBuf::from(std::env::var("OUT_DIR").expect("cargo sets OUT_DIR"));
    std::fs::write(out.join("virt.ld"), LINK_SCRIPT).expect("OUT_DIR is writable");
    println!(
        "cargo:rustc-link-arg-bins=-T{}",
        out.join("virt.ld").display()
    );
    println!("cargo:rerun-if-changed=build.rs");
}

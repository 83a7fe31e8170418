//! Runs every firmware case at 64x48 and 128x96 on QEMU's AArch64 `virt` board and prints,
//! over semihosting, the lines `firmware_cases::report` writes (checksums and counter ticks),
//! then a calibration line (ticks of a loop of known instruction count; with QEMU's
//! `-icount shift=0` each instruction is one virtual nanosecond and the generic timer counts
//! at its fixed frequency). Exits with semihosting's status: 0 when every case ran.
#![no_std]
#![no_main]

use core::fmt;

use firmware_cases::{
    firmware_run, Buffers, FIRMWARE_MAX_PIXELS, FIRMWARE_SCRATCH_F32, FIRMWARE_SCRATCH_U16,
};

/// Iterations of the calibration loop (two instructions each).
const CALIBRATION_LOOPS: u64 = 1_000_000;

// Entered at EL1 with the MMU off: turn on the FP/SIMD unit (CPACR_EL1.FPEN), set the stack,
// zero .bss, call Rust.
core::arch::global_asm!(
    ".section .text.boot, \"ax\"",
    ".global _start",
    "_start:",
    "mrs x0, CPACR_EL1",
    "orr x0, x0, #(3 << 20)",
    "msr CPACR_EL1, x0",
    "isb",
    "ldr x0, =__stack_top",
    "mov sp, x0",
    "ldr x0, =__bss_start",
    "ldr x1, =__bss_end",
    "1: cmp x0, x1",
    "b.hs 2f",
    "str xzr, [x0], #8",
    "b 1b",
    "2: bl firmware_main",
    "3: wfe",
    "b 3b",
);

/// A semihosting call (`hlt #0xf000`): operation `op`, parameter `arg`.
fn semihosting(op: u64, arg: u64) -> u64 {
    let result;
    // SAFETY: the semihosting trap; QEMU reads the parameter block `arg` points to.
    unsafe {
        core::arch::asm!("hlt #0xf000", inout("x0") op => result, in("x1") arg, options(nostack));
    }
    result
}

/// The host's standard output through semihosting: SYS_OPEN of ":tt" for writing (mode 4),
/// then SYS_WRITE of each string (as cortex-m-semihosting does; SYS_WRITE0 goes to QEMU's
/// standard error).
struct HostOut(u64);

impl HostOut {
    fn open() -> Result<Self, fmt::Error> {
        let name = b":tt\0";
        let block = [name.as_ptr() as u64, 4, 3];
        match semihosting(0x01, block.as_ptr() as u64) {
            u64::MAX => Err(fmt::Error),
            handle => Ok(Self(handle)),
        }
    }
}

impl fmt::Write for HostOut {
    fn write_str(&mut self, s: &str) -> fmt::Result {
        let block = [self.0, s.as_ptr() as u64, s.len() as u64];
        match semihosting(0x05, block.as_ptr() as u64) {
            0 => Ok(()),
            _ => Err(fmt::Error),
        }
    }
}

/// SYS_EXIT with ADP_Stopped_ApplicationExit and `code`.
fn exit(code: u64) -> ! {
    let block = [0x20026u64, code];
    semihosting(0x18, block.as_ptr() as u64);
    loop {
        core::hint::spin_loop();
    }
}

/// The generic timer's virtual count.
fn ticks() -> u64 {
    let count: u64;
    // SAFETY: reads a system register EL1 may read.
    unsafe {
        core::arch::asm!("isb", "mrs {}, cntvct_el0", out(reg) count, options(nomem, nostack))
    };
    count
}

/// `n` iterations of a two-instruction loop (`subs`, `b.ne`).
#[inline(never)]
fn spin(n: u64) {
    // SAFETY: a register-only countdown.
    unsafe {
        core::arch::asm!("2:", "subs {n}, {n}, #1", "b.ne 2b", n = inout(reg) n => _, options(nomem, nostack));
    }
}

#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    exit(101)
}

#[no_mangle]
extern "C" fn firmware_main() -> ! {
    exit(match run() {
        Ok(true) => 0,
        _ => 1,
    })
}

fn run() -> Result<bool, fmt::Error> {
    let mut out = HostOut::open()?;
    let mut mosaic = [0u16; FIRMWARE_MAX_PIXELS];
    let mut out8 = [0u8; 3 * FIRMWARE_MAX_PIXELS];
    let mut out16 = [0u16; 3 * FIRMWARE_MAX_PIXELS];
    let mut scratch = [0u16; FIRMWARE_SCRATCH_U16];
    let mut scratch_f32 = [0f32; FIRMWARE_SCRATCH_F32];
    let mut buffers = Buffers {
        mosaic: &mut mosaic,
        out8: &mut out8,
        out16: &mut out16,
        scratch: &mut scratch,
        scratch_f32: &mut scratch_f32,
    };
    let mut calibrate = || {
        let t0 = ticks();
        spin(CALIBRATION_LOOPS);
        (2 * CALIBRATION_LOOPS, ticks() - t0)
    };
    firmware_run(&mut out, &mut buffers, &mut ticks, None, &mut calibrate)
}

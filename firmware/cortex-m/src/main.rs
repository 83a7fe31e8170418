//! Runs every firmware case at 64x48 and 128x96 and prints, over semihosting, the lines
//! `firmware_cases::report` writes (checksums and SysTick counts), then a calibration line:
//! the SysTick count of a loop of known instruction count, so that the host can turn ticks
//! into instructions (under QEMU's `-icount shift=0` each instruction takes one virtual
//! nanosecond, and SysTick counts the board's core clock). Exits with semihosting's status:
//! 0 when every case ran.
#![no_std]
#![no_main]

use core::fmt;
use core::sync::atomic::{AtomicU32, Ordering};

use cortex_m::peripheral::syst::SystClkSource;
use cortex_m_rt::{entry, exception};
use cortex_m_semihosting::{debug, hio};
use firmware_cases::{
    firmware_run, Buffers, FIRMWARE_MAX_PIXELS, FIRMWARE_SCRATCH_F32, FIRMWARE_SCRATCH_U16,
};
use panic_halt as _;

/// Set at build time (`CAMSIM_FIRMWARE_ONLY=<case>`, scripts/firmware-profile.sh), the
/// firmware runs that case alone, once, at 64x48: a short trace for QEMU's instruction log.
const ONLY: Option<&str> = option_env!("CAMSIM_FIRMWARE_ONLY");
/// Iterations of the calibration loop (two instructions each).
const CALIBRATION_LOOPS: u32 = 1_000_000;

/// SysTick wraps (every 2^24 ticks).
static WRAPS: AtomicU32 = AtomicU32::new(0);

#[exception]
fn SysTick() {
    WRAPS.fetch_add(1, Ordering::Relaxed);
}

/// Ticks since SysTick started: the wrap count and the down-counter, read until no wrap
/// happened between the two reads.
fn ticks() -> u64 {
    loop {
        let wraps = WRAPS.load(Ordering::Relaxed);
        let current = cortex_m::peripheral::SYST::get_current();
        if WRAPS.load(Ordering::Relaxed) == wraps {
            return (u64::from(wraps) << 24) + u64::from(0x00ff_ffff - current);
        }
    }
}

/// Semihosting's stdout as a `fmt::Write`.
struct HostOut(hio::HostStream);

impl fmt::Write for HostOut {
    fn write_str(&mut self, s: &str) -> fmt::Result {
        self.0.write_all(s.as_bytes()).map_err(|_| fmt::Error)
    }
}

/// `n` iterations of a two-instruction loop (`subs`, `bne`), for calibrating ticks against
/// instructions.
#[inline(never)]
fn spin(n: u32) {
    let mut n = n;
    // SAFETY: a register-only countdown; no memory is touched.
    unsafe {
        core::arch::asm!(
            "2:",
            "subs {n}, {n}, #1",
            "bne 2b",
            n = inout(reg) n,
            options(nomem, nostack),
        );
    }
    let _ = n;
}

#[entry]
fn main() -> ! {
    let status = match run() {
        Ok(true) => debug::EXIT_SUCCESS,
        _ => debug::EXIT_FAILURE,
    };
    debug::exit(status);
    loop {
        cortex_m::asm::wfi();
    }
}

fn run() -> Result<bool, fmt::Error> {
    let Some(mut peripherals) = cortex_m::Peripherals::take() else {
        return Ok(false);
    };
    let syst = &mut peripherals.SYST;
    syst.set_clock_source(SystClkSource::Core);
    syst.set_reload(0x00ff_ffff);
    syst.clear_current();
    syst.enable_interrupt();
    syst.enable_counter();

    let mut out = HostOut(hio::hstdout().map_err(|_| fmt::Error)?);
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
        (2 * u64::from(CALIBRATION_LOOPS), ticks() - t0)
    };
    firmware_run(&mut out, &mut buffers, &mut ticks, ONLY, &mut calibrate)
}

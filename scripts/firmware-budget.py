#!/usr/bin/env python3
"""Instruction budgets of the firmware cases on the emulated Cortex-M4F, Cortex-M33 and Cortex-A53.

Reads the firmware's output under QEMU (target/firmware/qemu-<machine>.txt, written by
scripts/firmware-check.sh) and the host's times (host-checksums --time), and writes
budget.json, budget.md and budget.svg to --out (default target/firmware):

- instructions per pixel: the slope of a case's run between its two frame sizes (so per-frame
  costs drop out), from SysTick ticks times the board's instructions per tick, which the
  firmware measures with a loop of known length (QEMU's -icount shift=0 makes each
  instruction one virtual nanosecond, and SysTick counts the board's core clock);
- start-up: the instructions `FixedPipeline::new` / `FloatPipeline::new` took;
- beside them, the host's nanoseconds per pixel for the same code (the cores' portable build,
  one thread), and the issue's targets for the M4.

Standard library only. Usage:
    python3 scripts/firmware-budget.py [--logs target/firmware] [--host FILE] [--out DIR]
"""
import argparse
import json
import math
import os
import platform
import re
import sys

MACHINES = [("mps2-an386", "Cortex-M4F"), ("mps2-an505", "Cortex-M33"), ("virt", "Cortex-A53")]
# Issue 56's budgets on the M4 (instructions per pixel; fixed path, 8-bit output): bilinear
# (with WB and CCM), MHC with dynamic defects, highlights and CCM, the demo camera with the
# default noise reduction and with its fast setting, distortion correction, directional (kept
# from issue 44).
TARGETS_PER_PIXEL = {
    "fixed-bilinear": 110,
    "fixed-mhc-dpc-highlights": 350,
    "fixed-mhc-camera": 1200,
    "fixed-mhc-camera-fast": 800,
    "fixed-directional": 1500,
    "fixed-mhc-distortion": 700,
}
TARGET_STARTUP = 1_000_000


def parse_log(path):
    """Cases' ticks per frame size, and instructions per tick."""
    ticks, per_tick = {}, None
    with open(path) as f:
        for line in f:
            parts = line.split()
            if parts[:1] == ["ticks"]:
                name, size, construct, run = parts[1], parts[2], int(parts[3]), int(parts[4])
                w, h = (int(v) for v in size.split("x"))
                ticks.setdefault(name, {})[w * h] = (construct, run)
            elif parts[:1] == ["calibration"]:
                instructions, t = int(parts[1]), int(parts[3])
                per_tick = instructions / t
    if per_tick is None or not ticks:
        sys.exit(f"error: {path} has no calibration or no ticks lines; did the firmware run?")
    # The loop's count is exact; the tick reads around it add a fraction of a tick.
    return ticks, round(per_tick)


def budgets(ticks, per_tick):
    out = {}
    for name, sizes in ticks.items():
        if len(sizes) < 2:
            continue
        (small, (c_small, r_small)), (large, (_, r_large)) = sorted(sizes.items())[:1] + sorted(
            sizes.items()
        )[-1:]
        if name.startswith("optics"):
            # No pixels: the instructions of the whole grid of lenses and subjects.
            out[name] = {"instructions_per_run": r_small * per_tick}
            continue
        out[name] = {
            "instructions_per_pixel": round((r_large - r_small) * per_tick / (large - small), 1),
            "startup_instructions": c_small * per_tick,
        }
    return out


def parse_host(path):
    per_pixel, construct = {}, {}
    with open(path) as f:
        for line in f:
            parts = line.split()
            if parts[:1] == ["ns_per_pixel"]:
                per_pixel[parts[1]] = float(parts[2])
            elif parts[:1] == ["construct_ns"]:
                construct[parts[1]] = int(parts[2])
    return per_pixel, construct


def cpu_name():
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def svg_chart(rows, machines):
    """Horizontal bars on a log axis: instructions per pixel per board, and the host's ns per
    pixel beside them (in its own panel)."""
    bar, gap, left, panel = 7, 6, 250, 330
    colours = ["#3b6ea8", "#d08a2c", "#4f9a4f"]
    height = 80 + len(rows) * (len(machines) * bar + gap)
    width = left + 2 * panel + 40
    out = [
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" '
        'font-family="sans-serif" font-size="11">',
        f'<rect width="{width}" height="{height}" fill="white"/>',
        f'<text x="{left}" y="16" font-size="13">instructions per pixel (log), QEMU</text>',
        f'<text x="{left + panel + 20}" y="16" font-size="13">host ns per pixel (log)</text>',
    ]
    for i, (machine, core) in enumerate(machines):
        out.append(
            f'<rect x="{left + 150 * i}" y="26" width="10" height="10" fill="{colours[i]}"/>'
            f'<text x="{left + 14 + 150 * i}" y="35">{core} ({machine})</text>'
        )

    def scale(v, lo, hi):
        return panel * (math.log10(max(v, lo)) - math.log10(lo)) / (math.log10(hi) - math.log10(lo))

    instr = [r[m] for r in rows for m, _ in machines if r.get(m)]
    ns = [r["x86"] for r in rows if r.get("x86")]
    i_lo, i_hi = 10 ** math.floor(math.log10(min(instr))), 10 ** math.ceil(math.log10(max(instr)))
    n_lo, n_hi = 10 ** math.floor(math.log10(min(ns))), 10 ** math.ceil(math.log10(max(ns)))
    y = 48
    for r in rows:
        out.append(f'<text x="{left - 6}" y="{y + bar + 3}" text-anchor="end">{r["name"]}</text>')
        for i, (machine, _) in enumerate(machines):
            v = r.get(machine)
            if v:
                out.append(
                    f'<rect x="{left}" y="{y + i * bar}" width="{scale(v, i_lo, i_hi):.1f}" '
                    f'height="{bar - 1}" fill="{colours[i]}"><title>{v:.0f}</title></rect>'
                )
        if r.get("x86"):
            out.append(
                f'<rect x="{left + panel + 20}" y="{y}" width="{scale(r["x86"], n_lo, n_hi):.1f}" '
                f'height="{2 * bar - 1}" fill="#6a6a6a"><title>{r["x86"]:.2f} ns</title></rect>'
            )
        y += len(machines) * bar + gap
    for lo, hi, x0 in [(i_lo, i_hi, left), (n_lo, n_hi, left + panel + 20)]:
        decade = lo
        while decade <= hi:
            x = x0 + scale(decade, lo, hi)
            out.append(
                f'<line x1="{x:.1f}" y1="44" x2="{x:.1f}" y2="{y}" stroke="#ccc"/>'
                f'<text x="{x:.1f}" y="{y + 12}" text-anchor="middle">{decade:g}</text>'
            )
            decade *= 10
    out.append("</svg>")
    return "\n".join(out)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--logs", default="target/firmware")
    ap.add_argument("--host", default="target/firmware/host-times.txt")
    ap.add_argument("--out", default="target/firmware")
    args = ap.parse_args()

    result = {"machines": {}, "targets_m4": {"startup_instructions": TARGET_STARTUP, "instructions_per_pixel": TARGETS_PER_PIXEL}}
    order = []
    for machine, core in MACHINES:
        path = os.path.join(args.logs, f"qemu-{machine}.txt")
        ticks, per_tick = parse_log(path)
        order = order or list(ticks)
        result["machines"][machine] = {
            "core": core,
            "instructions_per_tick": per_tick,
            "cases": budgets(ticks, per_tick),
        }
    per_pixel, construct = parse_host(args.host)
    result["host"] = {
        "cpu": cpu_name(),
        "build": "the cores' portable build (no AVX dispatch), one thread, 648x492, best of 5",
        "ns_per_pixel": per_pixel,
        "construct_ns": construct,
    }

    m4 = result["machines"]["mps2-an386"]["cases"]
    m33 = result["machines"]["mps2-an505"]["cases"]
    a53 = result["machines"]["virt"]["cases"]
    lines = [
        "| case | M4 instructions per pixel | M33 instructions per pixel | A53 instructions per pixel | M4 start-up instructions | host ns per pixel | M4 target per pixel | M4 start-up target |",
        "|---|---|---|---|---|---|---|---|",
    ]
    rows = []
    misses = []
    for name in order:
        if name not in m4 or "instructions_per_pixel" not in m4[name]:
            continue
        target = TARGETS_PER_PIXEL.get(name)
        startup = m4[name]["startup_instructions"]
        per_px = m4[name]["instructions_per_pixel"]
        mark = lambda ok: "met" if ok else "**missed**"
        target_cell = f"<= {target}: {mark(per_px <= target)}" if target else ""
        if target and per_px > target:
            misses.append(f"{name}: {per_px:.0f} instructions per pixel > {target}")
        startup_cell = ""
        # Every configuration on both paths (issue 56).
        if name.startswith(("fixed-", "float-", "c-api-")):
            startup_cell = f"<= 1 M: {mark(startup <= TARGET_STARTUP)}"
            if startup > TARGET_STARTUP:
                misses.append(f"{name}: start-up {startup:,} instructions > 1,000,000")
        host = per_pixel.get(name)
        host_cell = f"{host:.2f}" if host is not None else ""
        lines.append(
            f"| {name} | {per_px:,.0f} | {m33[name]['instructions_per_pixel']:,.0f} | "
            f"{a53[name]['instructions_per_pixel']:,.0f} | {startup:,} | {host_cell} | {target_cell} | "
            f"{startup_cell} |"
        )
        rows.append({"name": name, "mps2-an386": per_px, "mps2-an505": m33[name]["instructions_per_pixel"],
                     "virt": a53[name]["instructions_per_pixel"], "x86": host})
    result["missed"] = misses

    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, "budget.json"), "w") as f:
        json.dump(result, f, indent=2)
        f.write("\n")
    for name in order:
        if name in m4 and "instructions_per_run" in m4[name]:
            lines.append("")
            what = {
                "optics-fixed-focus-dof": "for the whole grid of lenses and subjects "
                "(firmware_cases::optics_checksum)",
                "optics-tessar-corrections": "at start-up to derive the ISP's corrections from the "
                "Tessar's prescription through isp-core's lens_correction: the chief-ray Brown-Conrady "
                "fit, red's and blue's scales at 17 nodes, relative illumination per colour at 9 "
                "radii over a 32 x 32 rear-element grid, a 9 x 7 shading grid "
                "(firmware_cases::lens_corrections_checksum)",
            }.get(name, "for the whole run")
            lines.append(
                f"{name}: {m4[name]['instructions_per_run']:,} instructions on the M4, "
                f"{m33[name]['instructions_per_run']:,} on the M33, {a53[name]['instructions_per_run']:,} "
                f"on the A53 {what}."
            )
    table = "\n".join(lines) + "\n"
    with open(os.path.join(args.out, "budget.md"), "w") as f:
        f.write(table)
    # The optics case has no pixels: it is in the JSON's per-frame figures only.
    with open(os.path.join(args.out, "budget.svg"), "w") as f:
        f.write(svg_chart([r for r in rows if not r["name"].startswith("optics")], MACHINES) + "\n")
    print(table, end="")
    print(f"host: {result['host']['cpu']}")
    for miss in misses:
        print(f"target missed: {miss}")
    print(f"wrote budget.json, budget.md and budget.svg to {args.out}")


if __name__ == "__main__":
    main()

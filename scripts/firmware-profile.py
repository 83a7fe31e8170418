#!/usr/bin/env python3
"""Where a firmware case's instructions go on the emulated Cortex-M4 (or M33): a profile by
function, from QEMU itself.

Builds the firmware to run one case alone at 64x48 (CAMSIM_FIRMWARE_ONLY, into
target/firmware/profile), runs it under QEMU with one instruction per translation block
(-singlestep) and a log line per block executed (-d exec,nochain), so each line is one
executed instruction; counts them by address and attributes each address to the function
inlined into it, through the line tables (llvm-symbolizer from Debian's llvm-22): the
innermost inlined function and its source line. Prints the top functions and lines with their
share of the instructions and their instructions per pixel. Needs what scripts/firmware-check.sh needs. Usage:

    python3 scripts/firmware-profile.py fixed-mhc-camera [--machine mps2-an505] [--top 25]
"""
import argparse
import bisect
import collections
import os
import re
import shutil
import subprocess
import sys

# Routines charged to their callers too.
LIBRARY = re.compile(r"^__|memcpy|memset|memclr|memmove|compiler_builtins|libm::")
BOARDS = {"mps2-an386": "thumbv7em-none-eabihf", "mps2-an505": "thumbv8m.main-none-eabihf"}


def build(case, target, target_dir):
    env = dict(os.environ)
    env.update(
        PATH="/usr/bin:" + env.get("PATH", ""),
        RUSTC="/usr/bin/rustc",
        RUSTC_BOOTSTRAP="1",
        CARGO_TARGET_DIR=target_dir,
        CAMSIM_FIRMWARE_ONLY=case,
    )
    subprocess.run(
        ["/usr/bin/cargo", "build", "--release", "--locked", "-Z", "build-std=core,compiler_builtins",
         "-Z", "build-std-features=compiler-builtins-mem", "--manifest-path",
         "firmware/cortex-m/Cargo.toml", "--target", target],
        env=env, check=True,
    )
    return os.path.join(target_dir, target, "release", "camsim-firmware")


def llvm_tool(name):
    return shutil.which(name) or f"/usr/lib/llvm-22/bin/{name}"


def function_ranges(elf):
    """Defined functions' [start, end) and names, sorted by start (llvm-nm --print-size)."""
    out = subprocess.run([llvm_tool("llvm-nm"), "--numeric-sort", "--print-size", "--defined-only",
                          "--demangle", elf], capture_output=True, text=True, check=True).stdout
    ranges = []
    for line in out.splitlines():
        parts = line.split(" ", 3)
        if len(parts) == 4 and parts[2] in "tTwW":
            start = int(parts[0], 16) & ~1  # Thumb symbols carry bit 0
            ranges.append((start, start + int(parts[1], 16), parts[3]))
    return ranges


def symbolize(elf, addresses):
    """Each address's innermost inlined frame: (function, file:line)."""
    proc = subprocess.run(
        [llvm_tool("llvm-symbolizer"), f"--obj={elf}", "--inlines", "--demangle",
         "--functions=linkage"],
        input="".join(f"0x{a:x}\n" for a in addresses), capture_output=True, text=True, check=True,
    )
    frames = {}
    blocks = proc.stdout.split("\n\n")
    for addr, block in zip(addresses, blocks):
        lines = block.strip().splitlines()
        if len(lines) >= 2:
            where = lines[1].rsplit(":", 1)[0]
            where = re.sub(r".*/(src|library)/", r"\1/", where)
            frames[addr] = (lines[0], where)
        else:
            frames[addr] = ("?", "?")
    return frames


def short(name):
    # Drop generic arguments and hashes: the function, not its instantiation.
    name = re.sub(r"::h[0-9a-f]{16}$", "", name)
    depth, out = 0, []
    for ch in name:
        if ch == "<":
            depth += 1
            if depth == 1:
                out.append("<..>")
        elif ch == ">":
            depth -= 1
        elif depth == 0:
            out.append(ch)
    return "".join(out).replace("<..><..>", "<..>")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("case")
    ap.add_argument("--machine", default="mps2-an386", choices=sorted(BOARDS))
    ap.add_argument("--top", type=int, default=25)
    args = ap.parse_args()
    os.chdir(os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
    elf = build(args.case, BOARDS[args.machine], os.path.abspath("target/firmware/profile"))
    qemu = subprocess.Popen(
        ["qemu-system-arm", "-M", args.machine, "-nographic", "-monitor", "none", "-serial", "none",
         "-semihosting-config", "enable=on,target=native", "-singlestep", "-d", "exec,nochain",
         "-D", "/dev/stderr", "-kernel", elf],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, bufsize=1 << 20,
    )
    # Library routines (memcpy, memset, software division) are shared by every caller, so
    # their instructions are also charged to the call site that entered them: the
    # instruction executed just before a routine's first.
    ranges = [r for r in function_ranges(elf) if LIBRARY.search(r[2])]
    starts = [r[0] for r in ranges]

    def routine(addr):
        i = bisect.bisect_right(starts, addr) - 1
        return ranges[i][2] if i >= 0 and addr < ranges[i][1] else None

    counts, callers = collections.Counter(), collections.Counter()
    entered = None  # (routine, call site) while in library code called from outside it
    previous = None
    pc = re.compile(r"/([0-9a-f]{8})/")
    for line in qemu.stderr:
        m = pc.search(line)
        if not m:
            continue
        addr = int(m.group(1), 16)
        counts[addr] += 1
        name = routine(addr)
        if name is None:
            entered = None
        elif entered is None and previous is not None:
            entered = (name, previous)
        if entered:
            callers[entered] += 1
        previous = addr
    out = qemu.stdout.read()
    if qemu.wait() != 0:
        sys.exit(f"error: the firmware failed under QEMU:\n{out}")
    addresses = sorted(set(counts) | {site for _, site in callers})
    frames = symbolize(elf, addresses)
    by_function, by_line = collections.Counter(), collections.Counter()
    for addr in addresses:
        function, where = frames[addr]
        by_function[short(function)] += counts[addr]
        by_line[f"{where}  ({short(function)})"] += counts[addr]
    total = sum(counts.values())
    pixels = 64 * 48
    print(out.strip())
    print(f"{total:,} instructions executed in all on {args.machine}: start-up (zeroing the "
          "buffers, the test frame), the pipeline's construction and run, the checksum")
    print("by function (innermost inlined):")
    for name, n in by_function.most_common(args.top):
        print(f"{100 * n / total:6.2f} %  {n / pixels:8.1f} per pixel  {name}")
    print("by source line:")
    for name, n in by_line.most_common(args.top):
        print(f"{100 * n / total:6.2f} %  {n / pixels:8.1f} per pixel  {name}")
    print("library routines by call site:")
    for (routine, site), n in callers.most_common(args.top):
        function, where = frames[site]
        print(f"{100 * n / total:6.2f} %  {n / pixels:8.1f} per pixel  {short(routine)} from "
              f"{where}  ({short(function)})")


if __name__ == "__main__":
    main()

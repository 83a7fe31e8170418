#!/usr/bin/env python3
"""Times camsim's DNG decode beside LibRaw's unpack of the same files, in one run.

Usage (from the repository root, with the oracle environment that scripts/test-all.sh makes):
    cargo build --release -p camsim
    .venv/bin/python scripts/bench-dng-decode.py [--repeats N] [FILE.dng ...]

Without files it times the real DNGs in data/real-dng/. For each file it prints camsim's best
time (`camsim bench dng`: parse, decode, linearise, crop, from bytes in memory) and LibRaw's
best `unpack()` (rawpy, from bytes in memory; open and unpack only, nothing developed), both
on one thread, and camsim's speed as a multiple of LibRaw's.
"""
import argparse
import io
import json
import pathlib
import subprocess
import sys
import time


def libraw_unpack_ms(data, repeats):
    import rawpy

    best = float("inf")
    for _ in range(repeats):
        raw = rawpy.RawPy()
        raw.open_buffer(io.BytesIO(data))
        start = time.perf_counter()
        raw.unpack()
        best = min(best, (time.perf_counter() - start) * 1e3)
        raw.close()
    return best


def main():
    root = pathlib.Path(__file__).resolve().parent.parent
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("files", nargs="*", type=pathlib.Path)
    parser.add_argument("--repeats", type=int, default=10)
    parser.add_argument("--camsim", type=pathlib.Path, default=root / "target/release/camsim")
    args = parser.parse_args()
    files = args.files or sorted((root / "data/real-dng").glob("*.dng"))
    if not args.camsim.exists():
        sys.exit(f"{args.camsim} not found: run `cargo build --release -p camsim` first")
    print(f"{'file':<40} {'size':>11} {'camsim ms':>10} {'LibRaw ms':>10} {'camsim/LibRaw speed':>20}")
    for path in files:
        reply = subprocess.run(
            [str(args.camsim), "bench", "dng", "--input", str(path), "--repeats", str(args.repeats), "--json"],
            check=True,
            capture_output=True,
            text=True,
        )
        ours = json.loads(reply.stdout)
        theirs = libraw_unpack_ms(path.read_bytes(), args.repeats)
        size = f"{ours['width']}x{ours['height']}"
        print(f"{path.name:<40} {size:>11} {ours['ms']:>10.2f} {theirs:>10.2f} {theirs / ours['ms']:>19.2f}x")


if __name__ == "__main__":
    main()

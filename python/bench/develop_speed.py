"""How much developing through Python costs over the Rust pipeline, on a 12 MP frame.

Writes a 4000 x 3000 14-bit DNG (the Canon frame in data/real-dng tiled, with its colour
tags and a noise profile, so neither side estimates one), then in the same run times:

- `camsim bench isp --input FRAME.dng`: `develop_ms`, the whole library call `camsim isp`
  makes (preparation, the run into new memory, framing) -- the Rust peer doing the same
  work -- and `ms_per_frame`, the pipeline alone (its tables and buffers built and reused
  outside the timing);
- `camsim.imread(FRAME).postprocess(...)` from Python, best wall time of the repeats: the
  options' checks, the frame's checks, the pipeline and the numpy array it returns;
- the same with `out=` an array reused across calls (no fresh pages to fault in).

Usage (a release build of both: `pip install ./python` and `cargo build --release`):

    python python/bench/develop_speed.py [--camsim target/release/camsim] [--threads 2] \\
        [--repeats 10] [--demosaic directional] [--path float] [--denoise 0]

Prints one JSON object: milliseconds per frame of each and the ratios.
"""

from __future__ import annotations

import argparse
import json
import pathlib
import subprocess
import tempfile
import time

import numpy as np

import camsim

REPO = pathlib.Path(__file__).resolve().parents[2]


def frame(path: pathlib.Path) -> None:
    source = camsim.imread(REPO / "data" / "real-dng" / "canon-550d-colorchart-14bit.dng")
    tile = np.array(source.raw_image)
    big = np.tile(tile, (3, 3))[:3000, :4000]
    camsim.imwrite_dng(path, np.ascontiguousarray(big), like=source, noise_profile=[1.6e-4, 8.7e-7])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--camsim", default=str(REPO / "target" / "release" / "camsim"))
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--repeats", type=int, default=10)
    parser.add_argument("--demosaic", default="directional")
    parser.add_argument("--path", default="float")
    parser.add_argument(
        "--denoise", type=float, default=None,
        help="noise reduction's strength (0 turns raw and chroma noise reduction off) [default: the file's profile sets it on]",
    )
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        dng = pathlib.Path(tmp) / "frame-12mp.dng"
        frame(dng)
        flags = ["--demosaic", args.demosaic, "--path", args.path, "--threads", str(args.threads)]
        options = dict(demosaic=args.demosaic, path=args.path, threads=args.threads)
        if args.denoise is not None:
            flags += ["--denoise", str(args.denoise), "--chroma-denoise", str(args.denoise)]
            options.update(denoise=args.denoise, chroma_denoise=args.denoise)
        bench = subprocess.run(
            [args.camsim, "bench", "isp", "--input", str(dng), "--repeats", str(args.repeats), "--json", *flags],
            capture_output=True, text=True, check=True,
        )
        rust = json.loads(bench.stdout)
        raw = camsim.imread(dng)

        def best(**extra: object) -> float:
            times = []
            for _ in range(args.repeats):
                start = time.perf_counter()
                raw.postprocess(**options, **extra)
                times.append((time.perf_counter() - start) * 1e3)
            return min(times)

        python_ms = best()
        out = np.empty((3000, 4000, 3), np.uint8)
        reused_ms = best(out=out)
        result = {
            "frame": "4000x3000 14-bit RGGB",
            "options": options,
            "repeats": args.repeats,
            "rust_pipeline_ms": rust["ms_per_frame"],
            "rust_develop_ms": rust["develop_ms"],
            "python_ms": round(python_ms, 2),
            "python_out_reused_ms": round(reused_ms, 2),
            "python_over_rust_develop": round(python_ms / rust["develop_ms"], 3),
            "python_over_rust_pipeline": round(python_ms / rust["ms_per_frame"], 3),
            "python_out_reused_over_rust_pipeline": round(reused_ms / rust["ms_per_frame"], 3),
        }
        print(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()

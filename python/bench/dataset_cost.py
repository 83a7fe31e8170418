"""What a camsim dataset costs: seconds per sample by step, samples per second on one and two
workers (plain processes under xargs, and Ray), and the truth's own Monte Carlo noise against
the samples per pixel, written as JSON and an SVG chart.

    python python/bench/dataset_cost.py --camsim target/release/camsim \\
        --out docs/bench/dataset.json --svg docs/bench/dataset.svg

Use release builds of both the command and the Python module (``maturin develop --release``).
The spec is python/bench/dataset.toml (512 x 512, 16 spp, every generator, ISP output on).
The truth's noise at s samples per pixel is measured against a render of the same samples at
R (the reference); the two share their first s samples per pixel (each pixel has one random
stream), so the mean squared difference is sigma_s^2 (1 - s / R) and is divided by that.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import struct
import subprocess
import sys
import tempfile
import time
from typing import Any, Dict, List

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))


def read_exr(path: str) -> np.ndarray:
    """camsim's own EXR files (uncompressed scanlines of 32-bit float B, G, R) as (H, W, 3)."""
    data = open(path, "rb").read()
    at = 8
    window = None
    while data[at] != 0:
        name_end = data.index(b"\0", at)
        name = data[at:name_end].decode()
        kind_end = data.index(b"\0", name_end + 1)
        (size,) = struct.unpack_from("<i", data, kind_end + 1)
        value = data[kind_end + 5 : kind_end + 5 + size]
        if name == "dataWindow":
            window = struct.unpack("<4i", value)
        at = kind_end + 5 + size
    at += 1
    assert window is not None, path
    width, height = window[2] - window[0] + 1, window[3] - window[1] + 1
    at += 8 * height  # the offset table
    out = np.empty((height, width, 3), np.float32)
    for y in range(height):
        at += 8  # y and the byte count
        planes = np.frombuffer(data, "<f4", 3 * width, at).reshape(3, width)
        out[y] = planes[::-1].T  # B, G, R -> R, G, B
        at += 12 * width
    return out


def spec_with(text: str, **dataset: Any) -> str:
    """The spec's text with `[dataset]` keys replaced."""
    lines = text.splitlines()
    for key, value in dataset.items():
        lines = [f"{key} = {value}" if l.split("=")[0].strip() == key else l for l in lines]
    return "\n".join(lines) + "\n"


def run_processes(camsim: str, spec: str, out: str, n: int, workers: int) -> float:
    """Samples 0..n, one `camsim dataset --index` process each, `workers` at a time (the
    recipes' xargs); samples per second."""
    start = time.perf_counter()
    subprocess.run(
        f"seq 0 {n - 1} | xargs -P{workers} -I{{}} {camsim} dataset --spec {spec} --out {out} "
        f"--index {{}} --threads 1 >/dev/null 2>&1",
        shell=True,
        check=True,
    )
    return n / (time.perf_counter() - start)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--camsim", required=True, help="the camsim command (a release build)")
    p.add_argument("--spec", default=os.path.join(HERE, "dataset.toml"))
    p.add_argument("--samples", type=int, default=16, help="samples per throughput run")
    p.add_argument("--mc-samples", type=int, default=6)
    p.add_argument("--mc-spp", default="4,16,64")
    p.add_argument("--mc-reference", type=int, default=256)
    p.add_argument("--out", default="docs/bench/dataset.json")
    p.add_argument("--svg", default="docs/bench/dataset.svg")
    args = p.parse_args()
    import camsim.dataset

    camsim_bin = os.path.abspath(args.camsim)
    spec_path = os.path.abspath(args.spec)
    text = open(spec_path).read()
    work = tempfile.mkdtemp(prefix="camsim-dataset-cost-")
    n = args.samples
    result: Dict[str, Any] = {
        "command": "python " + " ".join(sys.argv),
        "machine": {
            "cpu": platform.processor() or platform.machine(),
            "cores": os.cpu_count(),
            "python": platform.python_version(),
        },
        "spec": os.path.relpath(spec_path),
    }
    try:
        # One worker, one process: the split by step.
        one = os.path.join(work, "one")
        start = time.perf_counter()
        lines = subprocess.run(
            [camsim_bin, "dataset", "--spec", spec_path, "--out", one, "--range", f"0..{n}",
             "--threads", "1", "--json"],
            capture_output=True, text=True, check=True,
        ).stdout.splitlines()
        one_process = n / (time.perf_counter() - start)
        timings = [json.loads(l) for l in lines]
        steps = ["render_s", "sensor_s", "isp_s", "write_s", "total_s"]
        result["per_sample_s"] = {
            s: {"mean": float(np.mean([t[s] for t in timings])),
                "median": float(np.median([t[s] for t in timings]))}
            for s in steps
        }
        meta = json.load(open(os.path.join(one, "000000", "record.json")))["render"]
        result["sample"] = {"width": meta["width"], "height": meta["height"], "spp": meta["spp"],
                            "samples": n}
        print(f"one process: {one_process:.3f} samples/s; per sample {result['per_sample_s']}",
              file=sys.stderr)

        # Plain processes under xargs, one and two at a time.
        procs = {}
        for workers in (1, 2):
            procs[workers] = run_processes(
                camsim_bin, spec_path, os.path.join(work, f"xargs{workers}"), n, workers)
            print(f"xargs -P{workers}: {procs[workers]:.3f} samples/s", file=sys.stderr)
        # Ray: a local cluster of one and of two workers (its start not counted).
        ray_rates = {}
        for workers in (1, 2):
            summary = camsim.dataset.generate(
                spec_path, os.path.join(work, f"ray{workers}"), n, workers=workers,
                threads=1, progress=False)
            ray_rates[workers] = summary["samples_per_s"]
            print(f"ray, {workers} workers: {ray_rates[workers]:.3f} samples/s", file=sys.stderr)
        result["samples_per_s"] = {
            "one_process_range": one_process,
            "processes": {"1": procs[1], "2": procs[2], "speedup": procs[2] / procs[1]},
            "ray": {"1": ray_rates[1], "2": ray_rates[2], "speedup": ray_rates[2] / ray_rates[1]},
        }

        # The truth's Monte Carlo noise against spp.
        spps = [int(s) for s in args.mc_spp.split(",")]
        renders: Dict[int, str] = {}
        seconds: Dict[int, float] = {}
        for spp in spps + [args.mc_reference]:
            spec_spp = os.path.join(work, f"spec-{spp}.toml")
            body = spec_with(text, spp=spp, isp="false").replace(
                '"../../data/', '"' + os.path.join(os.path.dirname(spec_path), "../../data/"))
            open(spec_spp, "w").write(body)
            out = os.path.join(work, f"mc{spp}")
            start = time.perf_counter()
            subprocess.run([camsim_bin, "dataset", "--spec", spec_spp, "--out", out, "--range",
                            f"0..{args.mc_samples}", "--threads", "0"],
                           capture_output=True, check=True)
            seconds[spp] = (time.perf_counter() - start) / args.mc_samples
            renders[spp] = out
            print(f"spp {spp}: {seconds[spp]:.2f} s per sample (all cores)", file=sys.stderr)
        reference = args.mc_reference
        rows = []
        generators = [
            json.load(open(os.path.join(renders[reference], f"{i:06}", "record.json")))["scene"]["generator"]
            for i in range(args.mc_samples)
        ]

        def relative_rmse(x: np.ndarray, r: np.ndarray, spp: int) -> float:
            mse = float(np.mean((x - r) ** 2)) / (1 - spp / reference)
            return float(np.sqrt(mse) / max(float(np.mean(r)), 1e-12))

        for spp in spps:
            shown, linear = [], []
            for i in range(args.mc_samples):
                x = read_exr(os.path.join(renders[spp], f"{i:06}", "truth_srgb.exr")).astype(np.float64)
                r = read_exr(os.path.join(renders[reference], f"{i:06}", "truth_srgb.exr")).astype(np.float64)
                # What an image shows: values clipped to the output's range (1 is white).
                shown.append(relative_rmse(np.clip(x, 0, 1), np.clip(r, 0, 1), spp))
                # Radiance as it is, highlights above white included (a lamp's bokeh).
                linear.append(relative_rmse(x, r, spp))
            rows.append({"spp": spp,
                         "relative_rmse": float(np.mean(shown)),
                         "relative_rmse_per_sample": shown,
                         "relative_rmse_unclipped": float(np.mean(linear)),
                         "relative_rmse_unclipped_per_sample": linear,
                         "seconds_per_sample_all_cores": seconds[spp]})
            print(f"spp {spp}: truth relative RMSE {rows[-1]['relative_rmse']:.4f}",
                  file=sys.stderr)
        result["monte_carlo"] = {"reference_spp": reference, "samples": args.mc_samples,
                                 "generators": generators, "rows": rows}
    finally:
        shutil.rmtree(work, ignore_errors=True)
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    with open(args.out, "w") as f:
        json.dump(result, f, indent=2)
        f.write("\n")
    with open(args.svg, "w") as f:
        f.write(chart(result))
    print(json.dumps(result["samples_per_s"], indent=2))


def chart(r: Dict[str, Any]) -> str:
    """Three panels: seconds per sample by step; samples per second on one and two workers;
    the truth's relative RMSE against spp (log-log)."""
    w, h, pad = 1050, 300, 50
    out: List[str] = [
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" '
        'font-family="sans-serif" font-size="11">',
        f'<rect width="{w}" height="{h}" fill="white"/>',
    ]
    panel = (w - 2 * pad) / 3

    def title(x: float, text: str) -> None:
        out.append(f'<text x="{x}" y="20" font-size="13" font-weight="bold">{text}</text>')

    # 1. The split.
    sample = r["sample"]
    title(pad, f"s per sample ({sample['width']}x{sample['height']}, {sample['spp']} spp, 1 thread)")
    steps = [("render", "render_s", "#4477aa"), ("sensor", "sensor_s", "#66ccee"),
             ("ISP", "isp_s", "#228833"), ("files", "write_s", "#ccbb44")]
    top = max(r["per_sample_s"]["total_s"]["mean"], 1e-9)
    y = 40
    for name, key, colour in steps:
        v = r["per_sample_s"][key]["mean"]
        bw = (panel - 110) * v / top
        out.append(f'<rect x="{pad + 50}" y="{y}" width="{bw:.1f}" height="30" fill="{colour}"/>')
        out.append(f'<text x="{pad}" y="{y + 19}">{name}</text>')
        out.append(f'<text x="{pad + 55 + bw:.1f}" y="{y + 19}">{v:.3f}</text>')
        y += 45
    # 2. Throughput.
    x0 = pad + panel + 20
    title(x0, "samples/s, 1 and 2 workers")
    rates = r["samples_per_s"]
    bars = [("xargs 1", rates["processes"]["1"]), ("xargs 2", rates["processes"]["2"]),
            ("Ray 1", rates["ray"]["1"]), ("Ray 2", rates["ray"]["2"])]
    top = max(v for _, v in bars)
    for i, (name, v) in enumerate(bars):
        bh = (h - 110) * v / top
        bx = x0 + 10 + i * (panel - 40) / 4
        out.append(f'<rect x="{bx:.1f}" y="{h - 50 - bh:.1f}" width="{(panel - 40) / 4 - 12:.1f}" '
                   f'height="{bh:.1f}" fill="{"#4477aa" if i < 2 else "#ee6677"}"/>')
        out.append(f'<text x="{bx:.1f}" y="{h - 35}">{name}</text>')
        out.append(f'<text x="{bx:.1f}" y="{h - 55 - bh:.1f}">{v:.2f}</text>')
    out.append(f'<text x="{x0 + 10}" y="{h - 15}">speed-up: xargs {rates["processes"]["speedup"]:.2f}x, '
               f'Ray {rates["ray"]["speedup"]:.2f}x</text>')
    # 3. Monte Carlo noise.
    x0 = pad + 2 * panel + 40
    mc = r["monte_carlo"]
    title(x0, "truth's relative RMSE vs spp")
    rows = mc["rows"]
    import math

    xs = [math.log2(row["spp"]) for row in rows]
    ys = [math.log10(max(row["relative_rmse"], 1e-6)) for row in rows]
    x_lo, x_hi = min(xs), max(xs) if max(xs) > min(xs) else min(xs) + 1
    y_lo, y_hi = min(ys) - 0.2, max(ys) + 0.2
    pw, ph = panel - 60, h - 110
    pts = [(x0 + 20 + pw * (x - x_lo) / (x_hi - x_lo), 50 + ph * (y_hi - y) / (y_hi - y_lo))
           for x, y in zip(xs, ys)]
    out.append('<polyline fill="none" stroke="#aa3377" stroke-width="2" points="'
               + " ".join(f"{px:.1f},{py:.1f}" for px, py in pts) + '"/>')
    for (px, py), row in zip(pts, rows):
        out.append(f'<circle cx="{px:.1f}" cy="{py:.1f}" r="3" fill="#aa3377"/>')
        out.append(f'<text x="{px + 5:.1f}" y="{py - 6:.1f}">{row["relative_rmse"]:.3f}</text>')
        out.append(f'<text x="{px - 6:.1f}" y="{h - 35}">{row["spp"]}</text>')
    out.append(f'<text x="{x0 + 20}" y="{h - 15}">spp (log scale); RMSE / mean, linear sRGB</text>')
    out.append("</svg>")
    return "\n".join(out) + "\n"


if __name__ == "__main__":
    main()

"""camsim's path tracer against Mitsuba 3 (scalar_rgb) on the Cornell box, in one run.

Parity: both render mitsuba.cornell_box() (camsim: its built-in `cornell-box`, the same numbers)
at 256 x 256, pinhole, one-pixel box filter, max depth 8, as K independent renders (seeds
1..K) of SPP/K samples each. Reported: each channel's image mean (camsim vs Mitsuba, relative
difference), and for 4x4-pixel blocks the difference of the two renderers' block means in units
of its standard error estimated from the K renders of each (a z-score: noise alone gives values
near 0 with an RMS near 1), plus the relative block differences beside what noise alone gives
(two halves of the same renderer's renders, scaled to the same sample count).

Speed: camera samples per second for both at the same thread count and depth, pinhole and
thin lens, timed in-process (camsim's own timer excludes loading; Mitsuba's mi.render call).

Usage: python scripts/bench_tracer.py [--spp 1024] [--replicas 8] [--threads 2] [--camsim PATH]
(scripts/bench-tracer.sh sets up the environment and builds camsim first.)
"""

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import drjit as dr
import mitsuba as mi

mi.set_variant("scalar_rgb")

SIZE = 256
DEPTH = 8
APERTURE = 0.1  # scene units, thin-lens speed runs
FOCUS = 3.9


def mitsuba_scene(spp, thinlens=False):
    d = mi.cornell_box()
    d["integrator"]["max_depth"] = DEPTH
    sensor = d["sensor"]
    sensor["film"]["rfilter"] = {"type": "box"}
    sensor["film"]["width"] = SIZE
    sensor["film"]["height"] = SIZE
    sensor["sampler"]["sample_count"] = spp
    if thinlens:
        sensor["type"] = "thinlens"
        sensor["aperture_radius"] = APERTURE
        sensor["focus_distance"] = FOCUS
    return mi.load_dict(d)


def mitsuba_render(spp, seed, thinlens=False):
    scene = mitsuba_scene(spp, thinlens)
    start = time.perf_counter()
    image = mi.render(scene, spp=spp, seed=seed)
    seconds = time.perf_counter() - start
    return np.array(image, dtype=np.float64)[..., :3], seconds


def camsim_render(camsim, spp, seed, threads, out, thinlens=False):
    cmd = [camsim, "render", "--scene", "cornell-box", "--width", str(SIZE), "--height",
           str(SIZE), "--spp", str(spp), "--seed", str(seed), "--threads", str(threads),
           "--max-depth", str(DEPTH), "--linear", str(out), "--json"]
    if thinlens:
        cmd += ["--camera", "thinlens", "--aperture-radius", str(APERTURE), "--focus-distance",
                str(FOCUS)]
    report = json.loads(subprocess.run(cmd, check=True, capture_output=True, text=True).stdout)
    image = np.array(mi.Bitmap(str(out)), dtype=np.float64)[..., :3]
    return image, report


def blocks(image):
    h, w, c = image.shape
    return image.reshape(h // 4, 4, w // 4, 4, c).mean(axis=(1, 3))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--spp", type=int, default=1024, help="total samples per pixel for parity")
    ap.add_argument("--replicas", type=int, default=8)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--speed-spp", type=int, default=64)
    ap.add_argument("--camsim", default="target/release/camsim")
    ap.add_argument("--json", type=Path, help="also write the figures here")
    args = ap.parse_args()
    dr.set_thread_count(args.threads)
    k = args.replicas
    per = max(1, args.spp // k)
    tmp = Path(tempfile.mkdtemp(prefix="camsim-bench-"))

    print(f"parity: cornell-box {SIZE}x{SIZE}, pinhole, box filter, max depth {DEPTH}, "
          f"{k} renders x {per} spp each, {args.threads} threads", flush=True)
    ours, theirs = [], []
    for seed in range(1, k + 1):
        img, _ = camsim_render(args.camsim, per, seed, args.threads, tmp / f"camsim-{seed}.exr")
        ours.append(img)
        img, _ = mitsuba_render(per, seed)
        theirs.append(img)
        print(f"  render {seed}/{k} done", flush=True)
    ours, theirs = np.stack(ours), np.stack(theirs)

    mean_ours = ours.mean(axis=(0, 1, 2))
    mean_theirs = theirs.mean(axis=(0, 1, 2))
    rel_mean = (mean_ours - mean_theirs) / mean_theirs
    print("channel means (R, G, B):")
    print(f"  camsim  {mean_ours.round(6).tolist()}")
    print(f"  mitsuba {mean_theirs.round(6).tolist()}")
    print(f"  relative difference {(100 * rel_mean).round(3).tolist()} %")

    bo = np.stack([blocks(i) for i in ours])
    bt = np.stack([blocks(i) for i in theirs])
    mo, mt = bo.mean(0), bt.mean(0)
    se = np.sqrt(bo.var(0, ddof=1) / k + bt.var(0, ddof=1) / k)
    lit = se > 0
    z = (mo - mt)[lit] / se[lit]
    rms_z = float(np.sqrt(np.mean(z ** 2)))
    dof = 2 * (k - 1)
    expected_rms = float(np.sqrt(dof / (dof - 2)))  # Student's t with 2(K-1) degrees of freedom
    frac_4 = float(np.mean(np.abs(z) > 4))
    print(f"4x4 blocks: {z.size} block-channels; z-score mean {z.mean():+.3f}, RMS {rms_z:.3f} "
          f"(noise alone: 0 and {expected_rms:.3f}), |z| > 4: {100 * frac_4:.2f} %")
    rel = np.abs(mo - mt) / np.maximum((mo + mt) / 2, 1e-6)
    half = k // 2
    # Two halves of one renderer differ by sqrt(2) x the noise of the full-count difference.
    noise = np.abs(bo[:half].mean(0) - bo[half:].mean(0)) / np.maximum(mo, 1e-6) / np.sqrt(2)
    print(f"  relative block difference camsim vs Mitsuba: median {100 * np.median(rel):.2f} %, "
          f"95th percentile {100 * np.percentile(rel, 95):.2f} %")
    print(f"  same, noise alone (camsim against itself): median {100 * np.median(noise):.2f} %, "
          f"95th percentile {100 * np.percentile(noise, 95):.2f} %")

    print(f"speed: {args.speed_spp} spp, {args.threads} threads, max depth {DEPTH}", flush=True)
    speed = {}
    for thinlens in (False, True):
        name = "thinlens" if thinlens else "pinhole"
        _, report = camsim_render(args.camsim, args.speed_spp, 0, args.threads, tmp / "speed.exr", thinlens)
        _, seconds = mitsuba_render(args.speed_spp, 0, thinlens)
        theirs_sps = SIZE * SIZE * args.speed_spp / seconds
        ours_sps = report["samples_per_s"]
        speed[name] = {"camsim_samples_per_s": ours_sps, "mitsuba_samples_per_s": theirs_sps,
                       "ratio": ours_sps / theirs_sps}
        print(f"  {name:8} camsim {ours_sps / 1e6:.2f} Msamples/s, Mitsuba {theirs_sps / 1e6:.2f} "
              f"Msamples/s: {ours_sps / theirs_sps:.2f}x")

    ok_mean = bool(np.all(np.abs(rel_mean) <= 0.01))
    ok_noise = bool(abs(z.mean()) < 0.1 and rms_z <= 1.25 * expected_rms and frac_4 < 0.01)
    figures = {
        "mitsuba": mi.__version__, "threads": args.threads, "spp": per * k, "replicas": k,
        "mean_camsim": mean_ours.tolist(), "mean_mitsuba": mean_theirs.tolist(),
        "mean_relative_difference": rel_mean.tolist(), "block_z_mean": float(z.mean()),
        "block_z_rms": rms_z, "block_z_rms_noise_only": expected_rms, "block_z_over_4": frac_4,
        "speed": speed, "means_within_1_percent": ok_mean, "blocks_within_noise": ok_noise,
    }
    if args.json:
        args.json.write_text(json.dumps(figures, indent=1) + "\n")
    print(f"means within 1 %: {'yes' if ok_mean else 'NO'}; block differences explained by noise: "
          f"{'yes' if ok_noise else 'NO'}")
    return 0 if ok_mean and ok_noise else 1


if __name__ == "__main__":
    sys.exit(main())

"""OpenCV's demosaicing measured the way `camsim bench demosaic` measures camsim's: RGGB mosaic
from each 8-bit RGB image (x257 for 16-bit), CPSNR over the image minus a 10-pixel border
averaged over the set, and single-thread Mpix/s (best run over >= 0.5 s) on a 2048x2048 mosaic
tiled from the first image. Run by scripts/bench-demosaic.sh with the oracle's .venv."""

import glob
import json
import sys
import time

import cv2
import numpy as np

METHODS = {
    "opencv-bilinear": (cv2.COLOR_BayerBG2RGB, (8, 16)),
    "opencv-ea": (cv2.COLOR_BayerBG2RGB_EA, (8, 16)),
    "opencv-vng": (cv2.COLOR_BayerBG2RGB_VNG, (8,)),
}


def mosaic(rgb, scale):
    m = np.empty(rgb.shape[:2], dtype=np.uint16)
    m[0::2, 0::2] = rgb[0::2, 0::2, 0]
    m[0::2, 1::2] = rgb[0::2, 1::2, 1]
    m[1::2, 0::2] = rgb[1::2, 0::2, 1]
    m[1::2, 1::2] = rgb[1::2, 1::2, 2]
    return m * scale


def cpsnr(out, truth, peak):
    d = (out.astype(np.float64) - truth.astype(np.float64))[10:-10, 10:-10]
    return 10 * np.log10(peak * peak / np.mean(d * d))


def main(datasets):
    cv2.setNumThreads(1)
    rows = []
    for folder in datasets:
        images = [cv2.cvtColor(cv2.imread(p, cv2.IMREAD_COLOR), cv2.COLOR_BGR2RGB) for p in sorted(glob.glob(folder + "/*.png"))]
        for name, (code, depths) in METHODS.items():
            for bits in depths:
                scale, dtype, peak = (1, np.uint8, 255.0) if bits == 8 else (257, np.uint16, 65535.0)
                scores = [cpsnr(cv2.cvtColor(mosaic(im, scale).astype(dtype), code), im.astype(np.float64) * scale, peak) for im in images]
                base = mosaic(images[0], scale).astype(dtype)
                h, w = base.shape[0] & ~1, base.shape[1] & ~1
                big = np.tile(base[:h, :w], (2048 // h + 1, 2048 // w + 1))[:2048, :2048].copy()
                best, start = float("inf"), time.perf_counter()
                while time.perf_counter() - start < 0.5 or best == float("inf"):
                    t = time.perf_counter()
                    cv2.cvtColor(big, code)
                    best = min(best, time.perf_counter() - t)
                rows.append({"dataset": folder, "method": name, "bits": bits, "cpsnr_db": float(np.mean(scores)), "mpix_per_s": 2048 * 2048 / best / 1e6})
    print(json.dumps(rows, indent=1) if "--json" in sys.argv else "\n".join(f"{r['dataset']:<14} {r['method']:<16} {r['bits']:>4} {r['cpsnr_db']:>10.2f} {r['mpix_per_s']:>10.1f}" for r in rows))


if __name__ == "__main__":
    main([a for a in sys.argv[1:] if not a.startswith("--")])

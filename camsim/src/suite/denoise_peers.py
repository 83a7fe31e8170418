"""The noise-reduction peers of `camsim bench`'s denoise suite, run with the oracle environment's
Python and timed in the same run as camsim. Embedded in camsim.

argv[1]: a JSON object {jobs, h_grid, bm3d, border}; each job {name, width, height, s, o, black,
white, noisy_raw, noisy_srgb, clean_srgb, out_raw}:
- noisy_raw: width * height little-endian uint16 samples, the noisy RGGB mosaic (12-bit codes);
- noisy_srgb, clean_srgb: width * height * 3 bytes, camsim's development of the noisy and of the
  noise-free raw with noise reduction off (the clean one is the reference);
- out_raw: where BM3D per CFA plane writes its denoised mosaic (uint16 codes), which camsim
  develops the same way.

Peers:
- OpenCV's fastNlMeansDenoisingColored on the noisy development, for every h in h_grid
  (hColor = h, template 7, search 21: OpenCV's defaults);
- with bm3d: CBM3D (bm3d.bm3d_rgb) on the noisy development with the true sigma (the standard
  deviation of noisy minus clean), and BM3D on each CFA plane of the raw after the generalised
  Anscombe transform for variance S x + O (sd 1 after it), inverted by the closed-form
  approximation of its exact unbiased inverse (Makitalo and Foi 2011, the Poisson formula less
  the Gaussian part's variance).

Prints {versions, rows: [{name, s, method, psnr_db (null for the raw peer: camsim develops
out_raw), seconds}]}. PSNR is on 8-bit codes over the interior `border` pixels in from each
edge, as camsim's cpsnr computes it.
"""

import json
import sys
import time

import cv2
import numpy as np


def psnr(a, b, border):
    a = a[border:-border, border:-border].astype(np.float64)
    b = b[border:-border, border:-border].astype(np.float64)
    return float(10 * np.log10(255.0 ** 2 / np.mean((a - b) ** 2)))


def gat(x, s, o):
    return 2.0 / s * np.sqrt(np.maximum(s * x + 0.375 * s * s + o, 0.0))


def inverse_gat(z, s, o):
    sigma2 = o / (s * s)
    z = np.maximum(z, 0.8)
    root = np.sqrt(1.5)
    counts = 0.25 * z ** 2 + 0.25 * root / z - 1.375 / z ** 2 + 0.625 * root / z ** 3 - 0.125 - sigma2
    return np.maximum(counts, 0.0) * s


def main():
    a = json.loads(sys.argv[1])
    border = a["border"]
    rows = []
    versions = {"opencv": cv2.__version__, "numpy": np.__version__}
    if a["bm3d"]:
        import bm3d
        from importlib.metadata import version
        versions["bm3d"] = version("bm3d")
    cv2.setNumThreads(1)
    for job in a["jobs"]:
        w, h = job["width"], job["height"]
        noisy = np.fromfile(job["noisy_srgb"], dtype=np.uint8).reshape(h, w, 3)
        clean = np.fromfile(job["clean_srgb"], dtype=np.uint8).reshape(h, w, 3)
        # OpenCV works in BGR; the filter treats channels through Lab, so give it the order
        # it expects.
        bgr = np.ascontiguousarray(noisy[:, :, ::-1])
        for hh in a["h_grid"]:
            start = time.perf_counter()
            out = cv2.fastNlMeansDenoisingColored(bgr, None, hh, hh, 7, 21)
            seconds = time.perf_counter() - start
            rows.append({"name": job["name"], "s": job["s"], "method": f"fnlm h={hh:g}",
                         "psnr_db": psnr(out[:, :, ::-1], clean, border), "seconds": seconds})
        if not a["bm3d"]:
            continue
        z = noisy.astype(np.float64) / 255.0
        sigma = float(np.std(z - clean.astype(np.float64) / 255.0))
        start = time.perf_counter()
        out = bm3d.bm3d_rgb(z, sigma)
        seconds = time.perf_counter() - start
        out8 = np.clip(np.round(out * 255.0), 0, 255).astype(np.uint8)
        rows.append({"name": job["name"], "s": job["s"], "method": "cbm3d",
                     "psnr_db": psnr(out8, clean, border), "seconds": seconds})
        raw = np.fromfile(job["noisy_raw"], dtype="<u2").reshape(h, w).astype(np.float64)
        black, white = job["black"], job["white"]
        x = (raw - black) / (white - black)
        s, o = job["s"], job["o"]
        start = time.perf_counter()
        denoised = np.empty_like(x)
        for dy in (0, 1):
            for dx in (0, 1):
                plane = gat(x[dy::2, dx::2], s, o)
                denoised[dy::2, dx::2] = inverse_gat(bm3d.bm3d(plane, 1.0), s, o)
        seconds = time.perf_counter() - start
        codes = np.clip(np.round(black + denoised * (white - black)), 0, white).astype("<u2")
        codes.tofile(job["out_raw"])
        rows.append({"name": job["name"], "s": job["s"], "method": "bm3d planes",
                     "psnr_db": None, "seconds": seconds})
        print(f"denoise peers: {job['name']} S {s:g} done", file=sys.stderr, flush=True)
    print(json.dumps({"versions": versions, "rows": rows}))


main()

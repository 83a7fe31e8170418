"""The demosaicing peers of `camsim bench`: OpenCV (bilinear, EA, VNG) and colour-demosaicing
(bilinear, Malvar2004, Menon2007), measured as camsim measures its own methods: an RGGB mosaic
of each 8-bit RGB image (x257 for 16 bits), CPSNR over the image less a 10-pixel border,
averaged over the set; single-thread Mpix/s, the best run over at least `min_seconds` (and at
least one run) on a square mosaic `tile` pixels wide tiled from the set's first image.

colour-demosaicing works in floating point: its input is the mosaic divided by the peak and its
output is rounded back to the depth, so its speed does not depend on the depth and is measured
once per method. Run by camsim with one JSON argument; prints a JSON list of rows."""

import glob
import json
import os
import sys
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import cv2  # noqa: E402
import numpy as np  # noqa: E402

cv2.setNumThreads(1)


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


def opencv_method(code, dtype):
    return lambda m: cv2.cvtColor(m.astype(dtype), code)


def colour_method(function, peak):
    def run(m):
        out = function(m.astype(np.float64) / peak, "RGGB")
        return np.clip(np.rint(out * peak), 0, peak)

    return run


def best_seconds(run, m, min_seconds):
    best, start = float("inf"), time.perf_counter()
    while time.perf_counter() - start < min_seconds or best == float("inf"):
        t = time.perf_counter()
        run(m)
        best = min(best, time.perf_counter() - t)
    return best


def main(request):
    import warnings

    # colour-science warns on import that matplotlib (its plotting) is missing; nothing here plots.
    warnings.filterwarnings("ignore", message=".*Matplotlib.*")
    import colour_demosaicing as cd

    tile, min_seconds = request["tile"], request["min_seconds"]
    rows, colour_speed = [], {}
    for folder in request["datasets"]:
        paths = sorted(glob.glob(os.path.join(folder, "*.png")))
        if request.get("images"):
            paths = paths[: request["images"]]
        if not paths:
            raise SystemExit(f"no PNG images in {folder}")
        images = [cv2.cvtColor(cv2.imread(p, cv2.IMREAD_COLOR), cv2.COLOR_BGR2RGB) for p in paths]
        for bits in request["depths"]:
            scale, dtype, peak = (1, np.uint8, 255.0) if bits == 8 else (257, np.uint16, 65535.0)
            methods = [
                ("OpenCV", "bilinear", opencv_method(cv2.COLOR_BayerBG2RGB, dtype), True),
                ("OpenCV", "EA", opencv_method(cv2.COLOR_BayerBG2RGB_EA, dtype), True),
            ]
            if bits == 8:  # OpenCV's VNG takes 8-bit mosaics only
                methods.append(("OpenCV", "VNG", opencv_method(cv2.COLOR_BayerBG2RGB_VNG, dtype), True))
            methods += [
                ("colour-demosaicing", "bilinear", colour_method(cd.demosaicing_CFA_Bayer_bilinear, peak), False),
                ("colour-demosaicing", "Malvar2004", colour_method(cd.demosaicing_CFA_Bayer_Malvar2004, peak), False),
                ("colour-demosaicing", "Menon2007", colour_method(cd.demosaicing_CFA_Bayer_Menon2007, peak), False),
            ]
            base = mosaic(images[0], scale)
            h, w = base.shape[0] & ~1, base.shape[1] & ~1
            big = np.tile(base[:h, :w], (tile // h + 1, tile // w + 1))[:tile, :tile].copy()
            for library, name, run, per_depth in methods:
                scores = [cpsnr(run(mosaic(im, scale)), im.astype(np.float64) * scale, peak) for im in images]
                key = (library, name, folder)
                if per_depth or key not in colour_speed:
                    seconds = best_seconds(run, big, min_seconds)
                    if not per_depth:
                        colour_speed[key] = seconds
                else:
                    seconds = colour_speed[key]
                rows.append({
                    "dataset": os.path.basename(os.path.normpath(folder)),
                    "library": library,
                    "method": name,
                    "bits": bits,
                    "cpsnr_db": float(np.mean(scores)),
                    "mpix_per_s": tile * tile / seconds / 1e6,
                    "images": len(images),
                })
                print(f"peers: {library} {name} {bits}-bit {rows[-1]['dataset']}", file=sys.stderr, flush=True)
    versions = {"opencv": cv2.__version__, "colour-demosaicing": cd.__version__, "numpy": np.__version__}
    print(json.dumps({"rows": rows, "versions": versions}))


if __name__ == "__main__":
    main(json.loads(sys.argv[1]))

"""The learned peer of `camsim bench`'s demosaicing chart: demosaicnet (Gharbi, Chaurasia,
Paris and Durand, "Deep joint demosaicking and denoising", SIGGRAPH Asia 2016; the pretrained
Bayer network in the PyPI wheel) on the CPU, measured as camsim measures its own methods: an
RGGB mosaic of each 8-bit RGB image, CPSNR over the image less a 10-pixel border at 8 and 16
bits (one network pass serves both: the 16-bit mosaic divided by its peak is the 8-bit one),
and single-thread Mpix/s on a square mosaic `tile` pixels wide tiled from the set's first image.

The network takes a three-channel masked mosaic in GRBG order and returns a smaller image
(unpadded convolutions). The RGGB mosaic becomes GRBG with one mirrored column on the left, and
a mirrored margin of PAD pixels (even, so the CFA phase is kept) gives the network the
context its border needs; the output is cropped back to the image. Run by camsim with one JSON
argument {datasets, images, depths, tile}; prints {rows, versions}."""

import glob
import json
import os
import sys
import time
import warnings

warnings.filterwarnings("ignore")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402
import torch as th  # noqa: E402
from PIL import Image  # noqa: E402

import demosaicnet  # noqa: E402

th.set_num_threads(1)
PAD = 48


def rggb(rgb):
    m = np.empty(rgb.shape[:2], dtype=np.float32)
    m[0::2, 0::2] = rgb[0::2, 0::2, 0]
    m[0::2, 1::2] = rgb[0::2, 1::2, 1]
    m[1::2, 0::2] = rgb[1::2, 0::2, 1]
    m[1::2, 1::2] = rgb[1::2, 1::2, 2]
    return m


def run(net, mosaic):
    """The network's RGB (h x w x 3 in [0, 1]) for an RGGB mosaic in [0, 1]."""
    h, w = mosaic.shape
    padded = np.pad(mosaic, ((PAD, PAD), (PAD + 1, PAD)), mode="reflect")
    masked = demosaicnet.bayer(np.repeat(padded[None], 3, axis=0))
    with th.no_grad():
        out = net(th.from_numpy(np.ascontiguousarray(masked)).unsqueeze(0)).squeeze(0).numpy()
    oy = (padded.shape[0] - out.shape[1]) // 2
    ox = (padded.shape[1] - out.shape[2]) // 2
    y0, x0 = PAD - oy, PAD + 1 - ox
    if y0 < 0 or x0 < 0:
        raise SystemExit("demosaicnet's border is wider than the padding")
    return np.clip(out[:, y0:y0 + h, x0:x0 + w].transpose(1, 2, 0), 0.0, 1.0)


def cpsnr(out, truth, peak):
    d = (out - truth)[10:-10, 10:-10]
    return 10 * np.log10(peak * peak / np.mean(d * d))


def main(request):
    net = demosaicnet.BayerDemosaick(pretrained=True).eval()
    tile, rows = request["tile"], []
    for folder in request["datasets"]:
        paths = sorted(glob.glob(os.path.join(folder, "*.png")))
        if request.get("images"):
            paths = paths[: request["images"]]
        images = [np.asarray(Image.open(p).convert("RGB"), dtype=np.float64) for p in paths]
        outputs = [run(net, rggb(im) / 255.0) for im in images]
        base = rggb(images[0]) / 255.0
        h, w = base.shape[0] & ~1, base.shape[1] & ~1
        big = np.tile(base[:h, :w], (tile // h + 1, tile // w + 1))[:tile, :tile].copy()
        start = time.perf_counter()
        run(net, big)
        seconds = time.perf_counter() - start
        for bits in request["depths"]:
            peak = 255.0 if bits == 8 else 65535.0
            scale = 1.0 if bits == 8 else 257.0
            scores = [cpsnr(np.rint(o * peak), im * scale, peak) for o, im in zip(outputs, images)]
            rows.append({
                "dataset": os.path.basename(os.path.normpath(folder)),
                "library": "demosaicnet",
                "method": "Gharbi2016",
                "bits": bits,
                "cpsnr_db": float(np.mean(scores)),
                "mpix_per_s": tile * tile / seconds / 1e6,
                "images": len(images),
            })
        print(f"peers: demosaicnet {rows[-1]['dataset']}", file=sys.stderr, flush=True)
    versions = {"demosaicnet": getattr(demosaicnet, "__version__", "0.0.14"), "torch": th.__version__}
    print(json.dumps({"rows": rows, "versions": versions}))


if __name__ == "__main__":
    main(json.loads(sys.argv[1]))

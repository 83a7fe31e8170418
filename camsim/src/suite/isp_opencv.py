"""The OpenCV peer of `camsim bench isp`: the same stages done the usual OpenCV way, timed in
the same run. Embedded in camsim and run with the oracle environment's Python.

argv[1]: a JSON object {frame, width, height, pattern, black, white, wb, ccm, sharpen,
denoise_sigma, threads, repeats, output}
where frame is a file of width * height little-endian uint16 raw samples, and output (optional)
a file to write the last run's 8-bit RGB image into, row by row. Prints one JSON object
{ms_per_frame, stages}.

Stages: black level (cv2.subtract, saturating), Bayer bilinear demosaic at 16 bits
(cv2.cvtColor), white balance and normalisation as one per-channel scale to float32
(cv2.multiply), the colour matrix (cv2.transform), then 8-bit linear codes
(cv2.convertScaleAbs) through an sRGB table (cv2.LUT); with denoise_sigma (camsim's raw noise
reduction on), after the black level, cv2.fastNlMeansDenoising on the mosaic packed as four
channels (each 2x2 block one pixel: template 3, search 5 packed pixels, as camsim's default
window; 16-bit, so the L1 norm, h the noise's deviation in codes); with sharpen > 0, an unsharp mask on
the luma of YCrCb (cv2.cvtColor, cv2.GaussianBlur 3x3, cv2.addWeighted, back to RGB). OpenCV
has no defect correction, so none runs. The 8-bit linear step loses shadow detail camsim keeps: this is a speed peer."""

import json
import sys
import time

import cv2
import numpy as np

CODES = {"RGGB": cv2.COLOR_BayerBG2RGB, "BGGR": cv2.COLOR_BayerRG2RGB,
         "GRBG": cv2.COLOR_BayerGB2RGB, "GBRG": cv2.COLOR_BayerGR2RGB}


def main():
    a = json.loads(sys.argv[1])
    cv2.setNumThreads(a["threads"])
    w, h = a["width"], a["height"]
    raw = np.fromfile(a["frame"], dtype="<u2").reshape(h, w)
    black, white = a["black"], a["white"]
    scale = tuple(g / (white - black) for g in a["wb"])
    ccm = np.array(a["ccm"], dtype=np.float32)
    x = np.arange(256) / 255.0
    lut = np.round(255 * np.where(x <= 0.0031308, 12.92 * x, 1.055 * x ** (1 / 2.4) - 0.055)).astype(np.uint8)
    code = CODES[a["pattern"]]
    sharpen = a.get("sharpen", 0.0)
    sigma = a.get("denoise_sigma")

    def denoise(d):
        packed = np.ascontiguousarray(d.reshape(h // 2, 2, w // 2, 2).transpose(0, 2, 1, 3).reshape(h // 2, w // 2, 4))
        packed = cv2.fastNlMeansDenoising(packed, h=[float(sigma)] * 4, templateWindowSize=3,
                                          searchWindowSize=5, normType=cv2.NORM_L1)
        return np.ascontiguousarray(packed.reshape(h // 2, w // 2, 2, 2).transpose(0, 2, 1, 3).reshape(h, w))

    def run():
        d = cv2.subtract(raw, black)
        if sigma:
            d = denoise(d)
        rgb = cv2.cvtColor(d, code)
        lin = cv2.multiply(rgb, scale, dtype=cv2.CV_32F)
        out = cv2.transform(lin, ccm)
        encoded = cv2.LUT(cv2.convertScaleAbs(out, alpha=255.0), lut)
        if sharpen > 0:
            ycc = cv2.cvtColor(encoded, cv2.COLOR_RGB2YCrCb)
            y = ycc[:, :, 0]
            blur = cv2.GaussianBlur(y, (3, 3), 0)
            ycc[:, :, 0] = cv2.addWeighted(y, 1 + sharpen, blur, -sharpen, 0)
            encoded = cv2.cvtColor(ycc, cv2.COLOR_YCrCb2RGB)
        return encoded

    best = float("inf")
    for _ in range(a["repeats"]):
        t = time.perf_counter()
        image = run()
        best = min(best, time.perf_counter() - t)
    if a.get("output"):
        np.ascontiguousarray(image).tofile(a["output"])
    print(json.dumps({
        "ms_per_frame": best * 1e3,
        "stages": "cv2.subtract, "
        + ("cv2.fastNlMeansDenoising (packed 4-channel mosaic, template 3, search 5), " if sigma else "")
        + "cv2.cvtColor (Bayer, 16-bit), cv2.multiply, cv2.transform, cv2.convertScaleAbs, cv2.LUT"
        + (", unsharp mask on YCrCb luma" if sharpen > 0 else ""),
    }))


if __name__ == "__main__":
    main()

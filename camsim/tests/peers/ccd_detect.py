"""colour-checker-detection (PyPI) on the frames camsim's chart detection is tested on: its
segmentation detector (detect_colour_checkers_segmentation, default settings) on each 8-bit
sRGB PNG. Run with the tuning peers' Python (.venv-tune).

argv[1]: a JSON object {frames: [{png, truth: 24 x [r, g, b]}]}, truth the frame's own values
(0..1) at each patch's drawn centre. A detected patch counts as identified when its colour is
nearer its own truth than any other patch's. Prints {versions, frames: [{checkers,
identified}]}: the checkers found and the most patches any of them identified.
"""

import json
import sys
from importlib.metadata import version

import numpy as np
from colour_checker_detection import detect_colour_checkers_segmentation


def identified(swatches, truth):
    d = np.linalg.norm(swatches[:, None, :] - truth[None, :, :], axis=2)
    return int(np.sum(np.argmin(d, axis=1) == np.arange(len(truth))))


def main():
    a = json.loads(sys.argv[1])
    out = []
    for frame in a["frames"]:
        truth = np.asarray(frame["truth"], dtype=np.float64)
        try:
            found = detect_colour_checkers_segmentation(frame["png"], additional_data=True)
        except Exception as e:  # a detector failure is a frame not found, said why
            out.append({"checkers": 0, "identified": 0, "error": f"{type(e).__name__}: {e}"})
            continue
        best = 0
        for checker in found:
            swatches = np.asarray(checker.swatch_colours, dtype=np.float64)[:, :3]
            if swatches.shape[0] == len(truth):
                best = max(best, identified(swatches, truth))
        out.append({"checkers": len(found), "identified": best})
    print(json.dumps({"versions": {"colour-checker-detection": version("colour-checker-detection")},
                      "frames": out}))


if __name__ == "__main__":
    main()

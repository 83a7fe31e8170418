"""Crops two ColorChecker patches (orange and purplish blue, with the board around them) from a
`camsim demo` output folder at 4x, truth beside the float ISP's output, for the README:

    .venv/bin/python scripts/demo-patches.py camsim-demo docs/demo-patches.png

Needs numpy and imageio (both in tests/oracle/requirements.txt)."""

import sys

import imageio.v3 as iio
import numpy as np

# Rows and columns of the demo's 600 x 400 frame holding patches 7 and 8 (orange, purplish blue).
ROWS, COLUMNS, ZOOM = slice(140, 200), slice(140, 240), 4


def crop(path):
    image = iio.imread(path)[ROWS, COLUMNS]
    return np.kron(image, np.ones((ZOOM, ZOOM, 1), dtype=image.dtype))


def main():
    folder, out = sys.argv[1], sys.argv[2]
    truth, ours = crop(f"{folder}/truth.png"), crop(f"{folder}/srgb.png")
    gap = np.full((truth.shape[0], 8, 3), 255, dtype=truth.dtype)
    iio.imwrite(out, np.concatenate([truth, gap, ours], axis=1))


if __name__ == "__main__":
    main()

"""Shared fixtures: the repository's files and the `camsim` command the package is compared
with (CAMSIM_BIN, else the workspace's debug build, which `cargo test` leaves behind). A
missing command or data file fails the tests: nothing here skips."""

from __future__ import annotations

import os
import pathlib
import subprocess

import numpy as np
import pytest

import camsim

REPO = pathlib.Path(__file__).resolve().parents[2]
REAL_DNGS = sorted((REPO / "data" / "real-dng").glob("*.dng"))


def cli_path() -> pathlib.Path:
    path = pathlib.Path(os.environ.get("CAMSIM_BIN", REPO / "target" / "debug" / "camsim"))
    if not path.is_file():
        raise RuntimeError(
            f"the camsim command is not at {path}: build it (cargo build -p camsim) or set CAMSIM_BIN"
        )
    return path


def run_cli(*args: str) -> str:
    done = subprocess.run(
        [str(cli_path()), *args], capture_output=True, text=True, check=False
    )
    if done.returncode != 0:
        raise AssertionError(f"camsim {' '.join(args)} failed: {done.stderr}")
    return done.stdout


def read_ppm(path: pathlib.Path) -> np.ndarray:
    """A binary PPM (P6, 8 or 16 bits) as (height, width, 3)."""
    data = path.read_bytes()
    fields = []
    at = 0
    while len(fields) < 4:
        while data[at : at + 1].isspace():
            at += 1
        if data[at : at + 1] == b"#":
            at = data.index(b"\n", at) + 1
            continue
        end = at
        while not data[end : end + 1].isspace():
            end += 1
        fields.append(data[at:end])
        at = end
    at += 1
    magic, width, height, maxval = fields[0], int(fields[1]), int(fields[2]), int(fields[3])
    assert magic == b"P6", magic
    dtype = np.dtype(">u2") if maxval > 255 else np.dtype("u1")
    pixels = np.frombuffer(data, dtype=dtype, count=width * height * 3, offset=at)
    return pixels.reshape(height, width, 3).astype(np.uint16 if maxval > 255 else np.uint8)


@pytest.fixture(scope="session")
def small_dng(tmp_path_factory: pytest.TempPathFactory) -> pathlib.Path:
    """A 14-bit DNG of a 192 x 128 crop of the real Canon frame, with its colour tags, written
    by the package (so the crop keeps the file's pattern phase and levels)."""
    assert REAL_DNGS, "data/real-dng has no DNG"
    source = REPO / "data" / "real-dng" / "canon-550d-colorchart-14bit.dng"
    raw = camsim.imread(source)
    crop = np.ascontiguousarray(raw.raw_image[400:528, 600:792])
    path = tmp_path_factory.mktemp("dng") / "crop.dng"
    camsim.imwrite_dng(path, crop, like=raw, noise_profile=[1.6e-4, 8.7e-7])
    return path

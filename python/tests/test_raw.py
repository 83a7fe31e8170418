"""Raw files: camsim.imread against rawpy (LibRaw), the zero-copy view, DNG writing, and
hostile input."""

from __future__ import annotations

import pathlib

import numpy as np
import pytest
import rawpy

import camsim

from conftest import REAL_DNGS


@pytest.mark.parametrize("path", REAL_DNGS, ids=lambda p: p.name)
def test_values_equal_rawpys(path: pathlib.Path) -> None:
    with camsim.imread(path) as ours, rawpy.imread(str(path)) as theirs:
        assert np.array_equal(ours.raw_image, theirs.raw_image_visible)
        assert ours.raw_image.dtype == np.uint16
        assert np.array_equal(ours.raw_pattern, theirs.raw_pattern)
        assert ours.black_level_per_channel == list(theirs.black_level_per_channel)
        assert ours.white_level == theirs.white_level
        assert ours.camera_whitebalance is not None
        # LibRaw reports the second green as 0 where it equals the first.
        np.testing.assert_allclose(ours.camera_whitebalance[:3], theirs.camera_whitebalance[:3], rtol=1e-6)
        assert ours.color_matrix is not None and ours.color_matrix.shape == (3, 3)
        sizes = theirs.sizes
        assert (ours.width, ours.height) == (sizes.width, sizes.height)
        # LibRaw's crop margins count from the raw's corner, camsim's from the active area's.
        crop = (sizes.crop_left_margin - sizes.left_margin, sizes.crop_top_margin - sizes.top_margin, sizes.crop_width, sizes.crop_height)
        assert ours.default_crop == crop
        assert ours.orientation == {0: 1, 3: 3, 5: 8, 6: 6}[sizes.flip]


def test_raw_image_is_a_view_not_a_copy() -> None:
    raw = camsim.imread(REAL_DNGS[0])
    a, b = raw.raw_image, raw.raw_image
    assert a.__array_interface__["data"][0] == b.__array_interface__["data"][0]
    assert not a.flags.writeable
    with pytest.raises(ValueError):
        a[0, 0] = 1
    # The array keeps the decoded file alive after the Raw is closed.
    raw.close()
    assert int(a.sum()) > 0
    with pytest.raises(ValueError, match="closed"):
        raw.raw_image


def test_metadata_of_a_camsim_dng(small_dng: pathlib.Path) -> None:
    with camsim.imread(small_dng) as raw:
        assert (raw.width, raw.height, raw.pattern, raw.bits) == (192, 128, "RGGB", 14)
        assert raw.noise_profile is not None and raw.noise_profile.shape == (3, 2)
        np.testing.assert_allclose(raw.noise_profile[:, 0], 1.6e-4, rtol=1e-6)
        assert raw.orientation == 1 and raw.default_crop is None
        assert raw.calibrations and raw.calibrations[0]["color_matrix"].shape == (3, 3)


def test_imwrite_dng_round_trip(tmp_path: pathlib.Path) -> None:
    source = camsim.imread(REAL_DNGS[-1])
    out = tmp_path / "copy.dng"
    camsim.imwrite_dng(out, source, orientation=6, default_crop=(2, 2, 100, 80), baseline_exposure=0.5)
    copy = camsim.imread(out)
    assert np.array_equal(copy.raw_image, source.raw_image)
    assert copy.pattern == source.pattern and copy.black_level == source.black_level
    assert copy.white_level == source.white_level
    np.testing.assert_allclose(copy.as_shot_neutral, source.as_shot_neutral, rtol=1e-6)
    np.testing.assert_allclose(copy.color_matrix, source.color_matrix, rtol=1e-6)
    assert (copy.orientation, copy.default_crop, copy.baseline_exposure) == (6, (2, 2, 100, 80), 0.5)
    with rawpy.imread(str(out)) as theirs:
        assert np.array_equal(theirs.raw_image_visible, source.raw_image)
    # Developed, the copy turns upright and crops as its tags say.
    assert copy.postprocess(demosaic="bilinear").shape == (100, 80, 3)


def test_imwrite_dng_from_an_array(tmp_path: pathlib.Path) -> None:
    mosaic = (np.arange(64 * 48, dtype=np.uint16).reshape(48, 64) * 3) % 4096
    out = tmp_path / "array.dng"
    camsim.imwrite_dng(out, mosaic, pattern="GBRG", bits=12, black_level=64, noise_profile=[1e-4, 1e-6])
    raw = camsim.imread(out)
    assert np.array_equal(raw.raw_image, mosaic)
    assert (raw.pattern, raw.bits, raw.black_level, raw.white_level) == ("GBRG", 12, (64,) * 4, 4095)
    with pytest.raises(camsim.OptionError, match="uint16"):
        camsim.imwrite_dng(out, mosaic.astype(np.float32))
    with pytest.raises(camsim.OptionError, match="pattern"):
        camsim.imwrite_dng(out, mosaic, pattern="XYZW")


def test_hostile_and_missing_files(tmp_path: pathlib.Path) -> None:
    with pytest.raises(FileNotFoundError, match="nowhere.dng"):
        camsim.imread(tmp_path / "nowhere.dng")
    good = REAL_DNGS[0].read_bytes()
    cases = {
        "empty.dng": b"",
        "text.dng": b"not a tiff at all" * 10,
        "truncated.dng": good[: len(good) // 3],
        "header-only.dng": good[:64],
    }
    for name, data in cases.items():
        path = tmp_path / name
        path.write_bytes(data)
        with pytest.raises(camsim.FileFormatError) as caught:
            camsim.imread(path)
        message = str(caught.value)
        assert name in message and "\n" not in message, message
        assert isinstance(caught.value, ValueError)
    # Bytes flipped across the file: refused or read, never a crash or a hang.
    rng = np.random.default_rng(7)
    for i in range(40):
        data = bytearray(good[:200_000])
        for at in rng.integers(0, len(data), 20):
            data[int(at)] = int(rng.integers(0, 256))
        path = tmp_path / f"flipped{i}.dng"
        path.write_bytes(bytes(data))
        try:
            camsim.imread(path)
        except camsim.FileFormatError:
            pass


def test_refusals_read_as_the_commands(tmp_path: pathlib.Path) -> None:
    import subprocess

    from conftest import cli_path

    good = REAL_DNGS[0].read_bytes()
    for name, data in {"cut.dng": good[: len(good) // 2], "junk.dng": b"II*\x00" + b"\xff" * 200}.items():
        path = tmp_path / name
        path.write_bytes(data)
        with pytest.raises(camsim.FileFormatError) as caught:
            camsim.imread(path)
        done = subprocess.run(
            [str(cli_path()), "isp", "--input", str(path), "--output", str(tmp_path / "x.png")],
            capture_output=True, text=True, check=False,
        )
        assert done.returncode != 0
        assert str(caught.value) in done.stderr, (str(caught.value), done.stderr)

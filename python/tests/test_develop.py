"""The ISP from Python: byte-identical to `camsim isp` on the same file and options, every
demosaicing method on both paths; options refused with the command line's messages; the
GIL released around the pixel loops."""

from __future__ import annotations

import pathlib
import threading

import numpy as np
import pytest

import camsim

from conftest import read_ppm, run_cli

METHODS = ["nearest", "bilinear", "mhc", "directional"]


@pytest.mark.parametrize("path", ["float", "fixed"])
@pytest.mark.parametrize("method", METHODS)
def test_equals_the_command_line(small_dng: pathlib.Path, tmp_path: pathlib.Path, method: str, path: str) -> None:
    out = tmp_path / "cli.ppm"
    run_cli("isp", "--input", str(small_dng), "--output", str(out), "--demosaic", method, "--path", path, "--threads", "2")
    ours = camsim.imread(small_dng).postprocess(demosaic=method, path=path, threads=3)
    assert ours.dtype == np.uint8 and ours.shape == (128, 192, 3)
    assert np.array_equal(ours, read_ppm(out))


CAMERA_OPTIONS = [
    (
        ["--out-bits", "16", "--sharpen", "0.5", "--look", "vivid", "--dpc-threshold", "200"],
        {"out_bits": 16, "sharpen": 0.5, "look": "vivid", "dpc_threshold": 200},
    ),
    (
        ["--wb", "2,1,1.5", "--ccm", "1.5,-0.3,-0.2,-0.2,1.4,-0.2,0,-0.4,1.4", "--highlight-knee", "1", "--gain", "1.5"],
        {"wb": [2, 1, 1.5], "ccm": np.array([[1.5, -0.3, -0.2], [-0.2, 1.4, -0.2], [0, -0.4, 1.4]]), "highlight_knee": 1.0, "gain": 1.5},
    ),
    (
        ["--awb", "grey-world", "--denoise", "2", "--chroma-denoise", "0", "--distortion", "-0.1,0.02,0,0"],
        {"awb": "grey-world", "denoise": 2.0, "chroma_denoise": 0.0, "distortion": (-0.1, 0.02, 0, 0)},
    ),
    (
        ["--black-level", "2000,2010,2020,2030", "--white-level", "14000", "--noise-profile", "2e-4,1e-6", "--crop", "active"],
        {"black_level": [2000, 2010, 2020, 2030], "white_level": 14000, "noise_profile": [2e-4, 1e-6], "crop": "active"},
    ),
]


@pytest.mark.parametrize("path", ["float", "fixed"])
@pytest.mark.parametrize("flags,options", CAMERA_OPTIONS)
def test_options_equal_the_command_lines(small_dng: pathlib.Path, tmp_path: pathlib.Path, flags, options, path: str) -> None:
    out = tmp_path / "cli.ppm"
    run_cli("isp", "--input", str(small_dng), "--output", str(out), "--path", path, *flags)
    ours = camsim.imread(small_dng).postprocess(path=path, **options)
    assert np.array_equal(ours, read_ppm(out))


def test_develop_an_array_equals_the_file(small_dng: pathlib.Path) -> None:
    raw = camsim.imread(small_dng)
    levels = dict(pattern=raw.pattern, black_level=list(raw.black_level), white_level=raw.white_level, wb=1 / raw.as_shot_neutral)
    from_array, report = camsim.develop(np.array(raw.raw_image), bits=raw.bits, report=True, demosaic="mhc", ccm=np.eye(3), noise_profile=[1.6e-4, 8.7e-7], **levels)
    from_file = raw.postprocess(demosaic="mhc", ccm=np.eye(3), wb=1 / raw.as_shot_neutral)
    assert np.array_equal(from_array, from_file)
    assert report["stages"][0] == "black level" and "mhc" in report["stages"]


def test_linear_output_is_the_float_paths_before_rounding(small_dng: pathlib.Path) -> None:
    raw = camsim.imread(small_dng)
    linear = raw.postprocess(linear=True)
    encoded8 = raw.postprocess()
    assert linear.dtype == np.float32 and linear.shape == encoded8.shape
    srgb = np.where(linear <= 0.0031308, 12.92 * linear, 1.055 * np.power(linear, 1 / 2.4) - 0.055)
    assert np.abs(np.round(srgb * 255) - encoded8).max() <= 1
    # The linear output is the exact curve of the encoded output, up to 16-bit rounding.
    encoded16 = raw.postprocess(out_bits=16, highlight_knee=1.0) / 65535.0
    exact = np.where(encoded16 <= 0.04045, encoded16 / 12.92, ((encoded16 + 0.055) / 1.055) ** 2.4)
    linear16 = raw.postprocess(linear=True, highlight_knee=1.0)
    assert np.abs(linear16 - exact).max() < 2e-5
    with pytest.raises(camsim.OptionError, match="float path"):
        raw.postprocess(linear=True, path="fixed")


def test_refusals_carry_the_command_lines_messages(small_dng: pathlib.Path) -> None:
    raw = camsim.imread(small_dng)
    with pytest.raises(camsim.OptionError, match=r"^demosaic must be one of nearest, bilinear, mhc, directional \(got \"fancy\"\)$"):
        raw.postprocess(demosaic="fancy")
    with pytest.raises(camsim.OptionError, match="unknown option \"colour\""):
        raw.postprocess(colour=1)
    with pytest.raises(camsim.OptionError, match="wb or awb"):
        raw.postprocess(wb=[1, 1, 1], awb="grey-world")
    with pytest.raises(camsim.OptionError, match="ccm must be 9 finite numbers"):
        raw.postprocess(ccm=[1, 2, 3])
    with pytest.raises(camsim.OptionError, match="out_bits must be 8 or 16"):
        raw.postprocess(out_bits=12)
    with pytest.raises(camsim.ProcessingError):
        raw.postprocess(gain=100.0)
    with pytest.raises(camsim.OptionError, match="uint16"):
        camsim.develop(np.zeros((8, 8), np.float32))
    with pytest.raises(camsim.OptionError, match="shape"):
        camsim.develop(np.zeros((2, 8, 8), np.uint16))
    for error in (camsim.OptionError, camsim.ProcessingError, camsim.FileFormatError):
        assert issubclass(error, ValueError)


def test_threads_develop_in_parallel_with_the_gil_released(small_dng: pathlib.Path) -> None:
    raw = camsim.imread(small_dng)
    big = np.tile(np.array(raw.raw_image), (8, 8))  # 1536 x 1024
    expected = camsim.develop(big, bits=14, black_level=2048, demosaic="directional", threads=1)
    results = {}
    running = threading.Event()

    def work(name: str) -> None:
        running.set()
        results[name] = camsim.develop(big, bits=14, black_level=2048, demosaic="directional", threads=1)

    workers = [threading.Thread(target=work, args=(n,)) for n in ("a", "b")]
    for w in workers:
        w.start()
    running.wait()
    # While the developers run, this thread keeps running Python: it could not if they held
    # the GIL through their pixel loops.
    spins = 0
    while any(w.is_alive() for w in workers):
        spins += 1
    for w in workers:
        w.join()
    assert spins > 10_000, spins
    assert np.array_equal(results["a"], expected) and np.array_equal(results["b"], expected)


def test_demosaic_equals_the_command_line(tmp_path: pathlib.Path) -> None:
    rng = np.random.default_rng(3)
    mosaic = rng.integers(0, 65535, (40, 56), dtype=np.uint16)
    source = tmp_path / "mosaic.pgm"
    source.write_bytes(b"P5 56 40 65535\n" + mosaic.astype(">u2").tobytes())
    for method in camsim.DEMOSAIC_METHODS:
        out = tmp_path / f"{method}.ppm"
        run_cli("demosaic", "--method", method, "--pattern", "GRBG", "--input", str(source), "--output", str(out))
        ours = camsim.demosaic(mosaic, "GRBG", method)
        assert ours.dtype == np.uint16 and np.array_equal(ours, read_ppm(out)), method
    eight = camsim.demosaic((mosaic >> 8).astype(np.uint8), "RGGB", "mhc")
    assert eight.dtype == np.uint8 and eight.shape == (40, 56, 3)
    with pytest.raises(camsim.OptionError, match="method must be one of"):
        camsim.demosaic(mosaic, "RGGB", "ahd")


def test_white_balance_and_colour_matrix_fit() -> None:
    # A grey world under a light that doubles red and halves blue.
    rng = np.random.default_rng(5)
    grey = rng.uniform(0.1, 0.6, (64, 64))
    light = {"R": 0.8, "G": 0.4, "B": 0.2}
    mosaic = np.empty((64, 64), np.uint16)
    for (dy, dx), colour in zip([(0, 0), (0, 1), (1, 0), (1, 1)], "RGGB"):
        mosaic[dy::2, dx::2] = np.round(grey[dy::2, dx::2] * light[colour] * 4095)
    est = camsim.estimate_white_balance(mosaic, "RGGB", "grey-world", bits=12)
    np.testing.assert_allclose(est["gains"], [0.5, 1.0, 2.0], rtol=0.03)
    m = np.array([[1.6, -0.4, -0.2], [-0.3, 1.5, -0.2], [0.0, -0.5, 1.5]])
    camera = rng.uniform(0, 1, (24, 3))
    fitted = camsim.fit_ccm(camera, camera @ m.T)
    np.testing.assert_allclose(fitted, m, atol=1e-9)


def test_shading_grid_defects_and_calibration_equal_the_config_files(small_dng: pathlib.Path, tmp_path: pathlib.Path) -> None:
    grid = np.empty((3, 4, 4))
    for y in range(3):
        for x in range(4):
            r2 = ((x - 1.5) / 1.5) ** 2 + ((y - 1) / 1.0) ** 2
            grid[y, x] = [1 + 0.4 * r2, 1 + 0.3 * r2, 1 + 0.3 * r2, 1 + 0.5 * r2]
    defects = [(10, 20), (100, 64), (3, 3)]
    nodes = ", ".join("[" + ", ".join(repr(float(g)) for g in node) + "]" for node in grid.reshape(-1, 4))
    config = tmp_path / "camera.toml"
    config.write_text(
        f"defects = {[list(d) for d in defects]}\n"
        "[lsc]\ngrid-width = 4\ngrid-height = 3\n"
        f"gains = [{nodes}]\n"
    )
    for path in ("float", "fixed"):
        out = tmp_path / f"cli-{path}.ppm"
        run_cli("isp", "--input", str(small_dng), "--output", str(out), "--config", str(config), "--path", path)
        ours = camsim.imread(small_dng).postprocess(lsc=grid, defects=defects, path=path)
        assert np.array_equal(ours, read_ppm(out)), path
    with pytest.raises(camsim.OptionError, match="lsc must be"):
        camsim.imread(small_dng).postprocess(lsc=np.ones((3, 4)))


def test_out_is_written_in_place(small_dng: pathlib.Path) -> None:
    raw = camsim.imread(small_dng)
    expected = raw.postprocess(demosaic="mhc")
    out = np.zeros((128, 192, 3), np.uint8)
    assert raw.postprocess(demosaic="mhc", out=out) is out
    assert np.array_equal(out, expected)
    wide = np.zeros((128, 192, 3), np.uint16)
    assert np.array_equal(raw.postprocess(out_bits=16, out=wide), raw.postprocess(out_bits=16))
    linear = np.zeros((128, 192, 3), np.float32)
    assert np.array_equal(raw.postprocess(linear=True, out=linear), raw.postprocess(linear=True))
    with pytest.raises(camsim.OptionError, match=r"shape \(128, 192, 3\)"):
        raw.postprocess(out=np.zeros((192, 128, 3), np.uint8))
    with pytest.raises(camsim.OptionError, match="uint16"):
        raw.postprocess(out_bits=16, out=out)
    with pytest.raises(camsim.OptionError, match="C-contiguous"):
        raw.postprocess(out=np.zeros((128, 192, 3), np.float64))
    # A framed output (the file's crop and orientation) is written framed.
    turned = np.zeros((192, 128, 3), np.uint8)
    copy = small_dng.parent / "turned.dng"
    camsim.imwrite_dng(copy, raw, orientation=6)
    again = camsim.imread(copy)
    assert np.array_equal(again.postprocess(out=turned), again.postprocess())


def test_option_refusals_are_the_commands_words(small_dng: pathlib.Path, tmp_path: pathlib.Path) -> None:
    import subprocess

    from conftest import cli_path

    raw = camsim.imread(small_dng)
    cases = [
        (["--ccm", "1,2,3"], {"ccm": [1, 2, 3]}),
        (["--black-level", "1,2"], {"black_level": [1, 2]}),
        (["--noise-profile", "1,2,3"], {"noise_profile": [1, 2, 3]}),
        (["--distortion", "0.1,0.2"], {"distortion": [0.1, 0.2]}),
        (["--gain", "100"], {"gain": 100.0}),
    ]
    for flags, options in cases:
        done = subprocess.run(
            [str(cli_path()), "isp", "--input", str(small_dng), "--output", str(tmp_path / "x.png"), *flags],
            capture_output=True, text=True, check=False,
        )
        assert done.returncode != 0
        with pytest.raises(ValueError) as caught:
            raw.postprocess(**options)
        # The same sentence, the option named as Python spells it.
        key = next(iter(options))
        expected = str(caught.value).replace(key, "--" + key.replace("_", "-"), 1)
        assert expected in done.stderr or str(caught.value) in done.stderr, (str(caught.value), done.stderr)


def test_calibration_file_equals_the_command_lines(small_dng: pathlib.Path, tmp_path: pathlib.Path) -> None:
    calibration = tmp_path / "nikon.toml"
    run_cli("calibrate", "--camera", "nikon-5100", "--output", str(calibration))
    for path in ("float", "fixed"):
        out = tmp_path / f"cli-{path}.ppm"
        run_cli("isp", "--input", str(small_dng), "--output", str(out), "--calibration", str(calibration), "--path", path)
        ours = camsim.imread(small_dng).postprocess(calibration=calibration, path=path)
        assert np.array_equal(ours, read_ppm(out)), path
    with pytest.raises(FileNotFoundError):
        camsim.imread(small_dng).postprocess(calibration=tmp_path / "none.toml")


def test_tuning_file_equals_the_command_lines(tmp_path: pathlib.Path) -> None:
    """`tuning=` develops as `camsim isp --tuning` and a config file's `tuning` key do."""
    captures = tmp_path / "captures"
    run_cli("tune-captures", "--out", str(captures))
    tuning = tmp_path / "tuning.toml"
    run_cli("tune", "--captures", str(captures), "--out", str(tuning))
    chart = captures / "chart_D65_6499k_1000l.dng"
    cli = tmp_path / "cli.ppm"
    run_cli("isp", "--input", str(chart), "--output", str(cli), "--tuning", str(tuning))
    config = tmp_path / "isp.toml"
    config.write_text('tuning = "tuning.toml"\n')
    from_config = tmp_path / "config.ppm"
    run_cli("isp", "--input", str(chart), "--output", str(from_config), "--config", str(config))
    ours = camsim.imread(chart).postprocess(tuning=tuning)
    assert np.array_equal(ours, read_ppm(cli))
    assert np.array_equal(ours, read_ppm(from_config))
    # The tuning changes the development: not the plain defaults.
    assert not np.array_equal(ours, camsim.imread(chart).postprocess())

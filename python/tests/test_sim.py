"""The simulator and the lens equations from Python: the same frames as `camsim demo` for
the same seed, and optics-core's functions over arrays."""

from __future__ import annotations

import json
import math
import pathlib

import numpy as np
import pytest

import camsim
from camsim import optics

from conftest import REPO, run_cli


def test_render_and_capture_equal_the_demos(tmp_path: pathlib.Path) -> None:
    size = dict(width=72, height=48, spp=4, seed=3)
    run_cli("demo", "--output", str(tmp_path), "--width", "72", "--height", "48", "--spp", "4", "--seed", "3", "--threads", "2")
    calls = []
    radiance = camsim.render("demo", threads=2, progress=lambda done, total: calls.append((done, total)), **size)
    assert isinstance(radiance, np.ndarray) and radiance.dtype == np.float32
    assert radiance.shape == (48, 72, 3) and not radiance.flags.writeable
    assert radiance.bands is not None and radiance.bands.shape[:2] == (48, 72)
    assert calls and calls[-1][0] == calls[-1][1]
    capture = camsim.Sensor(seed=3).capture(radiance)
    with camsim.imread(tmp_path / "raw.dng") as demo:
        assert np.array_equal(capture.mosaic, demo.raw_image)
        assert capture.black_level == demo.black_level and capture.white_level == demo.white_level
        np.testing.assert_allclose(capture.noise_profile, demo.noise_profile, rtol=1e-6)
    # The same seed renders the same radiance; another seed does not.
    again = camsim.render("demo", **size)
    assert np.array_equal(again, radiance)
    assert not np.array_equal(camsim.render("demo", **{**size, "seed": 4}), radiance)


def test_render_a_scene_dict_like_its_toml(tmp_path: pathlib.Path) -> None:
    scene = {
        "film": {"width": 32, "height": 24, "spp": 2, "max_depth": 4},
        "camera": {"position": [0.0, 1.0, 4.0], "target": [0.0, 1.0, 0.0], "up": [0.0, 1.0, 0.0], "fov_deg": 40.0},
        "materials": {"white": {"rgb": [0.7, 0.7, 0.7]}},
        "shape": [
            {"name": "ball", "type": "sphere", "material": "white", "center": [0.0, 1.0, 0.0], "radius": 0.8},
            {"name": "lamp", "type": "sphere", "material": "white", "center": [0.0, 4.0, 2.0], "radius": 0.5, "emission": {"rgb": [8.0, 8.0, 8.0]}},
        ],
    }
    from camsim._sim import _toml

    toml_path = tmp_path / "sphere.toml"
    toml_path.write_text(_toml(scene))
    try:
        from_dict = camsim.render(scene)
    except camsim.ProcessingError as e:  # the scene format differs: show the message
        raise AssertionError(f"scene dict refused: {e}\n{_toml(scene)}") from e
    from_file = camsim.render(toml_path)
    assert from_dict.shape == (24, 32, 3)
    assert np.array_equal(from_dict, from_file) and float(from_dict.max()) > 0


def test_simulator_refusals() -> None:
    with pytest.raises(camsim.ProcessingError, match="nowhere.toml"):
        camsim.render("nowhere.toml")
    radiance = camsim.render("cornell-box", width=16, height=16, spp=1)
    with pytest.raises(camsim.ProcessingError):
        camsim.Sensor(camera="no-such-camera").capture(radiance)
    with pytest.raises(TypeError, match="camsim.render"):
        camsim.Sensor().capture(np.zeros((4, 4, 3), np.float32))


def test_optics_over_arrays() -> None:
    f, n, c = 50.0, 2.8, 0.03
    h = f * f / (n * c) + f
    assert optics.hyperfocal_distance(f, n, c) == pytest.approx(h)
    assert math.isinf(float(optics.hyperfocal_distance(f, n, 0.0)))
    s = np.array([[2000.0, 3000.0], [h, np.inf]])
    near, far, total = optics.depth_of_field(f, n, c, s)
    assert near.shape == far.shape == total.shape == (2, 2)
    assert near[0, 1] == pytest.approx(3000.0 * (h - f) / (h + 3000.0 - 2 * f))
    assert math.isinf(far[1, 0]) and math.isinf(total[1, 1])
    # A point at the near limit blurs to exactly the acceptable circle.
    coc = optics.circle_of_confusion(f, n, s[0], near[0])
    np.testing.assert_allclose(coc, c, rtol=1e-9)
    np.testing.assert_allclose(optics.f_number([50, 100], [25, 25]), [2.0, 4.0])
    np.testing.assert_allclose(optics.image_distance(50.0, [100.0, 25.0]), [100.0, -50.0])
    assert math.isinf(float(optics.image_distance(50.0, 50.0)))
    np.testing.assert_allclose(optics.power_dioptres([50.0, 200.0]), [20.0, 5.0])
    np.testing.assert_allclose(optics.lensmaker_focal_length(1.5, 100.0, -100.0), 100.0)
    np.testing.assert_allclose(optics.stops_between(2.8, 5.6), 2.0, rtol=1e-12)
    with pytest.raises(camsim.ProcessingError, match="element 1"):
        optics.f_number([50.0, -1.0], 2.0)


def test_lenses_from_python_equal_the_command() -> None:
    path = REPO / "camsim" / "lenses" / "tessar-f4.5.toml"
    report = optics.lens(path, 486.1327)
    assert report == json.loads(run_cli("lens", str(path), "--json", "--wavelength", "486.1327"))
    assert report["f_number"] == pytest.approx(4.5, rel=2e-3)
    rays = [
        {"origin": [0.001, 0.0, -5.0], "direction": [0.0, 0.0, 1.0]},
        {"origin": [25.0, 0.0, -5.0], "direction": [0.0, 0.0, 1.0]},
    ]
    out = optics.trace(path, rays)
    assert abs(out[0]["image"][0]) < 1e-6
    assert out[1]["lost_at_surface"] == 1 and out[1]["lost_because"] == "vignetted"
    with pytest.raises(FileNotFoundError, match="nowhere.toml"):
        optics.lens("nowhere.toml")

"""camsim.dataset on a local Ray cluster of two worker processes: the dataset equals the one
``camsim dataset --range`` writes in one process, byte for byte, with a task that fails once
retried and nothing written twice; a dict spec and one sample in-process; raw files developed
as Ray tasks equal Raw.postprocess."""

from __future__ import annotations

import pathlib
import shutil
from typing import Dict, List

import numpy as np
import pytest
from PIL import Image

import camsim
import camsim.dataset

from conftest import REAL_DNGS, REPO, run_cli

COUNT = 6

SPEC = {
    "dataset": {"seed": 1, "count": COUNT, "width": 40, "height": 30, "spp": 2, "isp": True},
    "scene": {
        "generators": ["colorchecker", "primitives", "textured-plane", "demo", "cornell-box"],
        "images": str(REPO / "data" / "kodak"),
        "texture_cells": 24,
    },
    "camera": {
        "f_number": {"min": 1.4, "max": 16, "log": True},
        "motion_blur_px": [0, 4],
        "aperture": ["disk", "hexagon"],
    },
    "sensor": {
        "camera": ["nikon-5100", "canon-eos-5d-mark-ii"],
        "illuminant": ["A", "D65"],
        "iso": {"min": 100, "max": 3200, "log": True},
        "pattern": ["RGGB", "BGGR"],
        "bits": [10, 12, 14],
    },
}


def _write_spec(path: pathlib.Path) -> pathlib.Path:
    from camsim._sim import _toml

    path.write_text(_toml(SPEC))
    return path


def _files(root: pathlib.Path) -> Dict[str, bytes]:
    """Every sample's files and the spec copy: temporary folders and the manifest left out."""
    return {
        str(p.relative_to(root)): p.read_bytes()
        for p in sorted(root.rglob("*"))
        if p.is_file()
        and not any(part.startswith(".partial-") for part in p.relative_to(root).parts)
        and p.name != "manifest.jsonl"
    }


def test_ray_generates_the_commands_dataset_and_retries_without_duplicates(
    tmp_path: pathlib.Path,
) -> None:
    spec = _write_spec(tmp_path / "spec.toml")
    reference = tmp_path / "reference"
    run_cli("dataset", "--spec", str(spec), "--out", str(reference), "--range", f"0..{COUNT}",
            "--threads", "1")
    out = tmp_path / "ray"
    markers = tmp_path / "markers"
    markers.mkdir()
    # Index 2's first attempt fails after leaving a half-written folder.
    summary = camsim.dataset.generate(
        spec, out, workers=2, progress=False, _failure=(str(markers), [2])
    )
    assert (markers / "failed-2").exists(), "the injected failure did not happen"
    assert summary["written"] == COUNT and summary["present"] == 0
    assert [s["index"] for s in summary["samples"]] == list(range(COUNT))
    for s in summary["samples"]:
        assert s["status"] == "written"
        assert s["total_s"] >= s["render_s"] > 0
    expected, got = _files(reference), _files(out)
    assert sorted(got) == sorted(expected)
    for name, data in expected.items():
        assert got[name] == data, f"{name} differs"
    # The failed attempt's folder is left for the manifest to report, never taken for a sample.
    report = camsim.dataset.manifest(out)
    assert report["complete"] == COUNT and report["missing"] == [] and report["corrupt"] == []
    assert len(report["partial"]) == 1 and report["partial"][0].startswith(".partial-000002-")
    lines = (out / "manifest.jsonl").read_text().splitlines()
    assert len(lines) == COUNT

    # Again: every sample already there, nothing rewritten.
    before = {p: p.stat().st_mtime_ns for p in out.rglob("raw.dng")}
    again = camsim.dataset.generate(spec, out, workers=2, progress=False)
    assert again["written"] == 0 and again["present"] == COUNT
    assert {p: p.stat().st_mtime_ns for p in out.rglob("raw.dng")} == before


def test_one_sample_in_process_from_a_dict_spec(tmp_path: pathlib.Path) -> None:
    spec = _write_spec(tmp_path / "spec.toml")
    reference = tmp_path / "reference"
    run_cli("dataset", "--spec", str(spec), "--out", str(reference), "--index", "3")
    result = camsim.dataset.sample(SPEC, tmp_path / "dict", 3, threads=2)
    assert result["status"] == "written" and result["index"] == 3
    for name in ["raw.dng", "truth_camera.exr", "truth_srgb.exr", "srgb.png", "record.json"]:
        assert (tmp_path / "dict" / "000003" / name).read_bytes() == (
            reference / "000003" / name
        ).read_bytes(), name
    assert camsim.dataset.sample(SPEC, tmp_path / "dict", 3)["status"] == "present"
    with pytest.raises(camsim.OptionError, match="--index"):
        camsim.dataset.sample(SPEC, tmp_path / "dict", COUNT)
    bad = dict(SPEC, sensor={"illuminant": "D66"})
    with pytest.raises(camsim.OptionError, match='sensor.illuminant: "D66" is not one of'):
        camsim.dataset.sample(bad, tmp_path / "bad", 0)


def test_develop_a_folder_of_raws_on_ray(tmp_path: pathlib.Path) -> None:
    # The two camera DNGs and three simulated ones, under distinct names.
    spec = _write_spec(tmp_path / "spec.toml")
    run_cli("dataset", "--spec", str(spec), "--out", str(tmp_path / "ds"), "--range", "0..3")
    raws: List[pathlib.Path] = list(REAL_DNGS)
    for i in range(3):
        target = tmp_path / f"sim{i}.dng"
        shutil.copy(tmp_path / "ds" / f"{i:06}" / "raw.dng", target)
        raws.append(target)
    options = {"demosaic": "mhc", "path": "fixed"}
    out = tmp_path / "developed"
    results = camsim.dataset.develop(raws, out, options, workers=2, progress=False)
    assert [r["path"] for r in results] == [str(p) for p in raws]
    assert all(r["status"] == "written" for r in results)
    for raw_path, r in zip(raws, results):
        with camsim.imread(raw_path) as raw:
            expected = raw.postprocess(**options)
        got = np.asarray(Image.open(r["output"]))
        assert got.shape == expected.shape
        assert np.array_equal(got, expected), raw_path.name
    again = camsim.dataset.develop(raws, out, options, workers=2, progress=False)
    assert all(r["status"] == "present" for r in again)
    with pytest.raises(camsim.OptionError, match="demosaic"):
        camsim.dataset.develop(raws, out, {"demosaic": "none"}, workers=2, progress=False)
    with pytest.raises(camsim.OptionError, match="share a name"):
        camsim.dataset.develop([raws[0], raws[0]], out, options, progress=False)

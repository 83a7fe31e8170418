"""Thin-lens camera math from optics-core, vectorised over numpy arrays.

Lengths are in millimetres; every argument broadcasts against the others as numpy's
arithmetic does, and an infinite distance (a far limit beyond infinity focus, a hyperfocal
distance for ``c = 0``) is ``inf``. A refused element (a negative focal length, a subject
inside the focal length) raises :class:`camsim.ProcessingError` naming its flat index.

>>> from camsim import optics
>>> near, far, total = optics.depth_of_field(50.0, 2.8, 0.03, [2000.0, 3000.0])
>>> bool(near[1] < 3000.0 < far[1])
True
"""

from __future__ import annotations

import json
import os
from typing import Any, Dict, List, Sequence, Tuple

import numpy as np

from . import _camsim

__all__ = [
    "f_number",
    "entrance_pupil_diameter",
    "stops_between",
    "exposure_ratio",
    "hyperfocal_distance",
    "depth_of_field",
    "circle_of_confusion",
    "image_distance",
    "lateral_magnification",
    "sensor_distance_for_focus",
    "power_dioptres",
    "lensmaker_focal_length",
    "lens",
    "trace",
]


def _apply(name: str, *args: Any) -> Tuple[np.ndarray, ...]:
    arrays = np.broadcast_arrays(*(np.asarray(a, dtype=np.float64) for a in args))
    shape = arrays[0].shape
    flat = [np.ascontiguousarray(a.ravel()) for a in arrays]
    results = _camsim.optics_apply(name, flat)
    if not results:  # no elements
        return tuple(np.empty(shape) for _ in range(3 if name == "depth_of_field" else 1))
    return tuple(r.reshape(shape) for r in results)


def _one(name: str, *args: Any) -> np.ndarray:
    return _apply(name, *args)[0]


def f_number(focal_length: Any, pupil_diameter: Any) -> np.ndarray:
    """``N = f / D``."""
    return _one("f_number", focal_length, pupil_diameter)


def entrance_pupil_diameter(focal_length: Any, f_number: Any) -> np.ndarray:
    """``D = f / N``."""
    return _one("entrance_pupil_diameter", focal_length, f_number)


def stops_between(n_from: Any, n_to: Any) -> np.ndarray:
    """Stops from f-number ``n_from`` to ``n_to``: ``2 log2(n_to / n_from)``."""
    return _one("stops_between", n_from, n_to)


def exposure_ratio(n_from: Any, n_to: Any) -> np.ndarray:
    """Light at ``n_to`` relative to ``n_from``: ``(n_from / n_to)^2``."""
    return _one("exposure_ratio", n_from, n_to)


def hyperfocal_distance(focal_length: Any, f_number: Any, coc: Any) -> np.ndarray:
    """``H = f^2 / (N c) + f``; ``inf`` for ``c = 0``."""
    return _one("hyperfocal_distance", focal_length, f_number, coc)


def depth_of_field(
    focal_length: Any, f_number: Any, coc: Any, focus_distance: Any
) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Near limit, far limit and total depth of field when focused at ``focus_distance``
    (``inf`` allowed); far and total are ``inf`` at or beyond the hyperfocal distance."""
    near, far, total = _apply("depth_of_field", focal_length, f_number, coc, focus_distance)
    return near, far, total


def circle_of_confusion(
    focal_length: Any, f_number: Any, focus_distance: Any, point_distance: Any
) -> np.ndarray:
    """Blur circle diameter (mm, on the sensor) of a point at ``point_distance`` when focused
    at ``focus_distance``."""
    return _one("circle_of_confusion", focal_length, f_number, focus_distance, point_distance)


def image_distance(focal_length: Any, object_distance: Any) -> np.ndarray:
    """The Gaussian lens formula's image distance: positive for a real image behind the
    lens, negative for a virtual one, ``inf`` for an object at the focal point."""
    return _one("image_distance", focal_length, object_distance)


def lateral_magnification(focal_length: Any, object_distance: Any) -> np.ndarray:
    """``m = -z' / z``."""
    return _one("lateral_magnification", focal_length, object_distance)


def sensor_distance_for_focus(focal_length: Any, object_distance: Any) -> np.ndarray:
    """Lens-to-sensor distance that focuses a subject at ``object_distance``."""
    return _one("sensor_distance_for_focus", focal_length, object_distance)


def power_dioptres(focal_length: Any) -> np.ndarray:
    """``1000 / f`` (f in mm)."""
    return _one("power_dioptres", focal_length)


def lensmaker_focal_length(n: Any, r1: Any, r2: Any) -> np.ndarray:
    """Thin-lens focal length from the lensmaker's equation (radii in mm, ``inf`` flat)."""
    return _one("lensmaker_focal_length", n, r1, r2)


D_LINE_NM = 587.5618


def lens(
    path: "str | os.PathLike[str]", wavelength_nm: float = D_LINE_NM, pbrt_abbe: float = 50.0
) -> Dict[str, Any]:
    """A real lens from its file (camsim's TOML lens format, or pbrt's ``.dat`` with single
    indices as model glasses of Abbe number ``pbrt_abbe``): the paraxial data at
    ``wavelength_nm`` and, when the file gives its field, the curves against it -- the same
    dictionary ``camsim lens FILE --json`` prints.
    """
    return json.loads(_camsim.lens_report(os.fspath(path), float(wavelength_nm), float(pbrt_abbe)))


def trace(
    path: "str | os.PathLike[str]",
    rays: Sequence[Dict[str, Any]],
    wavelength_nm: float = D_LINE_NM,
    pbrt_abbe: float = 50.0,
) -> List[Dict[str, Any]]:
    """Rays through a lens file to its paraxial image plane at ``wavelength_nm``: each ray a
    dict with ``origin`` and ``direction`` (mm, the first vertex's frame, ``z`` towards the
    image) and optionally ``wavelength_nm``; each outcome says where it lands (``image``) or
    which surface lost it and why -- as ``camsim lens FILE --trace RAYS.json --json``.
    """
    return json.loads(
        _camsim.lens_trace(os.fspath(path), json.dumps(list(rays)), float(wavelength_nm), float(pbrt_abbe))
    )

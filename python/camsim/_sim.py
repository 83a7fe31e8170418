"""The simulator: scenes rendered to linear radiance and captured through the sensor model."""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from typing import Any, Callable, Dict, List, Mapping, Optional, Tuple, Union

import numpy as np

from . import _camsim

__all__ = ["render", "scene_names", "cameras", "Radiance", "Sensor", "Capture"]


def scene_names() -> List[str]:
    """The built-in scenes ``render`` knows by name."""
    return list(_camsim.scene_names())


def cameras() -> List[str]:
    """The cameras whose measured spectral responses the sensor model has."""
    return list(_camsim.cameras())


class Radiance(np.ndarray):
    """Linear sRGB radiance, float32 (height, width, 3), as :func:`render` returns it: a numpy
    array that also carries the rendering (``.rendering``: the scene's camera and, for a
    spectral scene, ``.bands``, the band radiances the sensor integrates)."""

    rendering: Optional["_camsim.Rendering"]

    def __array_finalize__(self, obj: Any) -> None:
        self.rendering = getattr(obj, "rendering", None)

    @property
    def bands(self) -> Optional[np.ndarray]:
        """Band radiances (height, width, bands) of a spectral scene, else ``None``."""
        return None if self.rendering is None else self.rendering.bands


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float, np.integer, np.floating)):
        return repr(float(v)) if isinstance(v, (float, np.floating)) else str(int(v))
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, (list, tuple, np.ndarray)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, Mapping):
        return "{" + ", ".join(f"{json.dumps(str(k))} = {_toml_value(x)}" for k, x in v.items()) + "}"
    raise TypeError(f"scene value {v!r} cannot be written as TOML")


def _toml(scene: Mapping[str, Any]) -> str:
    """A scene dict as TOML text with the scene file's layout: plain keys, then tables, then
    arrays of tables (``[[object]]``-style lists of dicts)."""
    lines: List[str] = []
    tables: List[Tuple[str, Any]] = []
    for k, v in scene.items():
        if isinstance(v, Mapping) or (
            isinstance(v, (list, tuple)) and v and all(isinstance(x, Mapping) for x in v)
        ):
            tables.append((k, v))
        else:
            lines.append(f"{json.dumps(str(k))} = {_toml_value(v)}")
    for k, v in tables:
        items = [v] if isinstance(v, Mapping) else list(v)
        header = f"[{json.dumps(str(k))}]" if isinstance(v, Mapping) else f"[[{json.dumps(str(k))}]]"
        for item in items:
            lines.append("")
            lines.append(header)
            for kk, vv in item.items():
                lines.append(f"{json.dumps(str(kk))} = {_toml_value(vv)}")
    return "\n".join(lines) + "\n"


def render(
    scene: Union[str, "os.PathLike[str]", Mapping[str, Any]] = "cornell-box",
    *,
    width: Optional[int] = None,
    height: Optional[int] = None,
    spp: Optional[int] = None,
    seed: int = 1,
    threads: int = 0,
    max_depth: Optional[int] = None,
    progress: Optional[Callable[[int, int], None]] = None,
) -> Radiance:
    """Renders a scene with camsim's path tracer, as ``camsim render`` does: a built-in name
    (see :func:`scene_names`), the path of a scene TOML file, or a dict with the TOML's keys.
    Width, height and samples per pixel default to the scene's; ``threads=0`` uses every
    core; ``progress(done, total)`` is called as tiles finish. Returns linear sRGB radiance,
    float32 (height, width, 3), a read-only :class:`Radiance`."""
    if isinstance(scene, Mapping):
        rendering = _camsim.render_scene(
            "<dict>", _toml(scene), width, height, spp, seed, threads, max_depth, progress
        )
    else:
        rendering = _camsim.render_scene(
            os.fspath(scene), None, width, height, spp, seed, threads, max_depth, progress
        )
    out = rendering.rgb.view(Radiance)
    out.rendering = rendering
    return out


@dataclass
class Capture:
    """A raw frame captured by :meth:`Sensor.capture`: the mosaic (uint16, height x width)
    and what the sensor knows of it."""

    mosaic: np.ndarray
    pattern: str
    bits: int
    black_level: Tuple[int, int, int, int]
    white_level: int
    exposure_s: float
    #: (3, 2): S, O per colour R, G, B (variance ``S x + O`` at signal ``x`` of white).
    noise_profile: np.ndarray
    #: (x, y) of each defective pixel.
    defects: List[Tuple[int, int]] = field(default_factory=list)
    #: Noise-free camera RGB at the sensor, in units of white, float32 (height, width, 3).
    truth_camera: Optional[np.ndarray] = None


@dataclass
class Sensor:
    """The sensor model of ``camsim demo``: a camera's measured spectral response (see
    :func:`cameras`), ISO, exposure (``None`` meters it), ADC bits, CFA pattern, and the
    ``"realistic"`` preset (shot, read, PRNU, DSNU and row noise, shading, defects, optical
    low-pass filter) or ``"ideal"``. ``seed`` seeds the frame's temporal noise (``camsim
    demo --seed``), ``fixed_seed`` the sensor's fixed patterns (default: the preset's)."""

    camera: str = "nikon-5100"
    iso: float = 100.0
    exposure: Optional[float] = None
    seed: int = 1
    bits: int = 12
    pattern: str = "RGGB"
    preset: str = "realistic"
    fixed_seed: Optional[int] = None

    def capture(self, radiance: Radiance) -> Capture:
        """Captures a :func:`render` result (its spectral bands, if any, and its camera's
        lens for vignetting) into a raw mosaic."""
        rendering = getattr(radiance, "rendering", None)
        if rendering is None:
            raise TypeError("capture takes what camsim.render returns (a camsim Radiance)")
        mosaic, meta = _camsim.capture(
            rendering,
            self.camera,
            self.preset,
            float(self.iso),
            None if self.exposure is None else float(self.exposure),
            int(self.bits),
            self.pattern,
            int(self.seed),
            self.fixed_seed,
        )
        return Capture(
            mosaic=mosaic,
            pattern=meta["pattern"],
            bits=meta["bits"],
            black_level=tuple(meta["black_level"]),
            white_level=meta["white_level"],
            exposure_s=meta["exposure_s"],
            noise_profile=np.asarray(meta["noise_profile"]),
            defects=list(meta["defects"]),
            truth_camera=meta["truth_camera"],
        )



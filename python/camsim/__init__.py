"""camsim for Python: a camera simulator and firmware-grade ISP on numpy arrays.

Raw files::

    import camsim
    with camsim.imread("photo.dng") as raw:          # rawpy's shape of API
        mosaic = raw.raw_image                       # uint16 (H, W), a view, no copy
        rgb = raw.postprocess(demosaic="mhc")        # uint8 (H, W, 3) sRGB

The ISP on arrays: :func:`develop`, :func:`demosaic`, :func:`estimate_white_balance`,
:func:`fit_ccm`. The simulator: :func:`render`, :class:`Sensor`. Thin-lens optics:
:mod:`camsim.optics`. Datasets at scale, on Ray: :mod:`camsim.dataset`.

Every pixel loop runs in Rust with the GIL released, so threads develop in parallel. Errors
are :class:`FileFormatError`, :class:`OptionError` and :class:`ProcessingError` (all
``ValueError``) or ``OSError`` for files the system refuses, each with the one-line message
the ``camsim`` command prints.
"""

from __future__ import annotations

import json
import os
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from . import _camsim
from ._camsim import FileFormatError, OptionError, ProcessingError
from . import optics
from . import dataset
from ._sim import Capture, Radiance, Sensor, cameras, render, scene_names

__all__ = [
    "Raw",
    "imread",
    "imwrite_dng",
    "develop",
    "demosaic",
    "estimate_white_balance",
    "fit_ccm",
    "DEVELOP_OPTIONS",
    "DEMOSAIC_METHODS",
    "AWB_METHODS",
    "render",
    "scene_names",
    "cameras",
    "Radiance",
    "Sensor",
    "Capture",
    "optics",
    "dataset",
    "FileFormatError",
    "OptionError",
    "ProcessingError",
]

PathLike = Union[str, "os.PathLike[str]"]

#: The keyword options :func:`develop` and :meth:`Raw.postprocess` take: ``camsim isp``'s
#: flags with ``_`` for ``-`` (see :func:`develop`).
DEVELOP_OPTIONS: Tuple[str, ...] = tuple(_camsim.develop_options())

#: The methods :func:`demosaic` runs, cheapest first.
DEMOSAIC_METHODS: Tuple[str, ...] = (
    "nearest",
    "bilinear",
    "bilinear-opencv",
    "mhc",
    "directional",
    "directional-fixed",
)

#: The automatic white-balance methods.
AWB_METHODS: Tuple[str, ...] = ("grey-world", "white-patch", "shades-of-grey", "grey-edge")

# LibRaw's colour indices for R, G, B (the second green of a 2x2 block is 3).
_COLOUR_INDEX = {"R": 0, "G": 1, "B": 2}


def _array(value: Any) -> Optional[np.ndarray]:
    return None if value is None else np.asarray(value, dtype=np.float64)


class Raw:
    """A raw frame and what its file states, as :func:`imread` returns it.

    Attributes follow rawpy's names where rawpy has one:

    - ``raw_image``: the samples, ``uint16`` (height, width) for a CFA mosaic, (height,
      width, 3) for a linear DNG; a read-only view of the decoded file, not a copy.
    - ``pattern``: the CFA pattern by its top-left 2x2 block (``"RGGB"``, ...), ``None`` for a
      linear frame; ``raw_pattern``: the same as rawpy's (2, 2) colour indices (0 R, 1 G,
      2 B, 3 the second G).
    - ``black_level``: per 2x2 CFA position, row by row; ``black_level_per_channel``: per
      colour index, as rawpy; ``white_level``; ``bits``.
    - ``as_shot_neutral``: the illuminant's colour in camera RGB (DNG AsShotNeutral);
      ``camera_whitebalance``: its reciprocals as four gains (R, G, B, G), as rawpy.
    - ``color_matrix``, ``forward_matrix``, ``camera_calibration``: (3, 3) arrays of the
      calibration under D65 (else the last one), ``calibrations``: every one, with its
      illuminant; ``analog_balance``.
    - ``noise_profile``: (3, 2) array of (S, O) per colour R, G, B: a sample's variance is
      ``S x + O`` at signal ``x`` (a fraction of white above black); ``None`` if the file has
      none.
    - ``baseline_exposure`` (EV), ``orientation`` (TIFF 1..8), ``default_crop`` ((left, top,
      width, height) or ``None``), ``camera_model``, ``defects`` ((x, y) pairs the file's
      bad-pixel opcodes list), ``opcodes_not_applied``.

    Use it as a context manager (``with camsim.imread(p) as raw:``) as with rawpy; closing
    drops the decoded samples once no array refers to them.
    """

    def __init__(self, file: "_camsim.RawFile") -> None:
        self._file = file
        meta: Dict[str, Any] = file.metadata()
        self.path: str = meta["path"]
        self.width: int = meta["width"]
        self.height: int = meta["height"]
        self.pattern: Optional[str] = meta["pattern"]
        self.bits: int = meta["bits"]
        self.black_level: Tuple[int, int, int, int] = tuple(meta["black_level"])
        self.white_level: int = meta["white_level"]
        self.baseline_exposure: Optional[float] = meta["baseline_exposure"]
        self.orientation: int = meta["orientation"]
        self.default_crop: Optional[Tuple[int, int, int, int]] = meta["default_crop"]
        self.defects: List[Tuple[int, int]] = list(meta["defects"] or [])
        self.opcodes_not_applied: List[Tuple[str, bool]] = list(meta["opcodes_not_applied"])
        profile = meta["noise_profile"]
        self.noise_profile: Optional[np.ndarray] = _array(profile)
        self.camera_model: Optional[str] = meta.get("camera_model")
        self.as_shot_neutral: Optional[np.ndarray] = _array(meta.get("as_shot_neutral"))
        self.as_shot_white_xy: Optional[np.ndarray] = _array(meta.get("as_shot_white_xy"))
        self.analog_balance: Optional[np.ndarray] = _array(meta.get("analog_balance"))
        self.calibrations: List[Dict[str, Any]] = [
            {
                "illuminant": c["illuminant"],
                "illuminant_code": c["illuminant_code"],
                "color_matrix": _array(c["color_matrix"]),
                "forward_matrix": _array(c["forward_matrix"]),
                "camera_calibration": _array(c["camera_calibration"]),
            }
            for c in meta.get("calibrations", [])
        ]
        chosen = next(
            (c for c in self.calibrations if c["illuminant"] == "D65"),
            self.calibrations[-1] if self.calibrations else None,
        )
        self.color_matrix: Optional[np.ndarray] = chosen["color_matrix"] if chosen else None
        self.forward_matrix: Optional[np.ndarray] = chosen["forward_matrix"] if chosen else None
        self.camera_calibration: Optional[np.ndarray] = (
            chosen["camera_calibration"] if chosen else None
        )

    @property
    def raw_image(self) -> np.ndarray:
        """The samples: a read-only ``uint16`` view, (height, width) or (height, width, 3)."""
        if self._file is None:
            raise ValueError("the Raw is closed")
        return self._file.raw_image

    @property
    def raw_image_visible(self) -> np.ndarray:
        """rawpy's name for the visible samples: the same array as ``raw_image`` (a DNG's
        active area is what camsim decodes)."""
        return self.raw_image

    @property
    def raw_pattern(self) -> Optional[np.ndarray]:
        """The CFA pattern as rawpy's (2, 2) ``uint8`` colour indices, ``None`` if linear."""
        if self.pattern is None:
            return None
        idx = [_COLOUR_INDEX[c] for c in self.pattern]
        # LibRaw's rule: the green that shares its row with blue is the second green.
        for i, c in enumerate(self.pattern):
            row = self.pattern[2 * (i // 2) : 2 * (i // 2) + 2]
            if c == "G" and "B" in row:
                idx[i] = 3
        return np.array(idx, dtype=np.uint8).reshape(2, 2)

    @property
    def black_level_per_channel(self) -> List[int]:
        """Black level per colour index (R, G, B, second G), as rawpy reports it."""
        if self.pattern is None:
            r, g, b, _ = self.black_level
            return [r, g, b, g]
        out = [0, 0, 0, 0]
        pattern = self.raw_pattern
        assert pattern is not None
        for position, index in enumerate(pattern.ravel()):
            out[int(index)] = self.black_level[position]
        return out

    @property
    def camera_whitebalance(self) -> Optional[List[float]]:
        """The as-shot white balance as rawpy's four gains (R, G, B, G): ``1 / neutral``."""
        if self.as_shot_neutral is None:
            return None
        r, g, b = (1.0 / float(v) for v in self.as_shot_neutral)
        return [r, g, b, g]

    def postprocess(self, **options: Any) -> np.ndarray:
        """Develops the frame as ``camsim isp`` does with the same options; the file's
        pattern, levels, as-shot white balance, colour matrices, noise profile, defect lists,
        shading maps and framing are the defaults. See :func:`develop` for the options."""
        image, _ = self.develop(**options)
        return image

    def develop(self, **options: Any) -> Tuple[np.ndarray, Dict[str, Any]]:
        """:meth:`postprocess` that also returns the report (stages run, white balance,
        noise profile and its source, times) as a dict, as ``camsim isp --json`` prints it."""
        if self._file is None:
            raise ValueError("the Raw is closed")
        image, report = _camsim.develop_file(self._file, **options)
        return image, json.loads(report)

    def close(self) -> None:
        """Drops this object's hold on the decoded samples."""
        self._file = None

    def __enter__(self) -> "Raw":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __repr__(self) -> str:
        kind = self.pattern or "linear RGB"
        return f"<camsim.Raw {self.width}x{self.height} {kind} {self.bits}-bit {self.path!r}>"


def imread(path: PathLike) -> Raw:
    """Reads a raw file: a DNG (uncompressed, lossless JPEG or lossy CinemaDNG; CFA or
    linear), or a single-channel 8- or 16-bit PNG/PGM mosaic. Hostile or broken files raise
    :class:`FileFormatError` (a ``ValueError``); files the system refuses raise ``OSError``."""
    return Raw(_camsim.read_raw(os.fspath(path)))


def imwrite_dng(
    path: PathLike,
    raw_or_array: Union[Raw, np.ndarray],
    *,
    pattern: Optional[str] = None,
    bits: Optional[int] = None,
    black_level: Optional[Union[int, Sequence[int]]] = None,
    white_level: Optional[int] = None,
    camera_model: Optional[str] = None,
    as_shot_neutral: Optional[Sequence[float]] = None,
    color_matrix: Optional[Any] = None,
    illuminant: str = "D65",
    forward_matrix: Optional[Any] = None,
    calibrations: Optional[List[Dict[str, Any]]] = None,
    analog_balance: Optional[Sequence[float]] = None,
    noise_profile: Optional[Any] = None,
    baseline_exposure: Optional[float] = None,
    orientation: Optional[int] = None,
    default_crop: Optional[Tuple[int, int, int, int]] = None,
    like: Optional[Raw] = None,
) -> None:
    """Writes a DNG as ``camsim demo`` writes ``raw.dng``: uncompressed 16-bit samples, the CFA
    pattern and levels, the colour tags (ColorMatrix and optional ForwardMatrix per
    illuminant, AsShotNeutral, AnalogBalance), NoiseProfile, BaselineExposure, Orientation and
    DefaultCrop.

    ``raw_or_array`` is a :class:`Raw` (its metadata are the defaults, and a DNG's opcodes and
    defect lists are kept) or a ``uint16`` array: (height, width) for a CFA mosaic,
    (height, width, 3) for linear RGB. Keyword arguments override. ``noise_profile`` is (S, O)
    or six values (S, O per colour R, G, B) or a (3, 2) array. ``calibrations`` is a list of
    at most two dicts with ``illuminant``, ``color_matrix`` and optionally ``forward_matrix``
    and ``camera_calibration``; ``color_matrix``/``illuminant``/``forward_matrix`` give one.
    ``like``: a :class:`Raw` whose tags an array is written with (a crop of a camera's frame
    keeps its pattern, levels and colour if it starts on an even row and column).
    """
    source = raw_or_array if isinstance(raw_or_array, Raw) else like
    if source is not None:
        samples = source.raw_image if isinstance(raw_or_array, Raw) else np.asarray(raw_or_array)
        defaults: Dict[str, Any] = {
            "pattern": source.pattern or "RGGB",
            "bits": source.bits,
            "black_level": list(source.black_level)
            if source.pattern
            else list(source.black_level[:3]),
            "white_level": source.white_level,
            "camera_model": source.camera_model or "camsim",
            "as_shot_neutral": source.as_shot_neutral,
            "calibrations": source.calibrations,
            "analog_balance": source.analog_balance,
            "noise_profile": source.noise_profile,
            "baseline_exposure": source.baseline_exposure,
            "orientation": source.orientation,
            "default_crop": source.default_crop,
        }
    else:
        samples = np.asarray(raw_or_array)
        defaults = {
            "pattern": "RGGB",
            "bits": 16,
            "black_level": [0],
            "white_level": None,
            "camera_model": "camsim",
            "as_shot_neutral": None,
            "calibrations": [],
            "analog_balance": None,
            "noise_profile": None,
            "baseline_exposure": None,
            "orientation": 1,
            "default_crop": None,
        }
    if samples.dtype != np.uint16:
        raise OptionError(
            f"raw_or_array must be a camsim.Raw or a uint16 array (got dtype {samples.dtype})"
        )
    if like is not None and not isinstance(raw_or_array, Raw):
        # The file's crop belongs to the whole frame, not to an array cut from it.
        defaults["default_crop"] = None
    given = {
        "pattern": pattern,
        "bits": bits,
        "black_level": None if black_level is None else list(np.atleast_1d(black_level)),
        "white_level": white_level,
        "camera_model": camera_model,
        "as_shot_neutral": as_shot_neutral,
        "analog_balance": analog_balance,
        "noise_profile": noise_profile,
        "baseline_exposure": baseline_exposure,
        "orientation": orientation,
        "default_crop": default_crop,
    }
    settings = {**defaults, **{k: v for k, v in given.items() if v is not None}}
    if calibrations is not None:
        settings["calibrations"] = calibrations
    elif color_matrix is not None:
        settings["calibrations"] = [
            {"illuminant": illuminant, "color_matrix": color_matrix, "forward_matrix": forward_matrix}
        ]
    bits_ = int(settings["bits"])
    white = settings["white_level"]
    white = (1 << bits_) - 1 if white is None else int(white)

    def matrix(m: Any) -> Optional[List[List[float]]]:
        return None if m is None else np.asarray(m, dtype=np.float64).reshape(3, 3).tolist()

    def vector(v: Any) -> Optional[List[float]]:
        return None if v is None else [float(x) for x in np.asarray(v, dtype=np.float64).ravel()]

    cals = [
        (
            str(c["illuminant"]),
            matrix(c["color_matrix"]),
            matrix(c.get("forward_matrix")),
            matrix(c.get("camera_calibration")),
        )
        for c in settings["calibrations"]
    ]
    _camsim.write_dng(
        os.fspath(path),
        np.ascontiguousarray(samples),
        str(settings["pattern"]),
        bits_,
        [int(b) for b in settings["black_level"]],
        white,
        str(settings["camera_model"]),
        vector(settings["as_shot_neutral"]),
        cals,
        vector(settings["analog_balance"]),
        vector(settings["noise_profile"]),
        settings["baseline_exposure"],
        int(settings["orientation"]),
        None if settings["default_crop"] is None else tuple(int(v) for v in settings["default_crop"]),
        raw_or_array._file if isinstance(raw_or_array, Raw) else None,
    )


def develop(
    mosaic: np.ndarray, *, bits: int = 16, report: bool = False, **options: Any
) -> Union[np.ndarray, Tuple[np.ndarray, Dict[str, Any]]]:
    """Develops a raw frame held in an array, as ``camsim isp`` develops a file.

    ``mosaic`` is ``uint16`` (height, width) CFA samples, or (height, width, 3) linear RGB;
    ``bits`` (8..16) is the depth of its samples. The options are ``camsim isp``'s flags with
    ``_`` for ``-``, each left out for its default:

    - ``pattern`` (``"RGGB"``, ``"BGGR"``, ``"GRBG"``, ``"GBRG"``), ``black_level`` (one value,
      four per 2x2 position, or three for linear RGB), ``white_level``, ``gain``;
    - ``wb`` (three gains) or ``awb`` (one of :data:`AWB_METHODS`); ``ccm`` (3x3, camera RGB
      to linear sRGB) or ``calibration`` (a ``camsim calibrate`` file); ``tuning`` (a
      ``camsim tune`` file: black level, defects, noise, shading, the white balance through
      its locus and the matrix at that colour temperature, under every other option);
    - ``demosaic`` (``"nearest"``, ``"bilinear"``, ``"mhc"``, ``"directional"``, the default);
    - ``denoise`` and ``chroma_denoise`` (strengths in [0, 4]), ``denoise_search``
      (``"wide"``, the default 5x5 search, or ``"fast"``, 3x3), ``noise_profile`` (S, O or
      six values);
    - ``highlight_knee`` ([0, 1], default 0.9), ``sharpen`` ([0, 4]), ``dpc_threshold``,
      ``defects`` ((x, y) pairs), ``lsc`` ((grid height, grid width, 4) gains), ``look``,
      ``distortion`` (k1, k2, p1, p2[, k3]) and ``camera_matrix`` (fx, fy, cx, cy);
    - ``path`` (``"float"``, the reference, or ``"fixed"``, the firmware's), ``out_bits``
      (8 or 16: ``uint8`` or ``uint16`` sRGB), ``linear=True`` (``float32`` linear sRGB in
      [0, 1]: the float path's output before rounding, decoded with the sRGB curve),
      ``crop`` (``"default"`` or ``"active"``), ``baseline_exposure``, ``threads`` (bands in
      parallel; the output does not depend on it), ``stage_times``;
    - ``out``: a C-contiguous (height, width, 3) array of the output's dtype to write into
      (returned), so a loop over frames reuses one buffer.

    Returns the (height, width, 3) image, and with ``report=True`` also the report dict.
    """
    array = np.asarray(mosaic)
    if array.dtype != np.uint16:
        raise OptionError(f"mosaic must be a uint16 array (got dtype {array.dtype})")
    image, text = _camsim.develop_array(array, int(bits), **options)
    return (image, json.loads(text)) if report else image


def demosaic(mosaic: np.ndarray, pattern: str = "RGGB", method: str = "directional") -> np.ndarray:
    """Demosaics a (height, width) ``uint8`` or ``uint16`` mosaic with one of
    :data:`DEMOSAIC_METHODS` (no other processing): a (height, width, 3) array of the same
    type."""
    return _camsim.demosaic(np.asarray(mosaic), pattern, method)


def estimate_white_balance(
    mosaic: np.ndarray,
    pattern: str = "RGGB",
    method: str = "grey-world",
    *,
    bits: int = 16,
    black_level: Union[int, Sequence[int]] = 0,
    white_level: Optional[int] = None,
) -> Dict[str, Any]:
    """Estimates a (height, width) ``uint16`` mosaic's white balance with one of
    :data:`AWB_METHODS`, over 2x2 superpixels as the ISP's AWB does: a dict with ``gains``
    (R, G, B, green 1), ``neutral`` (the illuminant in camera RGB) and ``cct_k`` (the
    neutral's correlated colour temperature, taking camera RGB as linear sRGB)."""
    white = (1 << int(bits)) - 1 if white_level is None else int(white_level)
    gains, neutral, cct = _camsim.estimate_white_balance(
        np.asarray(mosaic),
        pattern,
        method,
        int(bits),
        [float(b) for b in np.atleast_1d(black_level)],
        white,
    )
    return {"gains": np.array(gains), "neutral": np.array(neutral), "cct_k": cct}


def fit_ccm(camera: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """The least-squares 3x3 colour matrix ``M`` with ``reference ~= camera @ M.T``, from
    (N, 3) patch values (N >= 3), as ``camsim calibrate`` fits it."""
    return _camsim.fit_ccm(
        np.ascontiguousarray(camera, dtype=np.float64),
        np.ascontiguousarray(reference, dtype=np.float64),
    )

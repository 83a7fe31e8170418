"""Type stubs of camsim's compiled module (python/src/*.rs). Users call the wrappers in
camsim/__init__.py, camsim/_sim.py and camsim/optics.py."""

from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple

import numpy as np
import numpy.typing as npt

class FileFormatError(ValueError): ...
class OptionError(ValueError): ...
class ProcessingError(ValueError): ...

class RawFile:
    @property
    def raw_image(self) -> npt.NDArray[np.uint16]: ...
    def metadata(self) -> Dict[str, Any]: ...

def read_raw(path: str) -> RawFile: ...
def write_dng(
    path: str,
    samples: npt.NDArray[np.uint16],
    pattern: str,
    bits: int,
    black_level: List[int],
    white_level: int,
    camera_model: str,
    as_shot_neutral: Optional[List[float]],
    calibrations: List[
        Tuple[str, List[List[float]], Optional[List[List[float]]], Optional[List[List[float]]]]
    ],
    analog_balance: Optional[List[float]],
    noise_profile: Optional[List[float]],
    baseline_exposure: Optional[float],
    orientation: int,
    default_crop: Optional[Tuple[int, int, int, int]],
    source: Optional[RawFile] = None,
) -> None: ...
def develop_file(raw: RawFile, **kwargs: Any) -> Tuple[npt.NDArray[Any], str]: ...
def develop_array(
    mosaic: npt.NDArray[np.uint16], bits: int, **kwargs: Any
) -> Tuple[npt.NDArray[Any], str]: ...
def develop_options() -> List[str]: ...
def demosaic(mosaic: npt.NDArray[Any], pattern: str, method: str) -> npt.NDArray[Any]: ...
def estimate_white_balance(
    mosaic: npt.NDArray[np.uint16],
    pattern: str,
    method: str,
    bits: int,
    black_level: List[float],
    white_level: int,
) -> Tuple[Tuple[float, float, float], Tuple[float, float, float], float]: ...
def fit_ccm(
    camera: npt.NDArray[np.float64], reference: npt.NDArray[np.float64]
) -> npt.NDArray[np.float64]: ...

class Rendering:
    @property
    def rgb(self) -> npt.NDArray[np.float32]: ...
    @property
    def bands(self) -> Optional[npt.NDArray[np.float32]]: ...
    @property
    def scene(self) -> str: ...
    @property
    def spp(self) -> int: ...
    @property
    def seconds(self) -> float: ...

def render_scene(
    scene: str,
    text: Optional[str] = None,
    width: Optional[int] = None,
    height: Optional[int] = None,
    spp: Optional[int] = None,
    seed: int = 1,
    threads: int = 0,
    max_depth: Optional[int] = None,
    progress: Optional[Callable[[int, int], None]] = None,
) -> Rendering: ...
def capture(
    rendering: Rendering,
    camera: str = "nikon-5100",
    preset: str = "realistic",
    iso: float = 100.0,
    exposure: Optional[float] = None,
    bits: int = 12,
    pattern: str = "RGGB",
    seed: int = 1,
    fixed_seed: Optional[int] = None,
) -> Tuple[npt.NDArray[np.uint16], Dict[str, Any]]: ...
def scene_names() -> List[str]: ...
def cameras() -> List[str]: ...
def optics_apply(name: str, args: Sequence[npt.NDArray[np.float64]]) -> List[npt.NDArray[np.float64]]: ...
def lens_report(path: str, wavelength_nm: float, pbrt_abbe: float) -> str: ...
def lens_trace(path: str, rays_json: str, wavelength_nm: float, pbrt_abbe: float) -> str: ...
def dataset_prepare(text: str, dir: str, out: str) -> int: ...
def dataset_sample(text: str, dir: str, out: str, index: int, threads: int = 1) -> str: ...
def dataset_manifest(out: str) -> str: ...
def imwrite(path: str, image: npt.NDArray[np.uint16], bits: int) -> None: ...

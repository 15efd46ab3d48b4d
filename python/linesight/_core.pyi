# Type stubs of linesight._core (the compiled part of the linesight package).
from os import PathLike
from typing import Any, Mapping, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

_Path = Union[str, PathLike[str]]
_Image = npt.NDArray[np.uint8]
_Map = npt.NDArray[np.float32]
_Setting = Union[bool, int, float, str]

class InputError(ValueError): ...
class OptionError(InputError): ...
class UsageError(ValueError): ...

def read_image(path: _Path, grey: bool = False) -> _Image: ...
def read_pfm(path: _Path) -> _Map: ...
def write_pfm(path: _Path, disparity: _Map) -> None: ...
def matchers() -> list[str]: ...
def default_matcher() -> str: ...
def matcher_help() -> str: ...

class Matcher:
    def __init__(
        self,
        method: str = "",
        min_disparity: int = 0,
        num_disparities: int = 64,
        threads: int = 0,
        params: Mapping[str, _Setting] = {},
    ) -> None: ...
    def compute(self, left: _Image, right: _Image) -> Tuple[_Map, _Map]: ...
    @property
    def name(self) -> str: ...
    @property
    def settings(self) -> dict[str, Any]: ...

def compute_disparity(
    left: _Image,
    right: _Image,
    method: str = "",
    min_disparity: int = 0,
    num_disparities: int = 64,
    threads: int = 0,
    params: Mapping[str, _Setting] = {},
) -> _Map: ...

class StereoCalibration:
    @staticmethod
    def read(path: _Path) -> StereoCalibration: ...
    @staticmethod
    def pinhole(
        image_size: Tuple[int, int],
        focal_px: float,
        cx: float,
        cy: float,
        baseline_m: float,
        doffs_px: float = 0.0,
    ) -> StereoCalibration: ...
    def write(self, path: _Path) -> None: ...
    @property
    def image_size(self) -> Tuple[int, int]: ...
    @property
    def focal_px(self) -> float: ...
    @property
    def baseline_m(self) -> float: ...
    def as_dict(self) -> dict[str, Optional[npt.NDArray[np.float64]]]: ...

def detect_pattern(image: _Image, pattern: str) -> dict[str, Any]: ...
def calibrate_stereo(
    left_images: Sequence[_Image],
    right_images: Sequence[_Image],
    pattern: str,
    method: str = "zhang",
) -> Tuple[StereoCalibration, dict[str, Any]]: ...
def calibrate_stereo_from_corners(
    left_corners: Sequence[Optional[npt.NDArray[np.floating[Any]]]],
    right_corners: Sequence[Optional[npt.NDArray[np.floating[Any]]]],
    image_size: Tuple[int, int],
    pattern: str,
    method: str = "zhang",
) -> Tuple[StereoCalibration, dict[str, Any]]: ...

class Rectifier:
    def __init__(self, calibration: StereoCalibration, alpha: float = 0.0) -> None: ...
    def rectify(self, left: _Image, right: _Image) -> Tuple[_Image, _Image]: ...
    @property
    def calibration(self) -> StereoCalibration: ...

class RangingPipeline:
    def __init__(
        self,
        calibration: StereoCalibration,
        method: str = "",
        min_depth_m: float = 0.3,
        max_depth_m: float = 6.0,
        rectified: bool = False,
        threads: int = 0,
        params: Mapping[str, _Setting] = {},
        settings: Mapping[str, _Setting] = {},
        line: bool = False,
    ) -> None: ...
    def range(
        self,
        left: _Image,
        right: _Image,
        rois: Sequence[Sequence[int]] = [],
        auto: bool = False,
    ) -> dict[str, Any]: ...
    def reset_conductor(self) -> None: ...
    @property
    def settings(self) -> dict[str, Any]: ...
    @property
    def calibration(self) -> StereoCalibration: ...

def ranging_settings() -> dict[str, str]: ...
def depth_from_disparity(disparity: _Map, calibration: StereoCalibration) -> _Map: ...
def point_cloud(
    disparity: _Map,
    calibration: StereoCalibration,
    color: Optional[_Image] = None,
    min_depth_m: float = 0.0,
    max_depth_m: float = 0.0,
    stride: int = 1,
) -> Tuple[npt.NDArray[np.float32], Optional[npt.NDArray[np.uint8]]]: ...
def render_scene(
    seed: int = 1,
    obstacles: str = "",
    supersampling: int = 3,
    noise: float = 1.0,
    rectified: bool = False,
) -> dict[str, Any]: ...

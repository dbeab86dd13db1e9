"""Type stubs of the native module ``heliar._heliar`` (PyO3)."""

from datetime import datetime
from os import PathLike
from typing import Any, Dict, List, Optional, Tuple, Union

import numpy as np
import numpy.typing as npt

Time = Union[str, datetime]
"""An RFC 3339 string with offset, or a timezone-aware datetime."""
FrameArray = Union[npt.NDArray[np.float32], npt.NDArray[np.uint8], npt.NDArray[np.uint16]]
"""H×W×3: float32 linear camera values (as an EXR frame), or uint8/uint16 codes (as a PNG)."""
RGB = Tuple[float, float, float]

class HeliarError(Exception):
    """An error of the heliar library; the message is the command line's."""

def sun(
    lat: float,
    lon: float,
    time: Time,
    elevation: float = 0.0,
    pressure: Optional[float] = None,
    temperature: Optional[float] = None,
) -> Dict[str, Any]:
    """Solar position (NREL SPA): the fields of ``heliar sun``."""

def read_frame(path: Union[str, PathLike[str]]) -> FrameArray:
    """Decodes a frame file as heliar reads footage (EXR → float32, PNG → uint8/uint16)."""

class Scene:
    @staticmethod
    def load(path: Union[str, PathLike[str]], allow_outside_scene: bool = False) -> "Scene":
        """Loads and checks a scene folder (raises HeliarError with the CLI's message)."""
    @property
    def root(self) -> str: ...
    @property
    def name(self) -> str: ...
    @property
    def width(self) -> int: ...
    @property
    def height(self) -> int: ...
    @property
    def sequences(self) -> List[str]: ...
    def frame_files(self, sequence: Optional[str] = None) -> List[str]: ...
    def frame_times(self, sequence: Optional[str] = None) -> List[str]: ...
    def sun(self, time: Time) -> Dict[str, Any]:
        """Solar position at the scene's place, with ``dir_world``."""
    def bake(self, force: bool = False) -> bool:
        """Bakes the environment maps (``heliar bake``); True when the cache was used."""
    def estimator(
        self,
        sequence: Optional[str] = None,
        samples: Optional[int] = None,
        sun_bounce: bool = True,
        exposure: Optional[float] = None,
    ) -> "Estimator": ...
    def compositor(
        self,
        sequence: Optional[str] = None,
        samples: int = 4,
        darkening: str = "differential",
        ambient: str = "auto",
        transfer_paths: int = 512,
        volumes: str = "cpu",
        sun_bounce: bool = True,
        exposure: Optional[float] = None,
    ) -> "Compositor": ...

class Estimate:
    """One frame's estimate: the fields of a ``heliar estimate`` JSON line."""

    @property
    def frame(self) -> int: ...
    @property
    def time(self) -> str: ...
    @property
    def status(self) -> str:
        """ok, sun_not_separable, no_direct_sun, night, too_few_samples, saturated, dark_frame."""
    @property
    def fallback(self) -> Optional[str]: ...
    @property
    def pd(self) -> Optional[RGB]:
        """The sun's irradiance on a surface facing it."""
    @property
    def pa(self) -> Optional[RGB]:
        """The sky's irradiance on an unoccluded horizontal surface."""
    @property
    def pd_se(self) -> Optional[RGB]: ...
    @property
    def pa_se(self) -> Optional[RGB]: ...
    @property
    def condition_number(self) -> Optional[float]: ...
    @property
    def residual_rms(self) -> Optional[RGB]: ...
    @property
    def sun(self) -> Dict[str, Any]: ...
    @property
    def smoothed(self) -> Optional[Dict[str, List[float]]]: ...
    @property
    def samples(self) -> Dict[str, int]: ...
    @property
    def relight(self) -> bool: ...
    @property
    def estimate_ms(self) -> float: ...
    def to_dict(self) -> Dict[str, Any]: ...
    def to_json(self) -> str: ...

class Estimator:
    def estimate(self, frame: FrameArray, time: Time, index: Optional[int] = None) -> Estimate:
        """Estimates one frame (GIL released). Raises ValueError/TypeError for a bad array."""
    @property
    def exposure(self) -> float: ...
    @property
    def next_index(self) -> int: ...

class Lighting:
    def __init__(self, sun_dir: Tuple[float, float, float], pd: RGB, pa: RGB, above_horizon: bool = True) -> None: ...
    @property
    def sun_dir(self) -> Tuple[float, float, float]: ...
    @property
    def pd(self) -> RGB: ...
    @property
    def pa(self) -> RGB: ...
    @property
    def above_horizon(self) -> bool: ...

class Compositor:
    def composite(self, frame: FrameArray, lighting: Union[Estimate, Lighting], time: Optional[Union[str, datetime]] = None) -> Tuple[FrameArray, Dict[str, Any]]:
        """The composited frame (the input's form) and the pass report (GIL released); with the
        frame's `time`, objects with a motion are posed for it first, as `heliar augment` does."""
    @property
    def gpu(self) -> str: ...
    @property
    def warnings(self) -> List[str]: ...

class Decomposer:
    def __init__(
        self,
        lights: int = 300,
        sampler: str = "coherent-cut",
        rate_hz: float = 21.0,
        clusters: Optional[int] = None,
        peaks: Optional[bool] = None,
        relax: bool = True,
    ) -> None: ...
    def decompose(self, map: npt.NDArray[np.float32]) -> Dict[str, Any]:
        """index (N,), dir (N,3), rgb (N,3) and the frame's status and power."""
    @property
    def lights(self) -> int: ...

"""Type stubs of the native module (crates/tet_python)."""

from typing import Any, Callable, Dict, List, Optional, Tuple

import numpy as np
import numpy.typing as npt

__version__: str

class TetkitError(ValueError): ...
class TetkitIOError(OSError): ...

class Bundle:
    @property
    def points(self) -> npt.NDArray[np.float64]: ...
    @property
    def tets(self) -> npt.NDArray[np.uint32]: ...
    @property
    def scalar(self) -> npt.NDArray[np.float64]: ...
    @property
    def scalar_name(self) -> str: ...
    @property
    def scalar_range(self) -> Tuple[float, float]: ...
    @property
    def bounds(self) -> Tuple[Tuple[float, float, float], Tuple[float, float, float]]: ...
    @property
    def num_points(self) -> int: ...
    @property
    def num_tets(self) -> int: ...
    @property
    def times(self) -> Optional[List[float]]: ...
    @property
    def findings(self) -> List[str]: ...
    def at_time(self, t: float) -> "Bundle": ...
    def histogram(
        self, bins: Tuple[int, int] = (256, 256), scalar_range: Optional[Tuple[float, float]] = None,
        gradient_range: Optional[Tuple[float, float]] = None,
    ) -> Dict[str, Any]: ...
    def histogram_png(
        self, path: Optional[str] = None, bins: Tuple[int, int] = (256, 256), log: bool = True,
        scalar_range: Optional[Tuple[float, float]] = None, gradient_range: Optional[Tuple[float, float]] = None,
        units: Optional[str] = None, length_units: Optional[str] = None,
    ) -> bytes: ...
    def gradients(self, method: str = "lsq") -> npt.NDArray[np.float64]: ...
    def limits(self) -> Dict[str, Any]: ...
    def save(self, path: str) -> None: ...
    def _repr_html_(self) -> str: ...

class Table:
    @property
    def method(self) -> str: ...
    @property
    def bake_seconds(self) -> float: ...
    @property
    def memory_bytes(self) -> int: ...
    @property
    def certificate(self) -> Optional[Dict[str, Any]]: ...
    def save(self, path: str) -> None: ...

def bake(
    bundle: Bundle, tf_json: Optional[str] = None, tf_path: Optional[str] = None, colormap: Optional[str] = None,
    method: str = "table3d",
) -> Table: ...
def load(path: str) -> Bundle: ...
def read(path: str, scalar: Optional[str] = None, q: Optional[str] = None, all_steps: bool = False) -> Bundle: ...
def from_arrays(
    points: npt.NDArray[np.float64], tets: npt.NDArray[np.int64], scalars: npt.NDArray[np.float64]
) -> Bundle: ...
def from_cells(
    points: npt.NDArray[np.float64],
    cell_types: npt.NDArray[np.int64],
    offsets: npt.NDArray[np.int64],
    connectivity: npt.NDArray[np.int64],
    point_fields: List[Tuple[str, npt.NDArray[np.float64]]],
    cell_fields: List[Tuple[str, npt.NDArray[np.float64]]],
    scalar: Optional[str] = None,
    dims: Optional[Tuple[int, int, int]] = None,
    format: str = "arrays",
) -> Bundle: ...
def render(
    bundle: Bundle,
    tf_json: Optional[str] = None,
    tf_path: Optional[str] = None,
    colormap: Optional[str] = None,
    method: str = "table3d",
    lut: Optional[str] = None,
    view_json: Optional[str] = None,
    azimuth: float = 0.0,
    elevation: float = 0.0,
    zoom: float = 1.0,
    size: Tuple[int, int] = (512, 512),
    renderer: str = "walk",
    light: bool = False,
    cull: bool = True,
    table: Optional[Table] = None,
    progress: Optional[Callable[[int, int], None]] = None,
    light_dir: Optional[Tuple[float, float, float]] = None,
    shadows: bool = False,
    adaptive: Optional[float] = None,
) -> Tuple[npt.NDArray[np.float32], Dict[str, Any]]: ...
def reference(
    bundle: Bundle,
    tf_json: Optional[str] = None,
    tf_path: Optional[str] = None,
    colormap: Optional[str] = None,
    view_json: Optional[str] = None,
    azimuth: float = 0.0,
    elevation: float = 0.0,
    zoom: float = 1.0,
    size: Tuple[int, int] = (512, 512),
    progress: Optional[Callable[[int, int], None]] = None,
    light: bool = False,
    light_dir: Optional[Tuple[float, float, float]] = None,
    shadows: bool = False,
) -> npt.NDArray[np.float32]: ...
def tonemap(
    image: npt.NDArray[np.float32], exposure: float = 1.0, background: Tuple[float, float, float] = ..., reinhard: bool = True
) -> npt.NDArray[np.uint8]: ...
def encode_png(rgba: npt.NDArray[np.uint8]) -> bytes: ...
def diff(a: npt.NDArray[np.float32], b: npt.NDArray[np.float32]) -> Tuple[float, float, float, int]: ...
def methods() -> List[str]: ...

"""Type stubs of the native module (see tyndall/__init__.py for the documented API)."""

import pathlib
from os import PathLike
from typing import Any, Callable, Dict, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str

_Path = Union[str, "PathLike[str]"]
_Array = npt.NDArray[np.float32]

class GraphError(ValueError):
    node: Optional[str]
    port: Optional[str]
    param: Optional[str]

class EvalError(RuntimeError):
    node: Optional[str]
    port: Optional[str]
    param: Optional[str]

class GpuError(RuntimeError):
    node: Optional[str]
    port: Optional[str]
    param: Optional[str]

class Graph:
    def __init__(self) -> None: ...
    @staticmethod
    def load(path: _Path) -> "Graph": ...
    @staticmethod
    def from_str(text: str, path: Optional[_Path] = None) -> "Graph": ...
    def save(self, path: _Path) -> None: ...
    def to_str(self) -> str: ...
    @property
    def path(self) -> Optional["pathlib.Path"]: ...
    @property
    def nodes(self) -> Dict[str, str]: ...
    @property
    def edges(self) -> List[Tuple[str, str]]: ...
    def get(self, node: str, param: str, time: float = 0.0) -> Any: ...
    def set(self, node: str, param: str, value: Any) -> None: ...
    def add_node(self, id: str, kind: str, **params: Any) -> str: ...
    def remove_node(self, id: str) -> None: ...
    def connect(self, source: str, target: str) -> None: ...
    def disconnect(self, target: str) -> bool: ...
    def keys(self, node: str, param: str) -> List[Tuple[float, float, str]]: ...
    def set_keys(self, node: str, param: str, keys: Sequence[Tuple[float, ...]]) -> None: ...
    def copy(self) -> "Graph": ...

class Evaluator:
    def __init__(self, adapter: Optional[str] = None, ocio: Optional[str] = None) -> None: ...
    @property
    def adapter(self) -> str: ...
    @property
    def ocio(self) -> str: ...
    def _eval(
        self,
        graph: Graph,
        outputs: Optional[List[str]] = None,
        time: float = 0.0,
        size: Tuple[int, int] = (512, 512),
    ) -> list: ...

def catalog() -> List[dict]: ...
def node(
    kind: str,
    params: Optional[Mapping[str, Any]] = None,
    inputs: Optional[Mapping[str, _Array]] = None,
    outputs: Optional[List[str]] = None,
    time: float = 0.0,
    size: Optional[Tuple[int, int]] = None,
    data: Optional[str] = None,
    ocio: Optional[str] = None,
) -> list: ...
def render(
    graph: Graph,
    frames: Optional[str] = None,
    output_dir: Optional[str] = None,
    size: Tuple[int, int] = (960, 540),
    progress: Optional[Callable[[int, int, int], None]] = None,
    ocio: Optional[str] = None,
) -> List[int]: ...
def read_image(path: _Path) -> _Array: ...
def write_image(path: _Path, array: _Array) -> None: ...
def convert_colourspace(
    array: _Array, to: str, source: str = "", ocio: Optional[str] = None
) -> _Array: ...

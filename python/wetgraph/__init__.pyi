# SPDX-License-Identifier: MIT
# Type stubs of the wetgraph module (the C extension wetgraph._wetgraph and its Python layer).
import os
from dataclasses import dataclass
from typing import Any, Callable, Dict, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

VERSION: str
__version__: str

PathLike = Union[str, bytes, os.PathLike]
ParamValue = Union[bool, int, float, str, Sequence[float]]
DType = Union[None, str, type, np.dtype]

class Error(Exception):
    """The text the command line prints; the parts as attributes."""
    code: int
    status: str
    message: str
    file: Optional[str]
    line: int
    column: int
    node: Optional[str]

class Cancelled(Error): ...

class Cancel:
    def __init__(self) -> None: ...
    def request(self) -> None: ...
    def reset(self) -> None: ...
    @property
    def requested(self) -> bool: ...

class Engine:
    def __init__(self, *, threads: int = 0, memory_budget: int = 0,
                 cache_dir: Optional[PathLike] = None) -> None: ...
    def clear_cache(self) -> None: ...
    def memory_stats(self) -> Dict[str, int]: ...

@dataclass(frozen=True)
class Param:
    name: str
    type: str
    default: str
    min: Optional[float]
    max: Optional[float]
    label: Optional[str]
    values: Optional[Tuple[str, ...]]
    line: int

@dataclass(frozen=True)
class Input:
    name: str
    kind: str
    colorspace: str
    default: Optional[str]
    line: int

@dataclass(frozen=True)
class Output:
    name: str
    source: str
    format: Optional[str]
    colorspace: str
    group: Optional[str]
    line: int

ProgressFn = Callable[[int, int, Optional[str]], Any]
InputValue = Union[None, PathLike, npt.NDArray[np.uint8], npt.NDArray[np.uint16],
                   npt.NDArray[np.float32]]

class Graph:
    def __init__(self, graph: PathLike, engine: Optional[Engine] = None) -> None: ...
    @property
    def name(self) -> str: ...
    @property
    def path(self) -> str: ...
    @property
    def label(self) -> Optional[str]: ...
    @property
    def size_text(self) -> str: ...
    @property
    def engine(self) -> Engine: ...
    @property
    def params(self) -> List[Param]: ...
    @property
    def inputs(self) -> List[Input]: ...
    @property
    def outputs(self) -> List[Output]: ...
    size: Optional[Tuple[int, int]]
    seed: Optional[int]
    time: float
    @property
    def stats(self) -> Optional[Dict[str, Any]]: ...
    def set(self, name: Optional[str] = None, value: Optional[ParamValue] = None, /,
            **values: ParamValue) -> None: ...
    def unset(self, name: str) -> None: ...
    def value(self, name: str) -> str: ...
    def set_input(self, name: str, value: InputValue) -> None: ...
    def set_inputs(self, **inputs: InputValue) -> None: ...
    def check(self) -> None: ...
    def render(self, outputs: Union[None, str, Sequence[str]] = None, *, dtype: DType = None,
               progress: Optional[ProgressFn] = None,
               cancel: Optional[Cancel] = None) -> Dict[str, np.ndarray]: ...
    def render_files(self, folder: PathLike, outputs: Union[None, str, Sequence[str]] = None, *,
                     format: Union[None, str, Mapping[str, str]] = None,
                     progress: Optional[ProgressFn] = None,
                     cancel: Optional[Cancel] = None) -> Dict[str, str]: ...
    def cancel(self) -> bool: ...

def value_text(value: ParamValue) -> str: ...
def graphs() -> Dict[str, str]: ...
def find_graph(name: PathLike) -> str: ...
def load_plugin(path: PathLike) -> None: ...

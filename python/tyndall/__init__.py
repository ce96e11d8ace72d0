"""Tyndall from Python: graphs of volumetric light-shaft techniques evaluated on the GPU.

    import tyndall
    g = tyndall.Graph.load("graphs/physical/window.ron")
    ev = tyndall.Evaluator()
    out = ev.eval(g, ["tonemap.out"], size=(480, 270))   # {"tonemap.out": H×W×4 float32}
    g.set("tonemap", "exposure", 1.0)
    out = ev.eval(g, ["tonemap.out"], size=(480, 270))   # only the tone curve runs again
    print(out.stats.ran)                                   # ['tonemap']

Arrays are numpy ``float32``: H×W for one-channel ports (Scalar, Depth in metres, ShadowMap),
H×W×4 (linear RGBA) for Image ports. GPU work releases the GIL; Ctrl+C interrupts a call at
once (the evaluation in flight finishes in the background). Errors are ``GraphError`` (a
``ValueError``), ``EvalError`` and ``GpuError`` (``RuntimeError``s), each with ``.node``,
``.port`` and ``.param`` (None when the error is not about one).

Colours are read through an OpenColorIO config: ``ocio=`` on :class:`Evaluator`, :func:`node`
and :func:`render` (a ``.ocio`` file or an ``ocio://`` name, as the CLI's ``--ocio``; None:
``$OCIO``, else the built-in ACES 2.0 config). A config that cannot be read raises
``ValueError``. :func:`convert_colourspace` converts an array between two of its colour spaces.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Callable, Dict, Iterable, List, Mapping, Optional, Sequence, Tuple

import numpy as np

from . import _native
from ._native import (
    EvalError,
    GpuError,
    Graph,
    GraphError,
    convert_colourspace,
    read_image,
    write_image,
)

__version__ = _native.__version__

__all__ = [
    "EvalError",
    "Evaluator",
    "GpuError",
    "Graph",
    "GraphError",
    "NodeOutputs",
    "NodeStat",
    "Outputs",
    "Stats",
    "catalog",
    "convert_colourspace",
    "node",
    "read_image",
    "render",
    "write_image",
]


def catalog() -> List[dict]:
    """Every node kind, then the library groups found from the working directory.

    Each entry is a dict: ``kind``, ``category``, ``doc``, ``inputs`` and ``outputs`` (lists of
    ``{name, types, required, doc}``), ``params`` (``{name, type, default, min, max, unit, doc}``,
    ``choices`` for enums) and ``library`` (the group's reference, or None for built-in kinds).
    """
    return _native.catalog()


@dataclass(frozen=True)
class NodeStat:
    """One node of one evaluation: its id (``group/inner`` inside groups), kind, status
    (``"ran"``, ``"passed through"``, ``"reused"`` or ``"not needed"``), wall-clock
    milliseconds of its last run and GPU milliseconds (when measured)."""

    id: str
    kind: str
    status: str
    ms: float
    gpu_ms: Optional[float]


class Stats:
    """Per-node statistics of one evaluation, in evaluation order."""

    def __init__(self, rows: Iterable[tuple]):
        self.nodes: List[NodeStat] = [NodeStat(*r) for r in rows]

    def _with(self, status: str) -> List[str]:
        return [n.id for n in self.nodes if n.status == status]

    @property
    def ran(self) -> List[str]:
        """Ids of the nodes that ran (passed-through ones included: they ran and forwarded)."""
        return [n.id for n in self.nodes if n.status in ("ran", "passed through")]

    @property
    def reused(self) -> List[str]:
        """Ids of the nodes whose cached result was used."""
        return self._with("reused")

    @property
    def not_needed(self) -> List[str]:
        """Ids of the nodes no requested output depends on."""
        return self._with("not needed")

    @property
    def passed_through(self) -> List[str]:
        """Ids of the nodes that found their work unnecessary and forwarded an input."""
        return self._with("passed through")

    def __getitem__(self, node_id: str) -> NodeStat:
        for n in self.nodes:
            if n.id == node_id:
                return n
        raise KeyError(node_id)

    def __repr__(self) -> str:
        return f"Stats(ran={self.ran}, reused={self.reused}, not_needed={self.not_needed})"


class Outputs(dict):
    """``"node.port"`` → numpy array, plus ``stats`` (:class:`Stats`) and ``cameras``:
    ``"node.port"`` → the camera's or light's matrices a Depth, ShadowMap or LightMap carries
    (``view`` and ``proj`` as 4×4 row-major lists, ``far`` in metres, ``radiance``)."""

    stats: Stats
    cameras: Dict[str, dict]


def _outputs(native: list) -> Outputs:
    arrays, stats, cameras = native
    out = Outputs(arrays)
    out.stats = Stats(stats)
    out.cameras = dict(cameras)
    return out


class NodeOutputs(Outputs):
    """What :func:`node` returns: port name (``"out"``, ``"map"``) → numpy array, as
    ``tyndall node --output PORT=FILE`` names them; ``cameras`` likewise by port name.

    Deprecated: the former keys ``"kind.port"`` (kind in lower case, ``"math.out"``) still
    work for ``[]``, ``in`` and ``get``, with a ``DeprecationWarning``; they will be removed."""

    _prefix: str = ""

    def _former(self, key: object) -> Optional[str]:
        """The port a former ``"kind.port"`` key names, warning once per use; None if it is not
        one."""
        if not (isinstance(key, str) and self._prefix and key.startswith(self._prefix)):
            return None
        port = key[len(self._prefix):]
        if not dict.__contains__(self, port):
            return None
        warnings.warn(
            f'tyndall.node(...)["{key}"]: outputs are keyed by port name now, use ["{port}"]',
            DeprecationWarning,
            stacklevel=3,
        )
        return port

    def __missing__(self, key: str) -> np.ndarray:
        port = self._former(key)
        if port is None:
            raise KeyError(key)
        return dict.__getitem__(self, port)

    def __contains__(self, key: object) -> bool:
        return dict.__contains__(self, key) or self._former(key) is not None

    def get(self, key: str, default: object = None) -> object:
        if dict.__contains__(self, key):
            return dict.__getitem__(self, key)
        port = self._former(key)
        return default if port is None else dict.__getitem__(self, port)


def _node_outputs(native: list, kind: str) -> NodeOutputs:
    arrays, stats, cameras = native
    prefix = kind.lower() + "."
    by_port = {k[len(prefix):] if k.startswith(prefix) else k: v for k, v in arrays.items()}
    out = NodeOutputs(by_port)
    out._prefix = prefix
    out.stats = Stats(stats)
    out.cameras = {
        k[len(prefix):] if k.startswith(prefix) else k: v for k, v in dict(cameras).items()
    }
    return out


class Evaluator:
    """A GPU evaluator keeping its cache across calls: after ``Graph.set`` only the changed
    node and those below it run again.

    ``adapter``: None for the process's shared GPU context, else a substring of an adapter's
    name (``"llvmpipe"``, ``"NVIDIA"``; ``tyndall info`` lists them). Raises GpuError when no
    adapter qualifies. ``ocio``: the OpenColorIO config of its evaluations (a file or an
    ``ocio://`` name; None: ``$OCIO``, else the built-in config); ValueError when it cannot be
    read. A graph's ``colour: (working_space: …)`` names a colour space of that config.
    """

    def __init__(self, adapter: Optional[str] = None, ocio: Optional[str] = None):
        self._native = _native.Evaluator(adapter, None if ocio is None else str(ocio))

    @property
    def adapter(self) -> str:
        """The adapter's name and backend."""
        return self._native.adapter

    @property
    def ocio(self) -> str:
        """The OpenColorIO config its evaluations use."""
        return self._native.ocio

    def eval(
        self,
        graph: Graph,
        outputs: Optional[Sequence[str]] = None,
        time: float = 0.0,
        size: Tuple[int, int] = (512, 512),
    ) -> Outputs:
        """Evaluate ``outputs`` (``"node.port"``; ``"group/inner.port"`` inside groups; None:
        what the graph's output nodes read) at ``time``; ``size`` is the picture size of nodes
        that make pictures from nothing (as the CLI's ``--size``, default 512×512). Returns
        :class:`Outputs`. No files are written."""
        return _outputs(
            self._native._eval(graph, None if outputs is None else list(outputs), time, tuple(size))
        )


def node(
    kind: str,
    params: Optional[Mapping[str, object]] = None,
    inputs: Optional[Mapping[str, np.ndarray]] = None,
    outputs: Optional[Sequence[str]] = None,
    time: float = 0.0,
    size: Optional[Tuple[int, int]] = None,
    data: Optional[str] = None,
    ocio: Optional[str] = None,
) -> Outputs:
    """Run one node of ``kind`` on in-memory arrays, as ``tyndall node`` does on files.

    ``inputs``: port → array (H×W feeds Scalar/Depth/ShadowMap ports, or an Image port as grey;
    H×W×3 or ×4 feeds Image ports); any dtype, converted to float32. ``outputs``: port names
    (None: every picture output). ``data``: the node's data block as RON text. ``ocio``: the
    OpenColorIO config (as :class:`Evaluator`'s; ``ColourSpace`` and ``DisplayView`` read it). Returns
    :class:`NodeOutputs` keyed by port name (``out["out"]``, ``out["map"]``), as ``tyndall
    node --output PORT=FILE`` names them; the former ``"kind.port"`` keys are deprecated.
    """
    arrays = None
    if inputs is not None:
        arrays = {k: np.ascontiguousarray(v, dtype=np.float32) for k, v in inputs.items()}
    return _node_outputs(
        _native.node(
            kind,
            dict(params or {}),
            arrays,
            None if outputs is None else list(outputs),
            time,
            None if size is None else tuple(size),
            data,
            None if ocio is None else str(ocio),
        ),
        kind,
    )


def render(
    graph: Graph,
    frames: Optional[str] = None,
    output_dir: Optional[str] = None,
    size: Tuple[int, int] = (960, 540),
    progress: Optional[Callable[[int, int, int], None]] = None,
    ocio: Optional[str] = None,
) -> List[int]:
    """Render the graph's output nodes as ``tyndall render`` does.

    ``frames``: ``"1-24"``, ``"1,5,7-9"``, ``"1-24x2"`` (time = frame; a ``####`` in an output
    path becomes the frame, other paths get ``_NNNN``); None renders once with the names as
    written. Files go under ``output_dir`` (default: the working directory).
    ``progress(frame, done, total)`` is called after each frame. ``ocio``: the OpenColorIO
    config (as ``--ocio``; None: ``$OCIO``, else the built-in config); ValueError before any
    work when it cannot be read. Returns the frames rendered.
    """
    return _native.render(
        graph,
        frames,
        None if output_dir is None else str(output_dir),
        tuple(size),
        progress,
        None if ocio is None else str(ocio),
    )

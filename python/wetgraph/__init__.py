# SPDX-License-Identifier: MIT
"""wetgraph: render node-graph textures (.wetgraph files) to numpy arrays or image files.

A Graph is loaded by file or by name (the built-in graphs and those in WETGRAPH_PATH, as
`wetgraph render NAME` finds them); its parameters are set with Python values, its inputs from
image files or numpy arrays, and render() returns {output: array}. Each Graph renders on an
Engine whose cache it keeps: a render after a change computes only the nodes the change reaches
(Graph.stats tells which). Errors are wetgraph.Error, whose text is what the command line
prints.

    import wetgraph
    g = wetgraph.Graph("wet_material")
    g.set_input("basecolor", "color.jpg")
    g.set_input("height", height_array)          # (h, w) uint8, uint16 or float32
    g.set(water_level=0.4, liquid="tea")
    maps = g.render(["basecolor", "roughness"])  # float32, linear
"""
from dataclasses import dataclass
from typing import Optional, Tuple

from ._wetgraph import Cancel, Cancelled, Engine, Error, VERSION, find_graph, graphs, load_plugin
from ._wetgraph import Graph as _Graph

__all__ = ["Graph", "Engine", "Cancel", "Error", "Cancelled", "Param", "Input", "Output",
           "graphs", "find_graph", "load_plugin", "value_text", "VERSION"]
__version__ = VERSION


@dataclass(frozen=True)
class Param:
    """A parameter the graph declares: its type (float, int, bool, enum, color, string), the
    text of its default, its range (None where open), label and enum values."""
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
    """An image input: kind 'gray' or 'color', the colour space its files are in ('srgb' inputs
    are decoded to linear), the text of its default (None: the input is required)."""
    name: str
    kind: str
    colorspace: str
    default: Optional[str]
    line: int


@dataclass(frozen=True)
class Output:
    """An output: the node (and port) it comes from, its file format (None: png16 for gray,
    png for colour), its colour space and group."""
    name: str
    source: str
    format: Optional[str]
    colorspace: str
    group: Optional[str]
    line: int


def value_text(value):
    """The text a graph file would give a parameter value: booleans as true/false, numbers in
    the shortest form that reads back exactly, a sequence of 1, 3 or 4 numbers as a linear
    colour, strings (enum names, '#rrggbb', '=expression') as they are."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return value
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return repr(value)
    try:
        items = [float(v) for v in value]
    except TypeError:
        raise TypeError(f"a parameter value is a bool, number, string or sequence of numbers, "
                        f"not {type(value).__name__}") from None
    return " ".join(repr(v) for v in items)


class Graph(_Graph):
    """Graph(graph, engine=None)

    A graph loaded by file or by name, with the parameter values and inputs of its next render.
    Without an engine it makes its own (threads: one per core); share one Engine between graphs
    to share its cache and memory budget.
    """

    @property
    def params(self):
        """The parameters, as Param."""
        return [Param(*p) for p in self._param_info()]

    @property
    def inputs(self):
        """The image inputs, as Input."""
        return [Input(*p) for p in self._input_info()]

    @property
    def outputs(self):
        """The outputs, as Output."""
        return [Output(*p) for p in self._output_info()]

    def set(self, name=None, value=None, /, **values):
        """Set parameters: g.set("water_level", 0.4) or g.set(water_level=0.4, liquid="tea").
        Values are Python values (see value_text) or the text a graph file would hold; each is
        checked against the parameter's type and range at once (Error)."""
        if name is not None:
            super().set(name, value_text(value))
        for k, v in values.items():
            super().set(k, value_text(v))

    def set_inputs(self, **inputs):
        """Feed several inputs: g.set_inputs(height="h.png", basecolor=array)."""
        for k, v in inputs.items():
            self.set_input(k, v)

    def __repr__(self):
        return f"<wetgraph.Graph {self.name!r} from {self.path!r}>"

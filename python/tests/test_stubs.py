# SPDX-License-Identifier: MIT
# The type stubs (wetgraph/__init__.pyi, installed with the module) name everything the module
# offers: its public names, each class's public methods and properties, the info classes'
# fields; and every public callable has a docstring.
import ast
import dataclasses
import os

import wetgraph


def stub_tree():
    path = os.path.join(os.path.dirname(wetgraph.__file__), "__init__.pyi")
    with open(path) as f:
        return ast.parse(f.read())


def test_stubs_name_everything_the_module_offers():
    tree = stub_tree()
    top, members = set(), {}
    for node in tree.body:
        if isinstance(node, (ast.FunctionDef, ast.ClassDef)):
            top.add(node.name)
        elif isinstance(node, ast.AnnAssign):
            top.add(node.target.id)
        if isinstance(node, ast.ClassDef):
            names = set()
            for b in node.body:
                if isinstance(b, ast.FunctionDef):
                    names.add(b.name)
                elif isinstance(b, ast.AnnAssign):
                    names.add(b.target.id)
            members[node.name] = names
    assert set(wetgraph.__all__) - {"__version__"} <= top, set(wetgraph.__all__) - top
    for cls in (wetgraph.Graph, wetgraph.Engine, wetgraph.Cancel):
        public = {n for n in dir(cls) if not n.startswith("_")}
        assert public <= members[cls.__name__], (cls.__name__, public - members[cls.__name__])
    for cls in (wetgraph.Param, wetgraph.Input, wetgraph.Output):
        fields = [f.name for f in dataclasses.fields(cls)]
        assert set(fields) == members[cls.__name__], cls.__name__
    for attr in ("code", "status", "message", "file", "line", "column", "node"):
        assert attr in members["Error"], attr


def test_every_public_callable_has_a_docstring():
    assert wetgraph.__doc__ and "import wetgraph" in wetgraph.__doc__
    for name in wetgraph.__all__:
        obj = getattr(wetgraph, name)
        if callable(obj):
            assert obj.__doc__, name
    for cls in (wetgraph.Graph, wetgraph.Engine, wetgraph.Cancel):
        for n in dir(cls):
            if not n.startswith("_"):
                assert getattr(cls, n).__doc__, f"{cls.__name__}.{n}"

"""The package's import graph: stages import earlier stages only.

Read from the source with ``ast`` (nothing is imported): every ``import`` and
``from ... import`` statement of every module under ``pv_hdrvol/``, at module level and
inside functions alike. ``from .pkg import name`` is an edge to the module
``pv_hdrvol.pkg.name`` when that is a module, else to ``pv_hdrvol.pkg``; the
initialisation of parent packages that Python runs on the way is not an edge (it is the
same for every module). docs/development.md draws the stages.

The same reading measures every class (at most 600 lines) and every function (at most
100 lines, its docstring not counted).
"""
import ast
import pathlib

import pytest

pytestmark = pytest.mark.core

PACKAGE = pathlib.Path(__file__).resolve().parents[2] / "pv_hdrvol"
FACE = "pv_hdrvol"
#: the front ends, which may use the package's face (``import pv_hdrvol as hv``)
FRONT_ENDS = ("pv_hdrvol.integrations", "pv_hdrvol.viewer")


def _modules(root=PACKAGE):
    """``{dotted name: path}`` of every module of the package."""
    out = {}
    for path in sorted(root.rglob("*.py")):
        parts = list(path.relative_to(root.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = path
    return out


def import_graph(root=PACKAGE):
    """``{module: set of the package's modules it imports}`` (see the module docstring)."""
    modules = _modules(root)
    graph = {}
    for name, path in modules.items():
        is_package = path.name == "__init__.py"
        here = name.split(".") if is_package else name.split(".")[:-1]
        edges = set()
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
            if isinstance(node, ast.Import):
                targets = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom):
                if node.level:
                    base = here[:len(here) - (node.level - 1)] + ([node.module] if node.module else [])
                    base = ".".join(base)
                else:
                    base = node.module or ""
                targets = [f"{base}.{a.name}" if f"{base}.{a.name}" in modules else base for a in node.names]
            else:
                continue
            edges.update(t for t in targets if t in modules and t != name)
        graph[name] = edges
    return graph


def cycles(graph):
    """The strongly connected components of more than one module (Tarjan), each sorted."""
    index, low, stack, on_stack, found = {}, {}, [], set(), []
    counter = [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return sorted(found)


def _is_front_end(module):
    return module.startswith(FRONT_ENDS) or module.endswith("__main__")


def test_the_import_graph_has_no_cycle():
    graph = import_graph()
    assert len(graph) > 100  # the whole package was read
    assert cycles(graph) == []


def test_nothing_below_the_front_ends_imports_the_face():
    graph = import_graph()
    importers = sorted(m for m, edges in graph.items() if FACE in edges and not _is_front_end(m))
    assert importers == []


#: The stages in pipeline order (docs/development.md draws them): a module imports only
#: modules of its own stage or of earlier ones. ``pv_hdrvol`` is the face.
STAGES = ("_validate", "_jit", "params", "data", "datasets", "rays", "settings", "image", "raycast", "gpu", "culling",
          "parallel", "outofcore", "editor", "proxy", "viewer", "dispatch", "pv_hdrvol", "integrations")
#: Imports of a later stage that are allowed, with the reason: the proxy viewer is a Qt
#: window that runs in the viewer's Qt loop.
LATER_ALLOWED = {("pv_hdrvol.proxy.qt", "pv_hdrvol.viewer.qt")}


def _stage(module):
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "pv_hdrvol"


def test_every_stage_imports_only_earlier_stages():
    graph = import_graph()
    assert set(map(_stage, graph)) == set(STAGES)  # every stage is placed
    rank = {stage: i for i, stage in enumerate(STAGES)}
    later = sorted((m, e) for m, edges in graph.items() for e in edges
                   if not m.endswith("__main__") and rank[_stage(e)] > rank[_stage(m)])
    assert set(later) == LATER_ALLOWED, later


def test_the_face_defines_nothing_but_re_exports():
    """``pv_hdrvol/__init__.py`` holds imports, ``__version__``, ``__all__`` and the lazy
    ``__getattr__`` of an optional name only: the logic behind ``render`` and ``view``
    lives in :mod:`pv_hdrvol.dispatch`."""
    tree = ast.parse((PACKAGE / "__init__.py").read_text(encoding="utf-8"))
    kinds = []
    for node in tree.body:
        if isinstance(node, (ast.Import, ast.ImportFrom)) or (isinstance(node, ast.Expr)
                                                               and isinstance(node.value, ast.Constant)):
            continue
        if isinstance(node, ast.Assign):
            kinds.append(("assign", [t.id for t in node.targets]))
        elif isinstance(node, ast.FunctionDef):
            kinds.append(("def", node.name))
        else:
            kinds.append((type(node).__name__, None))
    expected = [("def", "__getattr__"), ("assign", ["__version__"]), ("assign", ["__all__"])]
    assert sorted(map(repr, kinds)) == sorted(map(repr, expected))


#: the most lines a class of the package may span (its ``class`` line to its last)
MAX_CLASS_LINES = 600


def class_sizes(root=PACKAGE):
    """``{"module:Class": lines}`` of every class (nested ones too), read with ``ast``:
    ``end_lineno - lineno + 1`` of its ``class`` statement."""
    sizes = {}
    for name, path in _modules(root).items():
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
            if isinstance(node, ast.ClassDef):
                sizes[f"{name}:{node.name}"] = node.end_lineno - node.lineno + 1
    return sizes


def test_no_class_is_longer_than_600_lines():
    """A class that grows past this holds more than one concern: move its machinery into
    functions or a module of its own (the VTK algorithm's execution is
    ``integrations/vtk_execute.py``, the editor's drawing ``editor/display.py``)."""
    sizes = class_sizes()
    assert sizes["pv_hdrvol.integrations.vtk_algorithm:HDRVolumeRenderer"] > 100  # the classes were read
    assert {name: n for name, n in sizes.items() if n > MAX_CLASS_LINES} == {}


def test_class_sizes_are_measured_from_class_to_last_line(tmp_path):
    pkg = tmp_path / "pv_hdrvol"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "a.py").write_text("class A:\n    x = 1\n\n    class B:\n        pass\n\n\ny = 2\n")
    assert class_sizes(pkg) == {"pv_hdrvol.a:A": 5, "pv_hdrvol.a:B": 2}


#: the most lines a function of the package may span, its docstring not counted
MAX_FUNCTION_LINES = 100
#: the same for a numba kernel (a function of a ``_*kernels*.py`` module): a marching
#: loop keeps its per-sample work inline, where a call per sample costs time
MAX_KERNEL_LINES = 150
def _limit(name):
    module = name.split(":")[0].rsplit(".", 1)[-1]
    return MAX_KERNEL_LINES if module.startswith("_") and "kernels" in module else MAX_FUNCTION_LINES


def function_sizes(root=PACKAGE):
    """``{"module:qualified.name": lines}`` of every function and method (nested ones
    too, named through what holds them), read with ``ast``: ``end_lineno - lineno + 1``
    of its ``def`` (decorators not counted) less the lines of its docstring."""
    sizes = {}

    def visit(node, module, prefix):
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                name = prefix + child.name
                if not isinstance(child, ast.ClassDef):
                    lines = child.end_lineno - child.lineno + 1
                    first = child.body[0]
                    if (isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant)
                            and isinstance(first.value.value, str)):
                        lines -= first.end_lineno - first.lineno + 1
                    sizes[f"{module}:{name}"] = lines
                visit(child, module, name + ".")
            else:
                visit(child, module, prefix)

    for module, path in _modules(root).items():
        visit(ast.parse(path.read_text(encoding="utf-8"), str(path)), module, "")
    return sizes


def _long_functions():
    return {name: n for name, n in function_sizes().items() if n > _limit(name)}


def test_no_function_is_longer_than_100_lines_or_a_kernel_than_150():
    """A function past this does more than one thing: give its steps names (functions
    of their own) so that it reads as the list of them, as ``build_parser`` (one
    builder per sub-command) and ``write_multiscale`` (open, plan, write each level,
    finish) do."""
    sizes = function_sizes()
    assert sizes["pv_hdrvol.integrations.cli:build_parser"] > 0  # the functions were read
    long = _long_functions()
    assert long == {}, f"longer than 100 lines (kernels 150) without the docstring: {long}"


def test_function_sizes_leave_out_docstrings_and_name_nested_functions(tmp_path):
    pkg = tmp_path / "pv_hdrvol"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "a.py").write_text('def f():\n    """Two\n    lines."""\n    def g():\n        return 1\n    return g\n\n\n'
                              'class A:\n    @property\n    async def h(self):\n        return 2\n')
    assert function_sizes(pkg) == {"pv_hdrvol.a:f": 4, "pv_hdrvol.a:f.g": 2, "pv_hdrvol.a:A.h": 2}


def test_the_graph_reader_finds_cycles_and_face_imports(tmp_path):
    """The checks above can fail: a scratch package with a cycle through a function-local
    import and a stage importing the face."""
    pkg = tmp_path / "pv_hdrvol"
    (pkg / "stage").mkdir(parents=True)
    (pkg / "__init__.py").write_text("from .stage.a import f\n")
    (pkg / "stage" / "__init__.py").write_text("")
    (pkg / "stage" / "a.py").write_text("from . import b\n\ndef f():\n    return b.g()\n")
    (pkg / "stage" / "b.py").write_text("def g():\n    from .a import f\n    from .. import f as face\n    return f, face\n")
    graph = import_graph(pkg)
    assert graph["pv_hdrvol.stage.a"] == {"pv_hdrvol.stage.b"}
    assert graph["pv_hdrvol.stage.b"] == {"pv_hdrvol.stage.a", "pv_hdrvol"}
    assert cycles(graph) == [["pv_hdrvol", "pv_hdrvol.stage.a", "pv_hdrvol.stage.b"]]


#: The calls that leave an empty block: only a loop that marches a ray makes them.
_LEAPS = {"leap_past", "_leap_to"}


def marching_loops(paths):
    """``{"module:function"}`` of the top-level functions in ``paths`` whose bodies
    (nested functions included) call one of ``_LEAPS``, leaving out the functions that
    define them and the overloads that implement them (``..._impl``)."""
    found = set()
    for path in paths:
        for node in ast.parse(path.read_text()).body:
            if not isinstance(node, ast.FunctionDef) or node.name in _LEAPS or node.name.endswith("_impl"):
                continue
            calls = {n.func.id for n in ast.walk(node) if isinstance(n, ast.Call) and isinstance(n.func, ast.Name)}
            if calls & _LEAPS:
                found.add(f"{path.stem}:{node.name}")
    return found


def test_the_grid_kernels_have_two_marching_loops():
    """Modes by type, not by copy: every storage (bricks in memory, out-of-core pages,
    a mip-map), every grid kind and every compositor (the precisions, the projections)
    runs the plain loop; per-label transfer functions, gradient-magnitude opacity and
    shaded mip-mapped rays run the labelled one. A new mode is an argument type of
    these, not a third loop."""
    raycast = PACKAGE / "raycast"
    loops = marching_loops(sorted(raycast.glob("_kernels*.py")) + [raycast / "_composite_kernels.py"])
    assert loops == {"_kernels:_march_plain", "_kernels_ext:_composite_ext"}


def test_the_loop_finder_sees_a_copied_loop(tmp_path):
    """The check above can fail: a module with a loop of its own that leaps."""
    (tmp_path / "_kernels_x.py").write_text(
        "def leap_past(k):\n    return k + 1\n\n\ndef _leap_past_impl(k):\n    return leap_past(k)\n\n\n"
        "def march(k, n):\n    while k < n:\n        k = leap_past(k)\n    return k\n\n\n"
        "def helper():\n    def inner(k):\n        return _leap_to(k)\n    return inner\n")
    assert marching_loops([tmp_path / "_kernels_x.py"]) == {"_kernels_x:march", "_kernels_x:helper"}

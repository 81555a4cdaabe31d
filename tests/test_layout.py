"""The compiled layout (kernels/layout.py) and the Model/Data split.

The scratch's named slots have the documented shapes inside a scratch of their kind, and the
slots of kernels that run inside one another share no memory; the compiled arrays live outside
the Robot (mrnea.compiled) and are dropped with it; the modules import downwards: model.py
imports no kernel and validate.py reaches no Numba.
"""

from __future__ import annotations

import ast
import gc
import itertools
import re
from pathlib import Path

import numba as nb
import numpy as np
import pytest
from conftest import random_chain
from numpy.lib.array_utils import byte_bounds

import mrnea
from mrnea import compiled
from mrnea.kernels.layout import (
    ACHIEVABLE,
    BATCH_PAD,
    NACT,
    NCOL,
    POSE,
    SOLVE,
    achievable_buffers,
    batch_scratch,
    branch_buffers,
    column_stash,
    drive_solve_buffers,
    effort_buffer,
    entry_scratch,
    force_buffers,
    loop_buffers,
    mrnea_buffers,
    new_scratches,
    pose_buffers,
    scratch_of,
    scratch_rows,
    solve_buffers,
    stash_buffers,
    tree_solve_buffers,
    update_buffers,
)

SRC = Path(mrnea.__file__).parent


def _py(fn):
    """A slot function's Python source (the views it returns, on NumPy arrays)."""
    return getattr(fn, "py_func", fn)


def _slots(kind: int, n: int, ws: tuple | None = None) -> dict[str, list[np.ndarray]]:
    ws = entry_scratch(n, kind) if ws is None else ws
    out = {"pose": list(_py(pose_buffers)(ws, n)), "mrnea": list(_py(mrnea_buffers)(ws, n)),
           "force": list(_py(force_buffers)(ws, n)), "effort": [_py(effort_buffer)(ws)],
           "branch": list(_py(branch_buffers)(ws, n)), "stash": list(_py(stash_buffers)(ws, n))}
    if kind in (SOLVE, ACHIEVABLE):
        out["column"] = [_py(column_stash)(ws, n)]
        out["solve"] = list(_py(solve_buffers)(ws, n))
        out["solve_hu"] = [out["solve"][0], out["solve"][2]]
    if kind == ACHIEVABLE:
        out["achievable"] = list(_py(achievable_buffers)(ws, n))
        out["drive_solve"] = list(_py(drive_solve_buffers)(ws, n))
        out["tree_solve"] = list(_py(tree_solve_buffers)(ws, n))
        out["update"] = list(_py(update_buffers)(ws, n))
        out["loop"] = list(_py(loop_buffers)(ws, n))
    return out


SHAPES = {  # (rows, columns) of each slot, in units of n: the layout module's docstring
    "pose": ["n33", "n3", "n3", "n3", "n33"], "mrnea": ["n3"] * 4, "force": ["n3"] * 2,
    "effort": ["n"], "solve": ["nn", "nn", "n", "n"], "branch": ["n3"] * 3, "stash": ["n3"] * 2,
    "column": ["nn"], "solve_hu": ["nn", "n"],
    "achievable": ["nn", *["n"] * 7],
    "drive_solve": ["nn", "nn", *["n"] * 4, "2n", "3n", *["n"] * 4],
    "tree_solve": ["n", "n"], "update": ["n", "n"], "loop": ["n"] * 3,
}


def _shapes(name: str, n: int) -> list[tuple[int, ...]]:
    """The shapes of slot group ``name``'s views for n joints (SHAPES, in units of n)."""
    unit = {"n": (n,), "n3": (n, 3), "n33": (n, 3, 3), "nn": (n, n), "2n": (2, n), "3n": (3, n)}
    return [unit[s] for s in SHAPES[name]]


# the slots used at the same time: a kernel's own, and those of every kernel it calls
# (a tree's forward passes use "branch", its backward passes "stash" and, mRNEA's, "column", the
# L slot: mRNEA writes only H and u' of "solve" meanwhile, "solve_hu")
TOGETHER = {
    POSE: [("pose", "mrnea"), ("pose", "force"), ("pose", "force", "effort"),
           ("pose", "force", "branch"), ("pose", "force", "effort", "stash")],
    SOLVE: [("pose", "mrnea", "solve"), ("pose", "force", "solve"), ("pose", "mrnea", "branch"),
            ("pose", "mrnea", "stash", "column", "solve_hu"), ("pose", "force", "stash", "solve")],
    ACHIEVABLE: [  # the simulation loop's "loop" rows: with all of its cycle's and reactions'
        ("pose", "mrnea", "achievable", "drive_solve", "tree_solve", "update", "loop"),
        ("pose", "force", "achievable", "drive_solve", "tree_solve", "update", "loop"),
        ("pose", "force", "effort", "loop"), ("pose", "force", "branch", "loop"),
        ("pose", "force", "effort", "stash", "loop"),
        ("pose", "mrnea", "stash", "column", "achievable", "loop"),
        ("pose", "mrnea", "branch", "achievable", "loop")],
}


@pytest.mark.parametrize("n", [1, 2, 7])
@pytest.mark.parametrize("kind", [POSE, SOLVE, ACHIEVABLE])
def test_slots_fit_their_scratch_and_do_not_overlap(kind: int, n: int) -> None:
    slots = _slots(kind, n)
    for name, views in slots.items():
        assert [v.shape for v in views] == _shapes(name, n), name
    for group in TOGETHER[kind]:
        views = [(name, k, v) for name in group for k, v in enumerate(slots[name])]
        for (a, i, x), (b, j, y) in itertools.combinations(views, 2):
            assert not np.shares_memory(x, y), f"{a}[{i}] and {b}[{j}] overlap"


def test_batch_scratch_has_one_scratch_per_thread() -> None:
    before = nb.get_num_threads()
    try:
        for threads in {1, nb.config.NUMBA_NUM_THREADS}:
            nb.set_num_threads(threads)
            assert all(a.shape[0] == threads for a in batch_scratch(4))
    finally:
        nb.set_num_threads(before)


@pytest.mark.parametrize("n", [1, 2, 6, 7])
@pytest.mark.parametrize("kind", [SOLVE, ACHIEVABLE])
def test_threads_of_a_batch_stack_are_a_cache_line_apart(kind: int, n: int) -> None:
    """Two threads' scratches in a batch stack (padded by BATCH_PAD rows): each thread's slots
    have their shapes, and no slot of one comes within 64 bytes of a slot of the other in the
    same array (no shared cache line)."""
    rows = _py(scratch_rows)(n, kind)
    stack = _py(new_scratches)(n, *rows, 2, BATCH_PAD)
    threads = [_slots(kind, n, _py(scratch_of)(stack, k)) for k in (0, 1)]
    for slots in threads:
        for name, views in slots.items():
            assert [v.shape for v in views] == _shapes(name, n), name
    for arr in stack:
        first, end = byte_bounds(arr)
        spans = [[byte_bounds(v) for views in slots.values() for v in views
                  if first <= byte_bounds(v)[0] < end] for slots in threads]
        for lo0, hi0 in spans[0]:
            for lo1, hi1 in spans[1]:
                assert hi0 + 64 <= lo1 or hi1 + 64 <= lo0


def test_integer_slots_are_integers() -> None:
    ws = entry_scratch(3, ACHIEVABLE)
    *_, pat, nbp, idx, tabu = _py(drive_solve_buffers)(ws, 3)
    near, lam_f = _py(tree_solve_buffers)(ws, 3)
    assert all(a.dtype == np.int64 for a in (pat, nbp, idx, tabu, near, lam_f))


def test_compiled_arrays_live_outside_the_robot_and_go_with_it() -> None:
    """A call leaves the Robot as it was (plain data); its compiled arrays are kept by id in
    mrnea.compiled until the Robot is collected; robots of one n share one scratch."""
    rng = np.random.default_rng(2)
    robot = random_chain(rng, 5, 0.4)
    before = dict(vars(robot))
    q = rng.uniform(-1, 1, 5)
    mrnea.forward_dynamics(robot, q, q, q)
    assert vars(robot).keys() == before.keys()
    assert all(vars(robot)[k] is v for k, v in before.items())
    model, shape, ws, act, tree = compiled.BY_ID[id(robot)]
    assert model.shape == (6, NCOL) and act.shape == (5, NACT) and shape == (5,) and not tree
    other = robot.with_gravity((0.0, 0.0, 9.81))
    mrnea.inverse_dynamics(other, q, q, q)
    assert compiled.BY_ID[id(other)][2] is ws
    key = id(robot)
    del robot
    gc.collect()
    assert key not in compiled.BY_ID


def _imports(path: Path) -> set[str]:
    """Every module ``path`` imports, at any depth of its code (lazy imports too)."""
    names = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            names |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module)
            names |= {f"{node.module}.{a.name}" for a in node.names}
    return names


def _file(module: str) -> Path | None:
    """The source of a module of the mrnea package (a subpackage: its __init__), or None."""
    rel = Path(*module.split(".")[1:])
    for p in (SRC / rel.with_suffix(".py"), SRC / rel / "__init__.py"):
        if module.startswith("mrnea.") and p.is_file():
            return p
    return None


def test_model_imports_no_kernel_and_no_io() -> None:
    """model.py is below io and the kernels: not even a lazy import of either (the writers
    behind Robot.to_urdf and to_toml are registered by mrnea.io)."""
    assert not {m for m in _imports(SRC / "model.py")
                if m.startswith(("mrnea.kernels", "numba", "mrnea.io"))}


def test_validate_reaches_no_numba() -> None:
    """validate.py and everything of mrnea it imports, transitively (subpackages' __init__
    included, the package's own __init__ not), import no Numba: trajectory can check a time
    step without loading the kernels."""
    seen, todo, outside = set(), ["mrnea.validate"], set()
    while todo:
        path = _file(todo.pop())
        if path is None or path in seen:
            continue
        seen.add(path)
        for m in _imports(path):
            if m.startswith("mrnea."):
                parts = m.split(".")
                todo += [".".join(parts[:k]) for k in range(2, len(parts) + 1)]
            else:
                outside.add(m.split(".")[0])
    assert SRC / "kernels" / "status.py" in seen
    assert "numba" not in outside, sorted(p.name for p in seen)


def _runtime_imports(path: Path) -> set[str]:
    """The mrnea modules ``path`` imports when it runs (lazy imports in functions too; not those
    under ``if TYPE_CHECKING:``), each resolved to a module file: ``from mrnea.x import y`` is
    ``mrnea.x.y`` where that is a module, else ``mrnea.x``."""
    names: set[str] = set()

    def visit(node: ast.AST) -> None:
        if isinstance(node, ast.If) and getattr(node.test, "id", "") == "TYPE_CHECKING":
            for child in node.orelse:
                visit(child)
            return
        if isinstance(node, ast.Import):
            names.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            for a in node.names:
                sub = f"{node.module}.{a.name}"
                names.add(sub if _file(sub) is not None else node.module)
        for child in ast.iter_child_nodes(node):
            visit(child)

    visit(ast.parse(path.read_text()))
    return {m for m in names if m == "mrnea" or m.startswith("mrnea.")}


def _module(path: Path) -> str:
    rel = path.relative_to(SRC).with_suffix("")
    parts = rel.parts[:-1] if rel.name == "__init__" else rel.parts
    return ".".join(("mrnea", *parts))


def _layer_table() -> list[tuple[str, list[str]]]:
    """The layers of docs/design.md's "package on one screen" table, top to bottom: (layer,
    the files column's entries: ``x.py``, ``x/y.py`` or a folder ``x/``)."""
    text = (SRC.parents[1] / "docs" / "design.md").read_text()
    section = text.split("## The package on one screen", 1)[1].split("\n## ", 1)[0]
    rows = [line.split("|")[1:3] for line in section.splitlines() if line.startswith("| ")]
    assert rows[0][0].strip() == "layer", rows[0]
    return [(layer.strip(), re.findall(r"`([^`]+)`", files)) for layer, files in rows[1:]]


def _layer_of(module: str, table: list[tuple[str, list[str]]]) -> int | None:
    """The row of ``module`` (``mrnea.x.y``; a package: its ``__init__.py``) in the table: a file
    named exactly, else the folder that holds it."""
    rel = module.split(".", 1)[1] if "." in module else ""
    named = {f"{rel.replace('.', '/')}.py", f"{rel.replace('.', '/')}/__init__.py"}
    for k, (_, files) in enumerate(table):
        if named & set(files):
            return k
    for k, (_, files) in enumerate(table):
        if any(f.endswith("/") and (rel + ".").startswith(f.replace("/", ".")) for f in files):
            return k
    return None


def test_imports_follow_the_layers_of_design_md() -> None:
    """Every module of the package has a row in docs/design.md's one-screen table, and each of
    its runtime imports (lazy ones included; a subpackage's __init__ that an import runs too)
    is of its own row or one above: the order the document states is the order of the code."""
    table = _layer_table()
    assert len(table) > 10, table  # the table was found
    wrong = []
    for path in SRC.rglob("*.py"):
        mod = _module(path)
        if mod == "mrnea":  # the package's __init__ gathers the public API from every layer
            continue
        row = _layer_of(mod, table)
        assert row is not None, f"{mod} has no row in docs/design.md's table"
        own = {".".join(mod.split(".")[:k]) for k in range(1, mod.count(".") + 1)}
        for target in _runtime_imports(path):
            parts = target.split(".")
            for dep in {".".join(parts[:k]) for k in range(2, len(parts) + 1)} - own - {mod}:
                dep_row = _layer_of(dep, table)
                if dep_row is None or dep_row > row:
                    wrong.append(f"{mod} ({table[row][0]}) imports {dep} "
                                 f"({'no row' if dep_row is None else table[dep_row][0]})")
    assert not wrong, "\n".join(sorted(wrong))


def test_imports_form_no_cycle() -> None:
    """Imports point down (docs/design.md, "Import order"): the graph of every module's runtime
    imports, lazy ones included, has no cycle. Importing ``mrnea.a.b`` also runs the package
    ``mrnea.a``'s __init__ (an edge too, except to the importer's own packages)."""
    graph: dict[str, set[str]] = {}
    for path in SRC.rglob("*.py"):
        mod = _module(path)
        own = {".".join(mod.split(".")[:k]) for k in range(1, mod.count(".") + 1)}
        edges = set()
        for target in _runtime_imports(path):
            parts = target.split(".")
            edges |= {".".join(parts[:k]) for k in range(1, len(parts) + 1)} - own
        graph[mod] = edges - {mod}
    assert "mrnea.report.html" in graph["mrnea.simulate"]  # SimulationResult.report (lazy)
    assert not any(m.startswith("mrnea.simulate") for m in graph["mrnea.report.html"])
    state: dict[str, int] = {}  # 1: on the current path, 2: done

    def cycle_from(mod: str, path: list[str]) -> list[str] | None:
        state[mod] = 1
        for nxt in sorted(graph.get(mod, ())):
            if state.get(nxt) == 1:
                return [*path, mod, nxt]
            if nxt not in state:
                found = cycle_from(nxt, [*path, mod])
                if found:
                    return found
        state[mod] = 2
        return None

    for mod in sorted(graph):
        if mod not in state:
            found = cycle_from(mod, [])
            assert found is None, " -> ".join(found[found.index(found[-1]):])

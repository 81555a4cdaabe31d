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
from pathlib import Path

import numpy as np
import pytest
from conftest import random_chain

import mrnea
from mrnea import compiled
from mrnea.kernels.layout import (
    ACHIEVABLE,
    NACT,
    NCOL,
    POSE,
    REACTIONS,
    SOLVE,
    achievable_buffers,
    drive_solve_buffers,
    effort_buffer,
    entry_scratch,
    force_buffers,
    mrnea_buffers,
    pose_buffers,
    solve_buffers,
)

SRC = Path(mrnea.__file__).parent


def _py(fn):
    """A slot function's Python source (the views it returns, on NumPy arrays)."""
    return getattr(fn, "py_func", fn)


def _slots(kind: int, n: int) -> dict[str, list[np.ndarray]]:
    ws = entry_scratch(n, kind)
    out = {"pose": list(_py(pose_buffers)(ws, n)), "mrnea": list(_py(mrnea_buffers)(ws, n)),
           "force": list(_py(force_buffers)(ws, n)), "effort": [_py(effort_buffer)(ws)]}
    if kind in (SOLVE, ACHIEVABLE):
        out["solve"] = list(_py(solve_buffers)(ws, n))
    if kind == ACHIEVABLE:
        out["achievable"] = list(_py(achievable_buffers)(ws, n))
        out["drive_solve"] = list(_py(drive_solve_buffers)(ws, n))
    return out


SHAPES = {  # (rows, columns) of each slot, in units of n: the layout module's docstring
    "pose": ["n33", "n3", "n3", "n3", "n33"], "mrnea": ["n3"] * 4, "force": ["n3"] * 2,
    "effort": ["n"], "solve": ["nn", "nn", "n", "n"],
    "achievable": ["nn", *["n"] * 6],
    "drive_solve": ["nn", "nn", *["n"] * 4, "2n", "3n", *["n"] * 4],
}
# the slots used at the same time: a kernel's own, and those of every kernel it calls
TOGETHER = {
    POSE: [("pose", "mrnea"), ("pose", "force")],
    REACTIONS: [("pose", "force", "effort")],
    SOLVE: [("pose", "mrnea", "solve"), ("pose", "force", "solve")],
    ACHIEVABLE: [("pose", "mrnea", "achievable", "drive_solve"),
                 ("pose", "force", "achievable", "drive_solve"), ("pose", "force", "effort")],
}


@pytest.mark.parametrize("n", [1, 2, 7])
@pytest.mark.parametrize("kind", [POSE, REACTIONS, SOLVE, ACHIEVABLE])
def test_slots_fit_their_scratch_and_do_not_overlap(kind: int, n: int) -> None:
    slots = _slots(kind, n)
    want = {"n": (n,), "n3": (n, 3), "n33": (n, 3, 3), "nn": (n, n), "2n": (2, n),
            "3n": (3, n)}
    for name, views in slots.items():
        assert [v.shape for v in views] == [want[s] for s in SHAPES[name]], name
    for group in TOGETHER[kind]:
        views = [(name, k, v) for name in group for k, v in enumerate(slots[name])]
        for (a, i, x), (b, j, y) in itertools.combinations(views, 2):
            assert not np.shares_memory(x, y), f"{a}[{i}] and {b}[{j}] overlap"


def test_integer_slots_are_integers() -> None:
    *_, pat, nbp, idx, tabu = _py(drive_solve_buffers)(entry_scratch(3, ACHIEVABLE), 3)
    assert all(a.dtype == np.int64 for a in (pat, nbp, idx, tabu))


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
    model, shape, ws, act = compiled.BY_ID[id(robot)]
    assert model.shape == (6, NCOL) and act.shape == (5, NACT) and shape == (5,)
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

"""The package's layers, enforced: every import inside patchlight goes down the layer order
(docs/architecture.md, "Layers"), never up or sideways, no private name or module is imported
across packages, no private name across modules (a package's own private modules, such as its
`_kernels`, excepted) nor any object's private attribute outside its class, and no CLI
subcommand imports another.

Imports are read from the source with ast, so lazy imports inside functions count too."""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

from patchlight.cli.parser import SUBCOMMANDS

ROOT = Path(__file__).resolve().parents[1] / "src" / "patchlight"

# Bottom first. A package may import only from layers below its own.
LAYERS = (
    ("errors", "shaders"),  # shaders: GLSL files only
    ("config", "progress", "limits"),
    ("imaging",),
    ("shading", "outputs"),  # outputs: folders written as one set, the writers' lock
    ("scene",),
    ("atlas", "rays"),
    ("radiosity",),
    ("bake", "bakedir", "normalmap"),
    ("solved",),
    ("volumes", "ground", "render"),
    ("patchview",),  # the view from one texel of a bake, drawn as render draws pictures
    ("viewer", "inputs", "blender"),  # inputs: what a command-line name or path stands for
    ("cli",),
    ("__init__",),  # the public API: patchlight.load_scene, bake, ...
)
LAYER = {name: i for i, names in enumerate(LAYERS) for name in names}


def _module_name(path: Path, root: Path | None = None) -> list[str]:
    parts = list(path.relative_to(root or ROOT).with_suffix("").parts)
    return parts[:-1] if parts[-1] == "__init__" else parts


def _imports(path: Path, root: Path | None = None) -> list[tuple[list[str], list[str], int]]:
    """(target module parts below patchlight, imported names, line) of every import in `path`."""
    here = _module_name(path, root)
    package = here if path.name == "__init__.py" else here[:-1]
    found = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.ImportFrom):
            names = [a.name for a in node.names]
            if node.level:
                base = package[:len(package) - (node.level - 1)]
                if node.module is None:  # `from .. import bakedir`: each name is a module
                    found.extend((base + [name], [], node.lineno) for name in names)
                    continue
                target = base + node.module.split(".")
            elif (node.module or "").split(".")[0] == "patchlight":
                target = node.module.split(".")[1:]
            else:
                continue
            found.append((target, names, node.lineno))
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.split(".")[0] == "patchlight":
                    found.append((alias.name.split(".")[1:], [], node.lineno))
    return found


def _package(parts: list[str]) -> str:
    return parts[0] if parts else "__init__"


def _sources() -> list[Path]:
    return sorted(p for p in ROOT.rglob("*.py") if "static" not in p.parts)


def package_graph() -> dict[str, set[str]]:
    """Package -> the packages it imports (its own left out)."""
    graph: dict[str, set[str]] = {}
    for path in _sources():
        source = _package(_module_name(path))
        for target, _, _ in _imports(path):
            if _package(target) != source:
                graph.setdefault(source, set()).add(_package(target))
    return graph


def test_every_package_has_a_layer():
    packages = {_package(_module_name(p)) for p in _sources()}
    assert packages <= set(LAYER), f"put {sorted(packages - set(LAYER))} into LAYERS"


def test_imports_only_go_down():
    upward = []
    for path in _sources():
        source = _package(_module_name(path))
        for target, _, line in _imports(path):
            dest = _package(target)
            if dest != source and LAYER.get(dest, -1) >= LAYER[source]:
                upward.append(f"{path.relative_to(ROOT)}:{line} ({source}) imports {'.'.join(target)} ({dest})")
    assert not upward, "imports that do not go down a layer:\n" + "\n".join(upward)


def test_no_cycle_between_packages():
    graph = package_graph()
    state: dict[str, int] = {}

    def visit(node, trail):
        state[node] = 1
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == 1:
                pytest.fail("import cycle: " + " -> ".join(trail[trail.index(nxt):] + [nxt]))
            if nxt not in state:
                visit(nxt, trail + [nxt])
        state[node] = 2

    for node in sorted(graph):
        if node not in state:
            visit(node, [node])


def test_no_private_imports_across_packages():
    private = []
    for path in _sources():
        source = _package(_module_name(path))
        for target, names, line in _imports(path):
            if _package(target) == source:
                continue
            hidden = [p for p in target + names if p.startswith("_") and not p.startswith("__")]
            if hidden:
                private.append(f"{path.relative_to(ROOT)}:{line} imports {'.'.join(target)} {names}")
    assert not private, "private modules or names imported from another package:\n" + "\n".join(private)


def _private(name: str) -> bool:
    return name.startswith("_") and not name.startswith("__")


def test_no_private_names_across_modules():
    """`from .uvs import _edge_codes` or `gatherer._see(...)`: a private name used outside the
    module (or class) that owns it. Attributes of modules from outside patchlight (os._exit)
    are the standard library's business."""
    private = []
    for path in _sources():
        tree = ast.parse(path.read_text(), str(path))
        outside = {(a.asname or a.name).split(".")[0] for node in ast.walk(tree) if isinstance(node, ast.Import)
                   for a in node.names if a.name.split(".")[0] != "patchlight"}
        for target, names, line in _imports(path):
            if any(_private(n) for n in names):
                private.append(f"{path.relative_to(ROOT)}:{line} imports {[n for n in names if _private(n)]} "
                               f"from {'.'.join(target)}")
        for node in ast.walk(tree):
            if isinstance(node, ast.Attribute) and _private(node.attr):
                owner = node.value.id if isinstance(node.value, ast.Name) else None
                if owner not in ("self", "cls") and owner not in outside:
                    private.append(f"{path.relative_to(ROOT)}:{node.lineno} uses {ast.unparse(node)}")
    assert not private, "private names used outside their module or class:\n" + "\n".join(private)


def test_cli_subcommands_do_not_import_one_another():
    crossing = []
    for name in SUBCOMMANDS:
        path = ROOT / "cli" / f"{name}.py"
        for target, names, line in _imports(path):
            reached = {target[1]} if target[:1] == ["cli"] and len(target) > 1 else set()
            if (reached & set(SUBCOMMANDS)) - {name}:
                crossing.append(f"cli/{name}.py:{line} imports {'.'.join(target)} {names}")
    assert not crossing, "subcommands importing each other (share through cli/options.py):\n" + "\n".join(crossing)


def test_relative_and_lazy_imports_are_resolved(tmp_path):
    """A function-level `from ..ground.track import track` in scene/x.py reads as scene -> ground."""
    (tmp_path / "scene").mkdir()
    (tmp_path / "scene" / "x.py").write_text("def f():\n    from ..ground.track import track\n    from . import model\n")
    assert [t[:2] for t in _imports(tmp_path / "scene" / "x.py", tmp_path)] == [
        (["ground", "track"], ["track"]), (["scene", "model"], [])]


if __name__ == "__main__":  # python tests/test_layers.py: the package graph, top layer first, and the largest modules
    graph = package_graph()
    for package in sorted(graph, key=lambda p: -LAYER[p]):
        print(f"{package} -> {', '.join(sorted(graph[package], key=lambda p: -LAYER[p]))}")
    print(f"{sum(map(len, graph.values()))} edges between {len(LAYER)} packages and top-level modules")
    sizes = sorted(((len(p.read_text().splitlines()), p.relative_to(ROOT)) for p in _sources()), reverse=True)
    print("largest modules:", ", ".join(f"{path} {lines}" for lines, path in sizes[:5]))

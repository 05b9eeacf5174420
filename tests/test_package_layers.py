"""The package's concepts build on each other in one order, without cycles (docs/layout.md).

Read from the installed package's sources: every `from .x import`, `from ..x import` and
`import planicp.x` of a module is an edge from its subpackage to the imported one. A subpackage
may import only those below it in `LAYERS`; the modules at the top of the package (`se2`,
`laser_scan`, `_validation`, `_settings`, `progress`, the native `_core`, the version string) are the
base every layer may use.
`demo` and `cli` sit on top."""

from __future__ import annotations

import ast
from pathlib import Path

import planicp

LAYERS = ["io", "plans", "tracking", "mapping", "sim", "evaluation", "ros", "sweep", "demo", "cli"]
BASE = {"se2", "laser_scan", "_validation", "_settings", "progress", "_core", "data", "__version__"}
ROOT_PACKAGE = "__init__"
"""`planicp` itself, which re-exports every layer: only the top (`demo`, `cli`) may import it."""
ROOT = Path(planicp.__file__).parent


def imports(path: Path) -> set[str]:
    """The units of planicp that the module at `path` imports (itself excluded)."""
    relative = path.relative_to(ROOT).with_suffix("")
    package = list(relative.parts[:-1])
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom):
            if node.level == 0:
                if node.module and node.module.startswith("planicp."):
                    found.add(node.module.split(".")[1])
                continue
            base = package[: len(package) - (node.level - 1)] if node.level > 1 else package
            target = [*base, *(node.module.split(".") if node.module else [])]
            if target:
                found.add(target[0])
            else:  # `from . import x` at the top: a module, or a name the root package re-exports
                found.update(a.name if a.name in {*LAYERS, *BASE} else ROOT_PACKAGE for a in node.names)
        elif isinstance(node, ast.Import):
            found.update(a.name.split(".")[1] for a in node.names if a.name.startswith("planicp."))
    own = relative.parts[0] if len(relative.parts) > 1 else relative.name
    return {unit for unit in found if unit != own}


def test_each_concept_imports_only_those_below_it() -> None:
    upward = []
    for path in sorted(ROOT.rglob("*.py")):
        relative = path.relative_to(ROOT)
        unit = relative.parts[0] if len(relative.parts) > 1 else relative.stem
        if unit not in LAYERS:
            continue
        for used in imports(path):
            if used in BASE:
                continue
            if used == ROOT_PACKAGE:
                assert LAYERS.index(unit) >= LAYERS.index("demo"), f"{relative} imports planicp itself"
                continue
            assert used in LAYERS, f"{relative} imports planicp.{used}, which no layer names"
            if LAYERS.index(used) >= LAYERS.index(unit):
                upward.append(f"{relative} -> {used}")
    assert not upward, "imports against the layer order: " + ", ".join(upward)


def test_the_base_modules_import_no_concept() -> None:
    for name in sorted(BASE - {"_core", "data", "__version__"}):
        used = imports(ROOT / f"{name}.py") - BASE
        assert not used, f"planicp/{name}.py imports {sorted(used)}"

"""The package's layout: one layer a folder, each importing only downwards (issue 32).

Read from the source with `ast`, so these checks cost no imports: the layer order, the share of
intra-package imports deferred into functions, the size of modules and classes, the root's
modules; and, in a subprocess, that building the command-line parser imports no heavy library."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path


PKG = Path(__file__).resolve().parents[1] / "tiseg"

# Bottom to top. The root modules (errors, log, backend, _version) and the data
# package sit below every layer; `tiseg/__init__.py` is the public face and may import any.
LAYERS = ["output", "model", "solver", "setup", "run", "post", "apps"]
BASE = {"errors", "log", "backend", "_version", "data"}
HEAVY = ("taichi", "matplotlib", "dask", "distributed")


def _modules():
    for p in sorted(PKG.rglob("*.py")):
        parts = list(p.relative_to(PKG.parent).with_suffix("").parts)
        is_pkg = parts[-1] == "__init__"
        if is_pkg:
            parts = parts[:-1]
        yield ".".join(parts), is_pkg, p


def _rank(module: str) -> int | None:
    """The layer of a dotted module name: -1 for the base modules, None for the package root."""
    parts = module.split(".")
    if len(parts) < 2:
        return None
    if parts[1] in BASE:
        return -1
    return LAYERS.index(parts[1]) if parts[1] in LAYERS else None


def _import_target(node: ast.ImportFrom, package: list[str]) -> str:
    """The dotted module a ``from ... import`` names, its relative level resolved in
    ``package``."""
    if not node.level:
        return node.module or ""
    base = package[: len(package) - node.level + 1]
    return ".".join(base + ([node.module] if node.module else []))


def _imports():
    """(importer, imported module, deferred) for every import of a tiseg module."""
    found = []
    for mod, is_pkg, path in _modules():
        tree = ast.parse(path.read_text(encoding="utf-8"))
        package = mod.split(".") if is_pkg else mod.split(".")[:-1]

        def visit(node, deferred, mod=mod, package=package):
            for child in ast.iter_child_nodes(node):
                inner = deferred or isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef))
                if isinstance(child, ast.ImportFrom):
                    target = _import_target(child, package)
                    if target.split(".")[0] == "tiseg":
                        found.append((mod, target, deferred))
                elif isinstance(child, ast.Import):
                    for alias in child.names:
                        if alias.name.split(".")[0] == "tiseg":
                            found.append((mod, alias.name, deferred))
                visit(child, inner, mod, package)

        visit(tree, False)
    return found


def test_every_import_runs_down_the_layers():
    up = []
    for importer, target, deferred in _imports():
        a, b = _rank(importer), _rank(target)
        if a is None or b is None:
            continue
        if b > a:
            up.append(f"{importer} -> {target}{' (in a function)' if deferred else ''}")
    assert not up, "imports that run up the layers:\n" + "\n".join(up)


def test_the_root_holds_the_layers_and_at_most_six_modules():
    # (__main__ is Python's hook for `python -m tiseg` and the console script's light entry)
    root = sorted(p.stem for p in PKG.glob("*.py") if p.stem != "__main__")
    assert len(root) <= 6, root
    folders = {p.name for p in PKG.iterdir() if (p / "__init__.py").is_file()}
    assert set(LAYERS) <= folders, folders


def test_few_imports_hide_in_functions():
    """Lower layers are imported at module top; only what pulls in Taichi, matplotlib or Dask
    (and the lazy public names of `tiseg/__init__.py`) waits for first use."""
    inner = [(a, b) for a, b, deferred in _imports() if a != "tiseg"]
    deferred = sum(1 for a, b, d in _imports() if d and a != "tiseg")
    assert deferred <= 0.20 * len(inner), f"{deferred} of {len(inner)} imports are deferred"


def _class_sizes() -> dict[str, int]:
    """Lines of every class of the package, counting the classes it inherits from in the
    package (each once, however often it is reached): a mixin's methods are the class for a
    reader as well. A base is found by its name in the class's module, or through the
    module's ``from ... import`` of it; bases from outside the package count nothing."""
    classes: dict[str, tuple[int, list[str]]] = {}
    for mod, is_pkg, path in _modules():
        tree = ast.parse(path.read_text(encoding="utf-8"))
        package = mod.split(".") if is_pkg else mod.split(".")[:-1]
        names = {}  # a name bound by `from X import name` -> "X.name"
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom):
                target = _import_target(node, package)
                for alias in node.names:
                    names[alias.asname or alias.name] = f"{target}.{alias.name}"
        for node in ast.walk(tree):
            if isinstance(node, ast.ClassDef):
                bases = []
                for b in node.bases:
                    if isinstance(b, ast.Name):
                        bases.append(names.get(b.id, f"{mod}.{b.id}"))
                classes[f"{mod}.{node.name}"] = (node.end_lineno - node.lineno + 1, bases)

    def total(name, seen):
        if name in seen or name not in classes:
            return 0
        seen.add(name)
        own, bases = classes[name]
        return own + sum(total(b, seen) for b in bases)

    return {name: total(name, set()) for name in classes}


def test_a_class_counts_the_classes_it_inherits_from_the_package():
    """The counting itself, on a class with a base in the package (tiseg.errors)."""
    sizes = _class_sizes()
    own = sizes["tiseg.errors.TisegError"]
    assert sizes["tiseg.errors.InputError"] > own > 0


def test_no_module_over_900_lines_and_no_class_over_600():
    long_modules = []
    for mod, _, path in _modules():
        if path.read_text(encoding="utf-8").count("\n") > 900:
            long_modules.append(mod)
    # with the lines of the classes they inherit from in the package (_class_sizes)
    long_classes = [f"{c} ({n})" for c, n in _class_sizes().items() if n > 600]
    assert not long_modules and not long_classes, (long_modules, long_classes)


def test_the_command_line_parser_imports_no_heavy_library():
    code = (
        "import sys; from tiseg.apps.cli import build_parser; build_parser(); "
        f"print([m for m in {HEAVY!r} if m in sys.modules])"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]", out.stdout + out.stderr


def test_every_import_of_tiseg_names_a_module_that_exists():
    """A relative import one level short (easy to leave behind when a module moves) fails
    only when its function first runs: found here from the source."""
    modules = {mod for mod, _, _ in _modules()}
    missing = sorted(f"{a} -> {b}" for a, b, _ in _imports() if b not in modules)
    assert not missing, "imports of modules that do not exist:\n" + "\n".join(missing)


def _module_level_graph() -> dict[str, set[str]]:
    """importer -> the tiseg modules it imports at module level: every import outside
    functions, those under `if TYPE_CHECKING:` included (a circle a type checker follows still
    ties the two modules together for a reader, and forces the import to hide), `from pkg
    import sub` read as the submodule `pkg.sub`."""
    modules = {mod for mod, _, _ in _modules()}
    graph: dict[str, set[str]] = {}
    for mod, is_pkg, path in _modules():
        package = mod.split(".") if is_pkg else mod.split(".")[:-1]
        body = list(ast.parse(path.read_text(encoding="utf-8")).body)
        while body:
            node = body.pop()
            if isinstance(node, (ast.If, ast.Try)):
                body.extend(node.body + node.orelse + getattr(node, "finalbody", []))
                for handler in getattr(node, "handlers", []):
                    body.extend(handler.body)
            elif isinstance(node, ast.ImportFrom):
                target = _import_target(node, package)
                for alias in node.names:
                    sub = f"{target}.{alias.name}"
                    hit = sub if sub in modules else target
                    if hit in modules and hit != mod:
                        graph.setdefault(mod, set()).add(hit)
            elif isinstance(node, ast.Import):
                for alias in node.names:
                    if alias.name in modules:
                        graph.setdefault(mod, set()).add(alias.name)
    return graph


def test_no_import_cycles_when_modules_load():
    """No import circle between the package's modules: module-level imports, those for type
    checking included, as `_module_level_graph` reads them (imports inside functions, the
    deferred ones that `test_few_imports_hide_in_functions` counts, are not). A circle would
    make the import order matter. The package root's lazy attributes are not imports, and
    `from .. import backend` is the module tiseg.backend, not the root."""
    graph = _module_level_graph()
    graph.pop("tiseg", None)
    state: dict[str, int] = {}
    cycles = []

    def walk(node, path):
        state[node] = 1
        for nxt in sorted(graph.get(node, ())):
            if nxt == "tiseg":
                continue
            if state.get(nxt) == 1:
                cycles.append(" -> ".join(path[path.index(nxt) :] + [nxt]))
            elif nxt not in state:
                walk(nxt, [*path, nxt])
        state[node] = 2

    for node in sorted(graph):
        if node not in state:
            walk(node, [node])
    assert not cycles, "import cycles:\n" + "\n".join(cycles)

"""The module paths of before the layer folders, kept working.

tiseg's modules live in one folder per layer (``model``, ``solver``, ``setup``, ``run``,
``output``, ``post``, ``apps``). Scripts written earlier import ``tiseg.simulation``,
``tiseg.schedules``, ``tiseg.numerics.operator`` and so on: `OLD_PATHS` maps each old
module or package to its new place, and a meta-path finder answers an import of an old name
with the module at the new one (the same module object, so ``isinstance`` checks and monkeypatching
behave as before)."""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.util
import sys

OLD_PATHS = {
    "tiseg.material": "tiseg.model.material",
    "tiseg.steady": "tiseg.model.steady",
    "tiseg.stability": "tiseg.model.stability",
    "tiseg.exact_dambreak": "tiseg.model.exact_dambreak",
    "tiseg.physics": "tiseg.model.physics",
    "tiseg.numerics": "tiseg.solver.numerics",
    "tiseg.timestepping": "tiseg.solver.timestepping",
    "tiseg.reference": "tiseg.solver.reference",
    "tiseg.field_tree": "tiseg.solver.field_tree",
    "tiseg.scene": "tiseg.setup.scene",
    "tiseg.scene_reference": "tiseg.setup.reference",
    "tiseg.initial": "tiseg.setup.initial",
    "tiseg.paths": "tiseg.output.paths",
    "tiseg.simulation": "tiseg.run.simulation",
    "tiseg.callbacks": "tiseg.run.callbacks",
    "tiseg.schedules": "tiseg.run.schedules",
    "tiseg.guards": "tiseg.run.guards",
    "tiseg.checkpoint": "tiseg.run.checkpoint",
    "tiseg.limits": "tiseg.run.limits",
    "tiseg.output.run_folder": "tiseg.run.run_folder",
    "tiseg.steady_channel": "tiseg.post.problems.steady_channel",
    "tiseg.analysis": "tiseg.post.analysis",
    "tiseg.render": "tiseg.post.render",
    "tiseg.problems": "tiseg.post.problems",
    "tiseg.figures": "tiseg.apps.figures",
    "tiseg.cli": "tiseg.apps.cli",
    "tiseg.cli_reference": "tiseg.apps.cli_reference",
    "tiseg.commands": "tiseg.apps.commands",
    "tiseg.viewer": "tiseg.apps.viewer",
    "tiseg.sweep": "tiseg.apps.sweep",
    "tiseg.bench": "tiseg.apps.bench",
    "tiseg.estimate": "tiseg.apps.estimate",
}


def new_path(name: str) -> str | None:
    """The module that the old dotted ``name`` now is, or None if ``name`` is not an old one."""
    head, rest = name, ""
    while head:
        if head in OLD_PATHS:
            return OLD_PATHS[head] + rest
        head, dot, tail = head.rpartition(".")
        rest = dot + tail + rest
    return None


class _OldPathFinder(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Finds an old module name and loads it as the module at its new place."""

    def find_spec(self, fullname, path=None, target=None):
        new = new_path(fullname)
        if new is None:
            return None
        return importlib.util.spec_from_loader(fullname, self, is_package=True)

    def create_module(self, spec):
        module = importlib.import_module(new_path(spec.name))
        # importlib writes the alias' spec onto the module it gets back: keep the real one
        self._specs = getattr(self, "_specs", {})
        self._specs[spec.name] = module.__spec__
        return module

    def exec_module(self, module):
        real = self._specs.pop(module.__spec__.name, None) if hasattr(self, "_specs") else None
        if real is not None:
            module.__spec__ = real


def install() -> None:
    """Put the finder on ``sys.meta_path`` (once)."""
    if not any(isinstance(f, _OldPathFinder) for f in sys.meta_path):
        sys.meta_path.insert(0, _OldPathFinder())  # before the path finder, which would load
        # a second copy of a module found through the old parent's __path__

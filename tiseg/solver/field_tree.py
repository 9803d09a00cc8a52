"""One Taichi field tree per owner, freed when the owner goes.

Taichi's plain ``ti.field(..., shape=...)`` places every field under its root, which it
materialises into a new field tree (an SNode tree) at the next kernel launch and never frees until
``ti.init`` resets the runtime; the LLVM backends hold at most 512 trees per runtime. A
`FieldTree` instead collects the fields of one object (a simulation's operator, its guard)
in a ``ti.FieldsBuilder`` and frees them all at once with `FieldTree.destroy`, which runs
by itself when the owner is garbage collected (`FieldTree.free_with`). A process can then
make any number of simulations one after another.

The fields are dense arrays laid out exactly as ``ti.field(dtype, shape=...)`` lays them out, so
kernels give the same bits either way.
"""

from __future__ import annotations

import weakref

from .. import backend


_made = 0  # field trees made in this process (tests reset Taichi after a test that made one)
_made_by_generation: dict[int, int] = {}  # field trees made under each Taichi runtime
# what holds Taichi fields now: the live trees, and the objects with plain fields that
# registered through track() (renderers, the viewer's window)
_holders: weakref.WeakSet = weakref.WeakSet()


def made() -> int:
    """How many field trees this process has made so far."""
    return _made


def made_since_init() -> int:
    """How many field trees this process made under the current Taichi runtime."""
    return _made_by_generation.get(backend.generation(), 0)


def track(obj) -> None:
    """Count ``obj`` as holding Taichi fields for as long as it lives (see `live`)."""
    _holders.add(obj)


def untrack(obj) -> None:
    """Stop counting ``obj`` (a cache that rebuilds itself for a new runtime need not hold
    the current one)."""
    _holders.discard(obj)


def live() -> int:
    """How many field trees and tracked objects are alive: 0 means a Taichi reset invalidates
    nothing anyone holds."""
    return len(_holders)


class FieldTree:
    """Fields of one owner, allocated with `field` and `vector`, usable after
    `finalize`, freed by `destroy` (or with the owner, see `free_with`)."""

    def __init__(self):
        import taichi as ti

        global _made
        _made += 1
        _holders.add(self)
        self._ti = ti
        self._builder = ti.FieldsBuilder()
        self._tree = None
        self._generation = backend.state().generation
        _made_by_generation[self._generation] = _made_by_generation.get(self._generation, 0) + 1

    def _place(self, f, shape):
        shape = (shape,) if isinstance(shape, int) else tuple(int(n) for n in shape)
        if shape:
            self._builder.dense(self._ti.axes(*range(len(shape))), shape).place(f)
        else:
            self._builder.place(f)
        return f

    def field(self, dtype, shape):
        """A scalar field of ``dtype`` and ``shape`` (() for a 0-D field)."""
        return self._place(self._ti.field(dtype), shape)

    def vector(self, n: int, dtype, shape):
        """A field of n-vectors of ``dtype`` and ``shape``."""
        return self._place(self._ti.Vector.field(n, dtype), shape)

    def finalize(self) -> None:
        """Build the tree: the fields exist from now on (call before any kernel reads them)."""
        self._tree = self._builder.finalize()

    def destroy(self) -> None:
        """Free the fields (a no-op when already freed, or when ``tiseg.init`` reset the
        runtime that held them: their tree went with it)."""
        tree, self._tree = self._tree, None
        _holders.discard(self)
        if tree is not None and backend.is_initialised():
            if backend.state().generation == self._generation:
                tree.destroy()

    def free_with(self, owner) -> None:
        """Destroy the fields when ``owner`` is garbage collected (not at interpreter exit,
        where the runtime goes anyway and may already be shutting down)."""
        weakref.finalize(owner, self.destroy).atexit = False

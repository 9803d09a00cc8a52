"""`data_oriented`: Taichi's class decorator with a fast attribute lookup.

``ti.data_oriented`` replaces the class's ``__getattribute__`` by a Python function that,
for every attribute read, looks the name up in the class, asks whether the value is a kernel
and binds it if so. Kernels of such a class need it (``self.kernel(...)`` must give a bound
kernel), but the host code reads many plain attributes of these objects on every step (the
operator's state, its ranges and caches), and Taichi's own launch path asks each ``self``
argument whether it is data-oriented: about 670 reads a step of the split fingers step, a
quarter of a warm step's wall time on a small grid (benchmarks/step_overhead.py).

This decorator keeps Taichi's lookup for the names that need it, the class's properties and
the attributes whose value is a kernel, and reads every other attribute as Python does. The
values returned are the same objects either way.
"""

from __future__ import annotations

import taichi as ti


def _slow_names(cls) -> frozenset:
    """Names whose class attribute (anywhere in the MRO) is a property or a Taichi kernel:
    Taichi's lookup handles these (it binds kernels and calls properties)."""
    out = set()
    for klass in cls.__mro__:
        for name, value in vars(klass).items():
            if isinstance(value, property) or hasattr(value, "_is_wrapped_kernel"):
                out.add(name)
            elif isinstance(value, (staticmethod, classmethod)) and hasattr(
                value.__func__, "_is_wrapped_kernel"
            ):
                out.add(name)
    return frozenset(out)


def data_oriented(cls):
    """``ti.data_oriented(cls)`` with a fast lookup of plain attributes (see the module)."""
    cls = ti.data_oriented(cls)
    taichi_lookup = cls.__getattribute__
    slow = _slow_names(cls)
    plain = object.__getattribute__

    def __getattribute__(self, name):
        if name in slow:
            return taichi_lookup(self, name)
        value = plain(self, name)
        if hasattr(value, "_is_wrapped_kernel"):  # a kernel kept on the instance
            return taichi_lookup(self, name)
        return value

    cls.__getattribute__ = __getattribute__
    return cls


__all__ = ["data_oriented"]

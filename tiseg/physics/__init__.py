"""Pointwise physics: fluxes, wave speeds, friction and sources of one state.

`pointwise` holds the Taichi functions (``Physics``), `friction` the friction laws
as components (Taichi function, NumPy twin, parameter slots, bounds) and `params` the
indices of the run-time numbers. Nothing here indexes a field; the loops over cells and faces
live in `tiseg.numerics`. This package imports no Taichi by itself, so the scene can read
the friction registry without starting it.
"""

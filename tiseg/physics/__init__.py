"""Pointwise physics as Taichi functions: fluxes, wave speeds, friction and sources of one state.

Nothing here indexes a field; the loops over cells and faces live in :mod:`tiseg.numerics`.
"""

from .pointwise import Params, Physics

__all__ = ["Physics", "Params"]

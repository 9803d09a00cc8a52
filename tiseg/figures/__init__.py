"""Figures of the paper regenerated from the library (matplotlib, Agg backend, no pyplot state).

* :mod:`.stability` -- figures 8-11 (steady Froude number, growth rates, sigma_Max and k_c).

Modules are imported on demand so that ``import tiseg.figures`` does not load matplotlib.
"""

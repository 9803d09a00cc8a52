"""The solver: the numerics that discretise the model on a grid (reconstructions, fluxes,
boundaries, rest masks, the Taichi operator and the split sweeps), the time steppers, and the
plain NumPy twins of the operators that the tests compare against."""

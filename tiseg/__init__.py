"""tiseg: segregation-induced finger formation in granular avalanches.

Implements Baker, Johnson & Gray (2016), J. Fluid Mech. 809: the depth-averaged bidisperse model,
its steady uniform states (section 4), its linear stability (section 5, appendices A-B) and 2D
simulations (section 6) with a Kurganov-Tadmor scheme in Taichi on CPU or GPU.
"""

from ._version import __version__
from .backend import init
from .errors import InputError, TisegError

__all__ = [
    "init",
    "Material",
    "Species",
    "TABLE1",
    "steady_state",
    "SteadyState",
    "TisegError",
    "InputError",
    "__version__",
]


def __getattr__(name):
    # Heavier parts (NumPy and up) are imported on first use so that `import tiseg` stays light:
    # the command line installs its Ctrl-C handling only once `tiseg` is imported.
    if name in ("material", "steady"):
        import importlib

        return importlib.import_module(f".model.{name}", __name__)
    if name in ("TABLE1", "Material", "Species"):
        from .model import material

        return getattr(material, name)
    if name in ("SteadyState", "steady_state"):
        from .model import steady

        return getattr(steady, name)
    if name in ("Simulation",):
        from .run.simulation import Simulation

        return Simulation
    if name in ("load_scene", "Scene"):
        from .setup import scene

        return getattr(scene, name)
    raise AttributeError(name)

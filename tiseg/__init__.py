"""tiseg: segregation-induced finger formation in granular avalanches.

Implements Baker, Johnson & Gray (2016), J. Fluid Mech. 809: the depth-averaged bidisperse model,
its steady uniform states (section 4), its linear stability (section 5, appendices A-B) and 2D
simulations (section 6) with a Kurganov-Tadmor scheme in Taichi on CPU or GPU.
"""

from .backend import init
from .errors import InputError, TisegError
from .material import TABLE1, Material, Species
from .steady import SteadyState, steady_state

__version__ = "0.1.0"

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
    # Heavier parts are imported on first use so that `import tiseg` stays light.
    if name in ("Simulation",):
        from .simulation import Simulation

        return Simulation
    if name in ("load_scene", "Scene"):
        from . import scene

        return getattr(scene, name)
    raise AttributeError(name)

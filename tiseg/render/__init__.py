"""Pictures of a run: one Taichi colour kernel for frames, movies, the viewer and panels.

* `render_fields` - NumPy fields (one snapshot) -> uint8 RGB image.
* `FrameRenderer` - the same picture straight from a running simulation's Taichi state.
* `annotate`, `add_colourbar` - time stamp, scale bar, colour bar burned in.
* `MovieWriter`, `FrameFolderWriter`, `render_run` - mp4 / GIF / PNG frames.
* `MovieRecorder` - frames of a running simulation into a movie (run, demo, viewer).
* `plot_panels` - paper-style matplotlib panels (figures 12-14), the kernel's pictures
  computed in NumPy (`tiseg.render.raster`): they need no Taichi.

Colours (``tiseg.render.colours``): phi = 1 white fines, phi = 0 brown coarse grains, turquoise
empty chute (h < h_min); viridis for h, |u|, u, v. x runs left to right, y bottom to top.
"""

from .colours import CHUTE_RGB, COARSE_RGB, FIELD_NAMES, FINES_RGB, canonical_field, viridis_table
from .raster import image_size

__all__ = [
    "render_fields",
    "FrameRenderer",
    "annotate",
    "add_colourbar",
    "image_size",
    "MovieWriter",
    "MovieRecorder",
    "FrameFolderWriter",
    "render_run",
    "plot_panels",
    "FINES_RGB",
    "COARSE_RGB",
    "CHUTE_RGB",
    "FIELD_NAMES",
    "canonical_field",
    "viridis_table",
]


def __getattr__(name):
    # frame imports Taichi, movie/panels imageio and matplotlib: import them only when asked
    # for (the panels and the movie writers need no Taichi)
    if name in ("FrameRenderer", "add_colourbar", "annotate", "render_fields"):
        from . import frame

        return getattr(frame, name)
    if name in ("MovieWriter", "MovieRecorder", "FrameFolderWriter", "render_run", "open_writer"):
        from . import movie

        return getattr(movie, name)
    if name in ("plot_panels",):
        from . import panels

        return getattr(panels, name)
    raise AttributeError(name)

"""Live GGUI viewer: run a scene and watch it evolve, with controls.

The picture is painted by the same frame kernel as every off-screen frame
(`tiseg.post.render.FrameRenderer`, straight from the Taichi state) into the window's image
field, which GGUI shows with ``canvas.set_image``; a scene with terrain has its bed
hill-shaded under the colours and its solid cells drawn as walls there, as in every picture
(`tiseg.post.render.relief`). Below the picture, three control panels:

* Run: pause/resume (space), single step (s), reset (r), screenshot (PNG), start/stop recording
  (mp4); simulated time, steps per second, real-time factor and frames per second.
* View: field (phi, h, |u|, u, v), relief shading, steps per frame.
* Parameters: inflow thickness and concentration, nu, slope angle. These are run-time numbers:
  `tiseg.run.simulation.Simulation.set_parameters` changes the scene and the operator
  together, without recompiling (the slope also changes the steady velocity u0 the inflow
  takes when the scene derives it). Reset restores the initial state and keeps the
  parameters; "scene values" restores the scene's.

Around the map (`tiseg.apps.viewer.captions`): at its right a colour bar with round ticks, their
numbers and the field's name and unit; under it a strip with the time stamp, a scale bar, the
status line (the last message, wrapped to the window's width) and a one-line hint of the keys;
``h`` shows a box with every key over the map. The captions are rasterised with Pillow into small
pictures only when their text changes, then copied into the window image each frame.

Recording is a callback of the simulation (`tiseg.post.render.movie.MovieRecorder`, the
movie path of ``tiseg run --movie`` and ``tiseg demo``): one frame every ``steps_per_frame``
steps, so a paused viewer records nothing.

GGUI needs Vulkan and, for a visible window, a display. A GGUI window that cannot open can kill the
process (no exception), so `display_problem` checks both *before* any window is made; where
either is missing the viewer says so in one line, suggests the off-screen path and exits with 2.
``Viewer(scene, show_window=False)`` runs without a display (Vulkan still needed) for tests and
benchmarks: `Viewer.run_frames` and `Viewer.capture`.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import glob
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

from tiseg.solver import field_tree
from tiseg.errors import TisegError
from tiseg.errors import InputError
from tiseg.apps.viewer import captions
from tiseg.post.render import colours as C
from tiseg.post.render.colours import FIELD_LABELS
from tiseg.post.render.colours import canonical_field

OFFSCREEN_HINT = (
    "use the off-screen path instead: `tiseg run SCENE --movie out.mp4` or "
    "`tiseg render RUN_DIR --movie out.mp4`"
)
FIELDS = (("phi", "phi"), ("h", "h"), ("speed", "|u|"), ("u", "u"), ("v", "v"))
# the older OperatorConfig names of set_params -> (scene key, value as the scene takes it)
CFG_KEYS = {
    "nu": ("flow.nu", float),
    "zeta": ("material.zeta_deg", math.degrees),
    "inflow_h": ("inflow.h", float),
    "inflow_phi": ("inflow.phi", float),
}


class DisplayUnavailable(TisegError):
    """No display or no Vulkan: the live window cannot open here."""


# =================================================================================================
# Is a window possible? (checked without touching GGUI)
# =================================================================================================
def _icd_manifests() -> list[str]:
    """Vulkan driver manifests the loader would find (Linux/BSD search order)."""
    env = os.environ.get("VK_DRIVER_FILES") or os.environ.get("VK_ICD_FILENAMES")
    if env:
        return [p for p in env.split(os.pathsep) if os.path.exists(p)]
    dirs = [
        os.environ.get("XDG_CONFIG_HOME", os.path.expanduser("~/.config")),
        "/etc/xdg",
        "/etc",
        os.environ.get("XDG_DATA_HOME", os.path.expanduser("~/.local/share")),
    ]
    dirs += (os.environ.get("XDG_DATA_DIRS") or "/usr/local/share:/usr/share").split(":")
    found = []
    for d in dirs:
        found += glob.glob(os.path.join(d, "vulkan", "icd.d", "*.json"))
    return found


class _VkInstanceCreateInfo(ctypes.Structure):
    _fields_ = [
        ("sType", ctypes.c_int),
        ("pNext", ctypes.c_void_p),
        ("flags", ctypes.c_uint32),
        ("pApplicationInfo", ctypes.c_void_p),
        ("enabledLayerCount", ctypes.c_uint32),
        ("ppEnabledLayerNames", ctypes.c_void_p),
        ("enabledExtensionCount", ctypes.c_uint32),
        ("ppEnabledExtensionNames", ctypes.c_void_p),
    ]


def vulkan_problem() -> str | None:
    """None when Vulkan works here (a loader, a driver and at least one device), else why not.

    Loads the Vulkan loader with ctypes, creates a bare instance and counts physical devices: a
    failure is a return code here, never a crash inside GGUI."""
    if sys.platform == "darwin":
        return _taichi_vulkan_problem()  # Taichi ships MoltenVK; no loader to probe
    names = ["vulkan-1.dll"] if sys.platform == "win32" else ["libvulkan.so.1", "libvulkan.so"]
    lib = None
    for name in names:
        try:
            lib = ctypes.CDLL(name)
            break
        except OSError:
            continue
    if lib is None:
        return (
            "no Vulkan loader (libvulkan.so.1) is installed; on Debian/Ubuntu: "
            "apt-get install libvulkan1 mesa-vulkan-drivers"
        )
    if sys.platform.startswith("linux") and not _icd_manifests():
        return (
            "no Vulkan driver (ICD) is installed; on Debian/Ubuntu: "
            "apt-get install mesa-vulkan-drivers"
        )
    try:
        info = _VkInstanceCreateInfo(
            1, None, 0, None, 0, None, 0, None
        )  # sType INSTANCE_CREATE_INFO
        inst = ctypes.c_void_p()
        lib.vkCreateInstance.restype = ctypes.c_int
        res = lib.vkCreateInstance(ctypes.byref(info), None, ctypes.byref(inst))
        if res != 0:
            return f"Vulkan is installed but no instance could be created (VkResult {res})"
        count = ctypes.c_uint32(0)
        lib.vkEnumeratePhysicalDevices.restype = ctypes.c_int
        res = lib.vkEnumeratePhysicalDevices(inst, ctypes.byref(count), None)
        lib.vkDestroyInstance(inst, None)
        if res != 0 or count.value == 0:
            return "Vulkan is installed but reports no device"
    except (AttributeError, OSError) as exc:
        return f"the Vulkan loader could not be used ({exc})"
    return _taichi_vulkan_problem()


def _taichi_vulkan_problem() -> str | None:
    """Taichi's own probe (it tries Vulkan at run time and answers False instead of crashing)."""
    try:
        from taichi._lib import core as _ti_core

        if not _ti_core.with_vulkan():
            return "Taichi cannot use Vulkan here (GGUI needs it)"
    except Exception:  # an old/odd Taichi without the probe: let GGUI try
        pass
    return None


def display_problem(show_window: bool = True) -> str | None:
    """None when a GGUI window can open here, else a one-line reason (checked: a display for a
    visible window, then Vulkan)."""
    if show_window and sys.platform.startswith(("linux", "freebsd")):
        disp = os.environ.get("DISPLAY")
        if not disp and not os.environ.get("WAYLAND_DISPLAY"):
            return "no display (DISPLAY is not set)"
        if disp and not _x_display_opens(disp):
            return f"the X display {disp!r} cannot be opened"
    return vulkan_problem()


def _x_display_opens(name: str) -> bool:
    """Whether Xlib can connect to the display (True when Xlib itself is not there to ask)."""
    path = ctypes.util.find_library("X11") or "libX11.so.6"
    try:
        x11 = ctypes.CDLL(path)
    except OSError:
        return True
    x11.XOpenDisplay.restype = ctypes.c_void_p
    x11.XOpenDisplay.argtypes = [ctypes.c_char_p]
    d = x11.XOpenDisplay(name.encode())
    if not d:
        return False
    x11.XCloseDisplay.argtypes = [ctypes.c_void_p]
    x11.XCloseDisplay(d)
    return True


# =================================================================================================
# The viewer
# =================================================================================================
class Viewer:
    """A simulation shown live in a GGUI window.

    ``scene``: a Scene, a built-in name or a TOML path (``overrides`` as for ``load_scene``), or
    pass a ready ``sim``. ``show_window=False`` renders off-screen (no display needed, Vulkan is).
    ``scale``: pixels per cell (default: fit the map to about 900-1400 pixels wide).
    ``save_dir``: where screenshots and recordings go.
    """

    BAR_W = captions.BAR_W  # colour bar column at the right of the map
    STRIP_H = captions.STRIP_H  # caption strip under the map
    PANEL_H = 230  # control panels below the map
    MIN_W = 760  # the three panels need this much width

    def __init__(
        self,
        scene=None,
        overrides=None,
        show_window: bool = True,
        field=None,
        scale: float | None = None,
        steps_per_frame: int = 1,
        shade: bool = True,
        arch: str | None = None,
        precision: str | None = None,
        threads: int = 0,
        save_dir=".",
        sim=None,
        stop_at_end: bool = True,
        fps_limit: int = 1000,
    ):
        problem = display_problem(show_window)
        if problem:
            raise DisplayUnavailable(f"cannot open the viewer: {problem}; {OFFSCREEN_HINT}")
        import taichi as ti

        from tiseg.post.render import FrameRenderer  # Taichi: first use only
        from tiseg.post.render.movie import MovieWriter  # noqa: F401  (fail early if imageio is missing)
        from tiseg.run.simulation import Simulation

        self.ti = ti
        if sim is None:
            if scene is None:
                raise TisegError("Viewer needs a scene or a simulation")
            from tiseg.setup.scene import load_scene

            sc = load_scene(scene, overrides)
            if precision:
                sc = sc.with_overrides({"numerics.precision": precision})
            sim = Simulation(sc, arch=arch, threads=threads)
        self.sim = sim
        self.show_window = show_window
        self.save_dir = Path(save_dir)
        self.stop_at_end = stop_at_end
        if field is None:
            field = "phi" if sim.layout.segregation else "h"
        self.is_1d = sim.layout.is_1d
        nx, ny = sim.layout.nx, sim.layout.ny
        if scale is None:
            aspect = 1.0 if self.is_1d else self.scene.dy / self.scene.dx
            scale = min(1400.0 / nx, max(1.0, 900.0 / nx))
            if not self.is_1d:
                scale = min(scale, 700.0 / (ny * aspect))
        self.renderer = FrameRenderer(sim, field=field, shade=shade, scale=scale)
        self.map_w = self.renderer.width
        self.map_h = self.renderer.height
        self.width = max(self.map_w + self.BAR_W, self.MIN_W)
        self.height = self.map_h + self.STRIP_H + self.PANEL_H
        # image y runs upwards: panels at the bottom, the caption strip above them, then the map
        self.map_x0, self.map_y0 = 0, self.PANEL_H + self.STRIP_H
        self.canvas_image = ti.Vector.field(3, ti.f32, shape=(self.width, self.height))
        # caption pictures (uploaded when their text changes) and the keys' box
        self._bar_image = ti.Vector.field(3, ti.f32, shape=(self.BAR_W, self.map_h))
        self._strip_image = ti.Vector.field(3, ti.f32, shape=(self.width, self.STRIP_H))
        box = captions.help_box()
        self._help_image = ti.Vector.field(3, ti.f32, shape=(box.shape[1], box.shape[0]))
        _upload(self._help_image, box)
        self._bar_key = self._strip_key = None
        self.show_help = False
        field_tree.track(self)  # plain fields and a window: no Taichi reset under it
        title = f"tiseg viewer - {self.scene.name} ({nx} x {ny} cells)"
        self.window = ti.ui.Window(
            title,
            (self.width, self.height),
            vsync=False,
            show_window=show_window,
            fps_limit=fps_limit,
        )
        self.canvas = self.window.get_canvas()
        self.gui = self.window.get_gui()
        self.steps_per_frame = int(steps_per_frame)
        self.paused = False
        self.message = ""
        self.record_path: Path | None = None
        self.frames = 0
        self.scene0 = sim.scene  # what "scene values" restores
        self._clock: list[tuple[float, int, float]] = []  # (wall, steps, t) for the readouts
        self._captured = None
        self._clear_background()

    # ------------------------------------------------------------------ simulation control
    def step(self, n: int = 1) -> int:
        """Advance n time steps (fewer if the scene's end is reached and stop_at_end is on)."""
        from tiseg.run.simulation import SimulationError

        done = 0
        for _ in range(n):
            before_end = self.sim.t < self.scene.t_end - 1e-12
            try:
                self.sim.step()  # lands on t_end, then runs on
            except SimulationError as exc:
                self.paused = True
                self.message = f"stopped: {exc}"
                break
            done += 1
            if self.stop_at_end and before_end and self.sim.t >= self.scene.t_end - 1e-12:
                self.paused = True
                self.message = f"reached t_end = {self.scene.t_end:g} s (Resume runs on)"
                break
        return done

    def reset(self) -> None:
        """Back to the initial state; the parameters stay as set."""
        self.sim.reset()
        self._clock.clear()
        self.message = "reset"

    def set_params(self, changes: dict | None = None, **cfg_names) -> None:
        """Change run-time parameters: scene keys, e.g. ``set_params({"flow.nu": 0.02,
        "material.zeta_deg": 28, "inflow.h": 0.003})``, or the older OperatorConfig names
        ``nu``, ``zeta`` [rad], ``inflow_h``, ``inflow_phi`` as keywords."""
        changes = dict(changes or {})
        for name, value in cfg_names.items():
            if name not in CFG_KEYS:
                raise TisegError(
                    f"set_params: unknown parameter {name!r}; use scene keys "
                    f"or one of {', '.join(CFG_KEYS)}"
                )
            key, to_scene = CFG_KEYS[name]
            changes[key] = to_scene(value)
        self.sim.set_parameters(changes)

    def set_field(self, field: str) -> None:
        self.renderer.set_field(field)

    # ------------------------------------------------------------------ drawing
    def _clear_background(self) -> None:

        self.renderer.painter.fill(
            self.canvas_image, 0, 0, self.width, self.height, *C.BACKGROUND_RGB
        )

    def draw(self) -> None:
        """Paint the map, its colour bar, the caption strip and (when on) the keys' box into the
        window image and hand it to the canvas."""
        r = self.renderer
        r.paint_into(self.canvas_image, self.map_x0, self.map_y0, self.map_w, self.map_h)
        self._update_captions()
        from tiseg.apps.viewer.blit import blit

        img, y_min = self.canvas_image, self.PANEL_H
        blit(img, self._bar_image, self.map_w, self.map_y0, y_min, 1.0)
        blit(img, self._strip_image, 0, self.PANEL_H, y_min, 1.0)
        if self.show_help:  # at the map's top left, over the strip if the map is low
            bw, bh = self._help_image.shape
            blit(img, self._help_image, 8, self.height - 8 - bh, y_min, 0.9)
        self.canvas.set_image(self.canvas_image)

    def caption_texts(self) -> dict:
        """What the captions say now: time stamp (with the field shown and the run's state),
        status line and hint (strings), and the scale bar
        (`tiseg.apps.viewer.captions.ScaleBar` or None)."""
        stamp = captions.time_text(self.sim.t, self.scene.t_end)
        stamp += "   " + captions.field_title(self.renderer.field)
        if self.recorder is not None:
            stamp += "   recording"
        if self.paused:
            stamp += "   paused"
        return {
            "stamp": stamp,
            "bar": captions.scale_bar(self.map_w, self.renderer.pixel_size),
            "status": self.message,
            "hint": captions.hint_line(),
        }

    def _update_captions(self) -> None:
        r = self.renderer
        key = (r.field, r.vrange)
        if key != self._bar_key:
            _upload(self._bar_image, captions.colour_bar_column(r.field, *r.vrange, self.map_h))
            self._bar_key = key
        texts = self.caption_texts()
        key = tuple(texts.values())
        if key != self._strip_key:
            strip = captions.caption_strip(self.width, self.map_w, **texts, height=self.STRIP_H)
            _upload(self._strip_image, strip)
            self._strip_key = key

    def toggle_help(self) -> None:
        self.show_help = not self.show_help

    def next_field(self) -> str:
        """Switch to the next field this run has (phi, h, |u|, u, v) and return its name."""
        names = self.available_fields()
        i = names.index(self.renderer.field) if self.renderer.field in names else -1
        self.set_field(names[(i + 1) % len(names)])
        return self.renderer.field

    def available_fields(self) -> list[str]:
        return [
            name
            for name, _ in FIELDS
            if not (name == "v" and self.is_1d)
            and not (name == "phi" and not self.sim.layout.segregation)
        ]

    def frame(self) -> None:
        """One frame: events, controls, simulation steps (unless paused), drawing, showing."""
        if self.show_window:
            self._events()
        self._controls()
        if not self.paused:
            self.step(self.steps_per_frame)
        self.draw()
        self._tick()
        if self.show_window:
            self.window.show()  # never without a window: GGUI crashes on that
        self.frames += 1

    @property
    def scene(self):
        """The simulation's scene (set_parameters replaces it)."""
        return self.sim.scene

    @property
    def recorder(self):
        cb = self.sim.callbacks.get("viewer:recording")
        return None if cb is None else cb.func

    def run_frames(self, n: int) -> None:
        for _ in range(int(n)):
            self.frame()

    def run(self, max_frames: int | None = None) -> None:
        """The window loop, until the window is closed (or max_frames frames)."""
        try:
            while self.window.running and (max_frames is None or self.frames < max_frames):
                self.frame()
        finally:
            self.close()

    def capture(self) -> np.ndarray:
        """The window's current image as uint8 (H, W, 3), row 0 at the top.

        GGUI draws a frame when its buffer is read and then starts an empty one, so the picture
        is read once per frame and kept for further calls in the same frame."""

        if self._captured is None or self._captured[0] != self.frames:
            a = self.window.get_image_buffer_as_numpy()[:, :, :3]
            self._captured = (self.frames, C.to_uint8(np.transpose(a, (1, 0, 2))[::-1]))
        return self._captured[1].copy()

    def capture_map(self) -> np.ndarray:
        """The map part of `capture` (without colour bar and controls)."""
        img = self.capture()
        top = self.height - (self.map_y0 + self.map_h)
        return img[top : top + self.map_h, self.map_x0 : self.map_x0 + self.map_w]

    def screenshot(self, path=None) -> Path:
        """Save the current picture (with time stamp, scale bar, colour bar) as PNG."""
        import imageio.v3 as iio

        path = (
            Path(path)
            if path
            else self.save_dir
            / (f"tiseg-{self.scene.name}-{self.renderer.field}-t{self.sim.t:07.3f}.png")
        )
        path.parent.mkdir(parents=True, exist_ok=True)
        iio.imwrite(path, self.renderer.to_numpy(annotate_frame=True, colourbar=True))
        self.message = f"saved {path}"
        return path

    def start_recording(self, path=None, fps: float = 30.0) -> Path:
        """Record a frame every ``steps_per_frame`` steps (a callback of the simulation)."""
        from tiseg.post.render.movie import MovieRecorder
        from tiseg.run.schedules import IterationInterval

        self.stop_recording()
        path = (
            Path(path)
            if path
            else self.save_dir / (f"tiseg-{self.scene.name}-{time.strftime('%Y%m%d-%H%M%S')}.mp4")
        )
        rec = MovieRecorder(self.renderer, path, fps)
        self.sim.add_callback(
            rec.callback(IterationInterval(self.steps_per_frame), name="viewer:recording")
        )
        self.record_path = path
        self.message = f"recording to {path}"
        return path

    def stop_recording(self) -> None:
        rec = self.recorder
        if rec is not None:
            self.sim.remove_callback("viewer:recording")
            rec.close()
            self.message = f"saved {self.record_path} ({rec.count} frames)"

    def toggle_recording(self) -> None:
        if self.recorder is None:
            self.start_recording()
        else:
            self.stop_recording()

    def set_steps_per_frame(self, n: int) -> None:
        self.steps_per_frame = int(n)
        cb = self.sim.callbacks.get("viewer:recording")
        if cb is not None and cb.schedule.n != self.steps_per_frame:
            from tiseg.run.schedules import IterationInterval

            cb.schedule = IterationInterval(self.steps_per_frame)

    def close(self) -> None:
        self.stop_recording()
        try:
            self.window.destroy()
        except Exception:
            pass

    # ------------------------------------------------------------------ readouts
    def _tick(self) -> None:
        now = time.perf_counter()
        self._clock.append((now, self.sim.stats.steps, self.sim.t))
        while len(self._clock) > 2 and now - self._clock[0][0] > 2.0:
            self._clock.pop(0)  # rates over the last ~2 s of wall time

    def rates(self) -> dict:
        """Frames, steps and simulated seconds per wall second over the last ~2 s."""
        if len(self._clock) < 2:
            return {"fps": 0.0, "steps_per_s": 0.0, "realtime": 0.0}
        (w0, s0, t0), (w1, s1, t1) = self._clock[0], self._clock[-1]
        dw = max(w1 - w0, 1e-9)
        return {
            "fps": (len(self._clock) - 1) / dw,
            "steps_per_s": (s1 - s0) / dw,
            "realtime": (t1 - t0) / dw,
        }

    # ------------------------------------------------------------------ input
    def _events(self) -> None:
        ti = self.ti
        for e in self.window.get_events(ti.ui.PRESS):
            if e.key == ti.ui.ESCAPE:
                self.window.running = False
            elif e.key == ti.ui.SPACE:
                self.paused = not self.paused
            elif e.key == "s":
                self.paused = True
                self.step(1)
            elif e.key == "r":
                self.reset()
            elif e.key == "h":
                self.toggle_help()
            elif e.key == "f":
                self.next_field()
            elif e.key == "p":
                self.screenshot()
            elif e.key == "m":
                self.toggle_recording()

    def _controls(self) -> None:
        g = self.gui
        W, H = float(self.width), float(self.height)
        top = (self.height - self.PANEL_H + 4) / H  # GUI y runs downwards, in fractions
        ph = (self.PANEL_H - 8) / H
        x0 = 4 / W
        cw = (W - 16) / 3 / W
        with g.sub_window("Run", x0, top, cw, ph) as w:
            if w.button("Resume" if self.paused else "Pause"):
                self.paused = not self.paused
                self.message = ""
            if w.button("Step"):
                self.paused = True
                self.step(1)
            if w.button("Reset"):
                self.reset()
            if w.button("Screenshot (PNG)"):
                self.screenshot()
            if w.button("Stop recording" if self.recorder else "Record (mp4)"):
                self.toggle_recording()
            r = self.rates()
            w.text(f"t = {self.sim.t:.3f} s   steps {self.sim.stats.steps}")
            w.text(
                f"{r['steps_per_s']:.1f} steps/s  {r['fps']:.1f} fps  "
                f"x{r['realtime']:.3g} real time"
            )
        with g.sub_window("View", x0 + cw + 4 / W, top, cw, ph) as w:
            w.text(f"field: {self.renderer.field}")
            labels = dict(FIELDS)
            for name in self.available_fields():
                if w.button(f"show {labels[name]}"):
                    self.set_field(name)
            self.renderer.shade = (
                0.35 if w.checkbox("relief shading", self.renderer.shade > 0) else 0.0
            )
            self.set_steps_per_frame(w.slider_int("steps/frame", self.steps_per_frame, 1, 100))
            lo, hi = self.renderer.vrange
            if self.renderer.field != "phi":
                _, f, unit = FIELD_LABELS[self.renderer.field]
                w.text(f"range {lo * f:.3g} .. {hi * f:.3g} {unit}")
        with g.sub_window("Parameters", x0 + 2 * (cw + 4 / W), top, cw, ph) as w:
            self._parameter_sliders(w)

    def _parameter_sliders(self, w) -> None:
        cfg = self.sim.op.cfg
        changes = {}
        if cfg.bc[0] == "inflow":
            h_mm = w.slider_float("inflow h [mm]", cfg.inflow_h * 1e3, 0.1, 6.0)
            if abs(h_mm * 1e-3 - cfg.inflow_h) > 1e-9:
                changes["inflow.h"] = h_mm * 1e-3
            if self.sim.layout.segregation:
                ph = w.slider_float("inflow phi", cfg.inflow_phi, 0.0, 1.0)
                if abs(ph - cfg.inflow_phi) > 1e-6:
                    changes["inflow.phi"] = ph
        else:
            w.text("no inflow in this scene")
        if cfg.viscous:
            nu = w.slider_float("nu [m^1.5/s]", cfg.nu, 0.0, 0.05)
            if abs(nu - cfg.nu) > 1e-9:
                changes["flow.nu"] = nu
        else:
            w.text("viscosity off (compile-time)")
        deg = w.slider_float("slope [deg]", math.degrees(cfg.zeta), 15.0, 45.0)
        if abs(math.radians(deg) - cfg.zeta) > 1e-7:
            changes["material.zeta_deg"] = deg
        if w.button("scene values"):
            self.sim.set_parameters(scene=self.scene0)
            return
        if changes:
            try:
                self.set_params(changes)
            except TisegError as exc:  # e.g. a perturbation that leaves [0, 1]
                self.message = str(exc)


def _upload(field, picture: np.ndarray) -> None:
    """A uint8 picture (rows, columns, 3; row 0 at the top) into an image field (x right, y up)
    of the same size."""
    a = np.transpose(picture[::-1], (1, 0, 2)).astype(np.float32) / 255.0
    field.from_numpy(np.ascontiguousarray(a))


# =================================================================================================
# Command line (tiseg view, python -m tiseg.apps.viewer; python -m viewer in a source checkout)
# =================================================================================================
def add_arguments(p) -> None:
    """Options of the viewer (the scene options come from `tiseg run`)."""
    from tiseg.apps.commands.common import add_scene_arguments

    add_scene_arguments(p)
    p.add_argument("--field", default=None, help="phi (default), h, speed (|u|), u or v")
    p.add_argument("--scale", type=float, default=None, help="pixels per cell (default: fit)")
    p.add_argument(
        "--steps-per-frame",
        type=int,
        default=None,
        help="time steps per frame (default: chosen with the grid, else 1)",
    )
    p.add_argument("--no-shade", action="store_true", help="no relief shading")
    p.add_argument(
        "--frames",
        type=int,
        default=None,
        metavar="N",
        help="close after N frames (for scripted checks)",
    )
    p.add_argument("--record", default=None, metavar="OUT.mp4", help="record from the start")
    p.add_argument("--save-dir", default=".", help="folder for screenshots and recordings")
    p.add_argument(
        "--offscreen",
        action="store_true",
        help="no window (needs Vulkan, not a display); with --frames, for timing",
    )


def run_from_args(args) -> int:
    """Open the viewer as the arguments say; raises DisplayUnavailable/TisegError for the caller
    to report in one line."""

    if args.frames is not None and args.frames < 0:
        raise InputError(f"--frames={args.frames}: must be >= 0")
    if args.steps_per_frame is not None and args.steps_per_frame < 1:
        raise InputError(f"--steps-per-frame={args.steps_per_frame}: must be >= 1")
    show = not args.offscreen
    # check before importing/initialising anything heavy, and before any window exists
    problem = display_problem(show)
    if problem:
        raise DisplayUnavailable(f"cannot open the viewer: {problem}; {OFFSCREEN_HINT}")
    field = args.field
    if field is not None:
        try:
            field = canonical_field(field)
        except ValueError as exc:
            raise InputError(str(exc)) from None
    overrides = list(args.overrides)
    chosen, sim = _live_setting(args, overrides)
    steps_per_frame = args.steps_per_frame
    if chosen is not None:
        overrides.append(f"domain.resolution={chosen.resolution:g}")
        steps_per_frame = steps_per_frame or chosen.steps_per_frame
        print(f"viewer: {chosen.text()}", flush=True)
        if sim is not None and sim.scene.domain.nx != chosen.nx:
            sim = None  # a finer grid than the one measured: a Simulation of its own
    v = Viewer(
        args.scene,
        sim=sim,
        overrides=overrides,
        show_window=show,
        field=field,
        scale=args.scale,
        steps_per_frame=steps_per_frame or 1,
        shade=not args.no_shade,
        arch=args.arch,
        precision=args.precision,
        threads=args.threads,
        save_dir=args.save_dir,
    )
    if chosen is not None:
        v.message = chosen.status()
    if args.record:
        v.start_recording(args.record)
    wall = time.perf_counter()
    v.run(max_frames=args.frames)
    wall = time.perf_counter() - wall
    print(
        f"viewer: {v.frames} frames, t = {v.sim.t:.4g} s, {v.sim.stats.steps} steps in "
        f"{wall:.2f} s ({v.frames / max(wall, 1e-9):.1f} fps)"
    )
    if v.message.startswith("saved"):
        print(v.message)
    return 0


def _live_setting(args, overrides):
    """(the grid and steps per frame this machine shows live, the Simulation measured on),
    `tiseg.apps.viewer.live`; (None, None) where the command line sets the grid or the scene
    has none to choose."""
    from tiseg.apps.viewer import live
    from tiseg.setup.scene import load_scene

    scene = load_scene(args.scene, overrides)
    if not live.applies(scene, overrides):
        return None, None
    print("viewer: timing this machine to choose the grid (a few seconds) ...", flush=True)
    sim = live.probe(scene, args.arch, args.precision, args.threads)
    return live.choose(scene, live.measure(sim)), sim


def main(argv=None) -> int:
    import argparse

    p = argparse.ArgumentParser(
        prog="python -m tiseg.apps.viewer", description="Live GGUI view of a tiseg simulation."
    )
    add_arguments(p)
    args = p.parse_args(argv)
    try:
        return run_from_args(args)
    except TisegError as exc:
        sys.stderr.write(f"viewer: {exc}\n")
        return 2
    except KeyboardInterrupt:
        return 130

"""Movies and frame folders from rendered frames, and `render_run` for a finished run.

* mp4: imageio-ffmpeg's bundled ffmpeg (works offline), H.264 in yuv420p so every player opens
  it. yuv420p subsamples colour 2 x 2, so frames are padded to even sizes (with the background
  colour, at the right and bottom) instead of letting ffmpeg rescale them (macro_block_size=1).
* GIF: imageio's Pillow plugin, looping; frames are kept in memory until `close` (GIFs are
  for short clips).
* PNG frames: ``frame_00000.png`` ... in a folder.

Every writer takes uint8 (H, W, 3) frames; a frame of another size than the first is padded or
cropped to the first frame's size, because a video has one size.
"""

from __future__ import annotations

from ...output.names import FIELDS_FILE, SCENE_FILE

import contextlib
import errno
import math
import os
import re
import subprocess
import tempfile
from fractions import Fraction
from pathlib import Path

import numpy as np

from ...errors import InputError, TisegError
from . import colours as C
from ...run.callbacks import Callback
from ...log import bar_disable

DEFAULT_FPS = 10.0


def _fit(frame: np.ndarray, shape: tuple[int, int], fill) -> np.ndarray:
    """frame padded (with fill) or cropped at the right/bottom to shape (H, W)."""
    frame = np.asarray(frame)
    if frame.ndim != 3 or frame.shape[2] != 3 or frame.dtype != np.uint8:
        raise ValueError(f"a frame must be uint8 (H, W, 3), got {frame.dtype} {frame.shape}")
    H, W = shape
    if frame.shape[:2] == (H, W):
        return frame
    out = np.empty((H, W, 3), dtype=np.uint8)
    out[:] = fill
    h, w = min(H, frame.shape[0]), min(W, frame.shape[1])
    out[:h, :w] = frame[:h, :w]
    return out


def _check_fps(fps: float) -> float:
    fps = float(fps)
    if not (math.isfinite(fps) and fps > 0):
        raise InputError(f"fps={fps!r} must be a positive number")
    return fps


class MovieWriter:
    """Write frames to ``path``: mp4 (or .mov/.mkv/.avi/.webm through ffmpeg) or, when the suffix
    is .gif, an animated GIF. Use as a context manager or call `close`."""

    def __init__(self, path, fps: float = DEFAULT_FPS, quality: float = 8.0):
        self.path = Path(path)
        self.fps = _check_fps(fps)
        self.quality = quality
        self.gif = self.path.suffix.lower() == ".gif"
        self.count = 0
        self.shape: tuple[int, int] | None = None
        self._proc = None  # ffmpeg
        self._log = None
        self._frames: list[np.ndarray] = []
        self._fill = C.to_uint8(C.BACKGROUND_RGB)
        refuse_link(self.path)
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise InputError(
                f"cannot create the folder of {str(self.path)!r}: {exc.strerror}"
            ) from None

    def append(self, frame: np.ndarray) -> None:
        """Add one uint8 (H, W, 3) frame (row 0 at the top)."""
        frame = np.asarray(frame)
        if self.shape is None:
            h, w = frame.shape[:2]
            # yuv420p needs even sizes; GIF does not
            self.shape = (h, w) if self.gif else (h + h % 2, w + w % 2)
            if not self.gif:
                self._open()
        frame = np.ascontiguousarray(_fit(frame, self.shape, self._fill))
        if self.gif:
            self._frames.append(frame)
        else:
            self._send(frame.tobytes())
        self.count += 1

    def _open(self) -> None:
        """Start ffmpeg, reading raw RGB frames on its stdin. Started here rather than through
        imageio-ffmpeg's ``write_frames``, which never looks at ffmpeg's exit status: a movie on
        a full disk came out unplayable (no index) without any error."""
        import imageio_ffmpeg

        h, w = self.shape
        fps = Fraction(self.fps).limit_denominator()
        crf = int((1.0 - self.quality / 10.0) * 51)  # imageio-ffmpeg's quality scale, 51 worst
        cmd = [imageio_ffmpeg.get_ffmpeg_exe(), "-y", "-v", "error"]
        cmd += ["-f", "rawvideo", "-vcodec", "rawvideo", "-s", f"{w}x{h}", "-pix_fmt", "rgb24"]
        cmd += ["-r", str(fps), "-i", "-", "-an", "-vcodec", "libx264", "-pix_fmt", "yuv420p"]
        cmd += ["-crf", str(crf), str(self.path)]
        self._log = tempfile.TemporaryFile()  # ffmpeg's messages, for the one-line error
        # a session of its own: Ctrl-C stops tiseg, which then finishes the movie itself
        self._proc = subprocess.Popen(
            cmd,
            stdin=subprocess.PIPE,
            stdout=subprocess.DEVNULL,
            stderr=self._log,
            start_new_session=True,
        )

    def _send(self, data: bytes) -> None:
        try:
            self._proc.stdin.write(data)
        except OSError:  # ffmpeg has quit (it could not open the file, the disk is full, ...)
            self._finish()
            _remove_file(self.path)
            raise TisegError(f"cannot write the movie {str(self.path)!r}: ffmpeg quit") from None

    def _finish(self) -> None:
        """Wait for ffmpeg; when it failed, remove what it left and raise one line."""
        proc, self._proc = self._proc, None
        with contextlib.suppress(OSError):  # a pipe ffmpeg has already closed
            proc.stdin.close()
        status = proc.wait()
        self._log.seek(0)
        log = self._log.read().decode("utf-8", "replace")
        self._log.close()
        problem = None
        if status != 0:
            problem = _ffmpeg_problem(log) or f"ffmpeg exit status {status}"
        elif self.path.is_file() and self.path.stat().st_size == 0:
            problem = "ffmpeg wrote an empty file"
        if problem is not None:
            _remove_file(self.path)
            raise TisegError(f"cannot write the movie {str(self.path)!r}: {problem}")

    def close(self) -> None:
        """Finish the file; a TisegError (and no file left) when it could not be written."""
        if self.gif:
            frames, self._frames = self._frames, []
            if frames:
                import imageio.v3 as iio

                data = iio.imwrite(
                    "<bytes>",
                    np.stack(frames),
                    extension=".gif",
                    duration=1000.0 / self.fps,
                    loop=0,
                )
                _write_file(self.path, data, "GIF")
        elif self._proc is not None:
            self._finish()

    def __enter__(self) -> "MovieWriter":
        return self

    def __exit__(self, *exc) -> None:
        if exc[0] is not None:
            _close_quietly(self)
        else:
            self.close()


def _ffmpeg_problem(log: str) -> str:
    """The cause in ffmpeg's error messages: the first system error named (such as "No space
    left on device"), else its first line without the "[out#0/mp4 @ 0x...] " source tag."""
    found = [(log.find(m), m) for m in map(os.strerror, errno.errorcode) if m in log]
    if found:
        return min(found)[1]
    lines = log.strip().splitlines()
    return re.sub(r"^\[[^\]]*\]\s*", "", lines[0]).strip() if lines else ""


def refuse_link(path: Path) -> None:
    """Refuse to write at a symbolic link: what would be written is its target, which may be
    any file outside the run folder. (A link is not replaced either: the user put it there.)"""
    if path.is_symlink():
        raise InputError(
            f"{str(path)!r} is a symbolic link (to {os.readlink(path)!r}); tiseg does not "
            "write through links: remove it or choose another name"
        )


def _remove_file(path: Path) -> None:
    """Remove a broken output, if it is a plain file (never a device such as /dev/full)."""
    if path.is_file() and not path.is_symlink():
        with contextlib.suppress(OSError):
            path.unlink()


def save_figure(fig, path, dpi: float) -> None:
    """Save a Matplotlib figure at ``path`` (its folder made): never through a link; where the
    write fails (a full disk, ...) the part written is removed and a one-line TisegError
    says why."""
    path = Path(path)
    refuse_link(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(path, dpi=dpi)
    except OSError as exc:
        _remove_file(path)
        raise TisegError(f"cannot write the figure {str(path)!r}: {exc.strerror or exc}") from None


def _write_file(path: Path, data: bytes, what: str) -> None:
    """Write an encoded picture; when that fails (a full disk, ...), remove the part written
    and raise one line. (Encoded in memory first: imageio, when its own file write fails,
    raises again later from a destructor, as a traceback at exit.)"""
    refuse_link(path)
    try:
        with open(path, "wb") as f:
            f.write(data)
    except OSError as exc:
        _remove_file(path)
        raise TisegError(f"cannot write the {what} {str(path)!r}: {exc.strerror or exc}") from None


def _close_quietly(writer) -> None:
    """Close a writer while another exception is on its way: its error must not hide that one."""
    with contextlib.suppress(TisegError):
        writer.close()


class FrameFolderWriter:
    """Write frames as ``<folder>/frame_00000.png``, ``frame_00001.png``, ..."""

    def __init__(self, folder, prefix: str = "frame_"):
        self.folder = Path(folder)
        self.prefix = prefix
        self.count = 0
        self.paths: list[Path] = []
        refuse_link(self.folder)
        try:
            self.folder.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise InputError(
                f"cannot create frame folder {str(self.folder)!r}: {exc.strerror}"
            ) from None

    def append(self, frame: np.ndarray) -> None:
        import imageio.v3 as iio

        path = self.folder / f"{self.prefix}{self.count:05d}.png"
        _write_file(
            path,
            iio.imwrite("<bytes>", np.asarray(frame, dtype=np.uint8), extension=".png"),
            "frame",
        )
        self.paths.append(path)
        self.count += 1

    def close(self) -> None:
        pass

    def __enter__(self) -> "FrameFolderWriter":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


class MovieRecorder:
    """The one movie path from a running simulation (``tiseg run --movie``, ``tiseg demo``, the
    viewer's recording): a `tiseg.post.render.FrameRenderer` and a `MovieWriter`.

    Call it with a `tiseg.run.callbacks.Snapshot` (as a snapshot callback at output times)
    or with the simulation itself (as a plain callback, e.g. every n steps): each call appends
    one frame with time stamp, scale bar and colour bar (φ's coarse-to-fines ramp too: the
    experiment's colours need a key as much as a map does). `callback` wraps it for
    `tiseg.run.simulation.Simulation.add_callback`."""

    def __init__(self, renderer, path, fps: float = DEFAULT_FPS, colourbar: bool = True):
        self.renderer = renderer
        self.path = Path(path)
        self.colourbar = colourbar
        self.writer = MovieWriter(self.path, fps)

    @classmethod
    def for_simulation(
        cls, sim, path, field: str = "phi", fps: float = DEFAULT_FPS, **renderer_kw
    ) -> "MovieRecorder":
        """A recorder with its own renderer of ``field`` (phi falls back to h without phi),
        ``auto_scale`` pixels per cell unless ``scale`` is given: a 300-cell grid drawn one
        pixel per cell is a stamp on a screen, and its captions do not fit."""
        from .frame import FrameRenderer

        field = C.canonical_field(field)
        if field == "phi" and not sim.layout.segregation:
            field = "h"  # no concentration without segregation
        renderer_kw.setdefault("scale", auto_scale(sim.scene.domain.nx))
        return cls(FrameRenderer(sim, field=field, **renderer_kw), path, fps)

    @property
    def count(self) -> int:
        return self.writer.count

    def __call__(self, state) -> None:
        snap = None if state is self.renderer.sim else state
        frame = self.renderer.to_numpy(annotate_frame=True, colourbar=self.colourbar, state=snap)
        self.writer.append(frame)

    def callback(self, schedule, snapshot: bool | None = None, name: str = "movie"):
        """This recorder as a `tiseg.run.callbacks.Callback` (a snapshot callback on a
        time schedule unless ``snapshot=False``)."""

        return Callback(
            self, schedule, name=name, snapshot=schedule.timed if snapshot is None else snapshot
        )

    def close(self) -> None:
        self.writer.close()

    def __enter__(self) -> "MovieRecorder":
        return self

    def __exit__(self, *exc) -> None:
        self.writer.__exit__(*exc)


def open_writer(path, fps: float = DEFAULT_FPS):
    """A `MovieWriter` for a file path with a suffix, else a `FrameFolderWriter`."""
    path = Path(path)
    return MovieWriter(path, fps) if path.suffix else FrameFolderWriter(path)


def _fields_path(run) -> Path:
    p = Path(run)
    if p.is_dir():
        p = p / FIELDS_FILE
    if not p.is_file():
        raise InputError(
            f"no fields file at {str(p)!r}: give a run folder (with fields.nc, as "
            "written by `tiseg run`) or the .nc file itself"
        )
    return p


def run_h_min(ds, run_dir: Path | None = None) -> float:
    """h_min of the run: from scene.toml beside the fields file, else the file's scene
    attribute, else the paper's 1e-4 m."""
    from ...setup.scene import load_scene, scene_from_text

    try:
        if run_dir is not None and (run_dir / SCENE_FILE).is_file():
            return float(load_scene(run_dir / SCENE_FILE).numerics.h_min)
        if "scene" in ds.attrs:
            return float(scene_from_text(str(ds.attrs["scene"])).numerics.h_min)
    except Exception:  # an unreadable scene must not stop a movie: use the default
        pass
    return 1e-4


def auto_scale(nx: int, min_width: int = 600) -> int:
    """Pixels per cell for a movie: 1, or the integer that makes the map at least min_width
    pixels wide (captions and scale bar need room; integer scales keep cells square blocks)."""
    return max(1, math.ceil(min_width / max(nx, 1)))


def _pick_frames(n: int, max_frames: int | None) -> list[int]:
    """Indices of at most max_frames snapshots, evenly spread, first and last included."""
    if max_frames is None or max_frames >= n:
        return list(range(n))
    if max_frames < 1:
        raise InputError(f"max_frames={max_frames!r} must be at least 1")
    if max_frames == 1:
        return [n - 1]
    return sorted({int(round(k * (n - 1) / (max_frames - 1))) for k in range(max_frames)})


def _snapshot(ds, k: int) -> dict:
    out = {name: ds[name].isel(time=k).values for name in ("h", "phi", "u", "v") if name in ds}
    out["x"], out["y"] = ds["x"].values, ds["y"].values
    for name in ("b", "solid"):  # the terrain's static fields, in runs that have one
        if name in ds and ds[name].dims == ("y", "x"):
            out[name] = ds[name].values
    return out


def global_range(ds, field: str, h_min: float, indices) -> tuple[float, float]:
    """One colour range over the chosen snapshots, so colours mean the same in every frame
    (streamed one snapshot at a time: a large run never sits in memory whole)."""
    lo, hi = math.inf, -math.inf
    for k in indices:
        r = C.default_range(field, data=_snapshot(ds, k), h_min=h_min)
        lo, hi = min(lo, r[0]), max(hi, r[1])
    if C.canonical_field(field) == "v":
        m = max(abs(lo), abs(hi))
        lo, hi = -m, m
    return C._nondegenerate(lo, hi, field)


def render_run(
    run_dir,
    field: str = "phi",
    movie=None,
    frames=None,
    gif=None,
    fps: float = DEFAULT_FPS,
    max_frames: int | None = None,
    shade=True,
    scale: float | None = None,
    vrange=None,
    annotate: bool = True,
    progress: bool = False,
) -> dict:
    """Render the snapshots of a run (its folder or fields.nc) to an mp4 (``movie``), a PNG
    folder (``frames``) and/or a GIF (``gif``). One frame per snapshot (at most ``max_frames``,
    evenly spread), each with time stamp and scale bar (``annotate``) and a colour bar (for the
    mapped fields with one range for the whole movie, ``vrange`` or the data's).
    ``scale``: pixels per cell; default `auto_scale` (small grids are enlarged so that
    the captions fit).
    Returns {"frames": count, "size": (H, W), "outputs": [paths]}."""
    from ...output.netcdf import read_fields
    from .frame import annotate as annotate_image
    from .frame import add_colourbar, render_fields

    field = C.canonical_field(field)
    if movie is None and frames is None and gif is None:
        raise InputError("nothing to write: give a movie (.mp4), a GIF and/or a frames folder")
    fps = _check_fps(fps)
    path = _fields_path(run_dir)
    ds = read_fields(path)
    try:
        need = {"phi": "phi", "h": "h", "speed": "u", "u": "u", "v": "v"}[field]
        if need not in ds:
            have = [v for v in ("h", "phi", "u", "v") if v in ds]
            raise InputError(f"field {field!r} is not in {str(path)!r} (it has {', '.join(have)})")
        n = ds.sizes["time"]
        if n == 0:
            raise InputError(f"{str(path)!r} holds no snapshot")
        indices = _pick_frames(n, max_frames)
        h_min = run_h_min(ds, path.parent)
        if field != "phi" and vrange is None:
            vrange = global_range(ds, field, h_min, indices)
        times = ds["time"].values
        x, y = ds["x"].values, ds["y"].values
        dx = float(abs(x[1] - x[0])) if x.size > 1 else 1.0
        dy = float(abs(y[1] - y[0])) if y.size > 1 else dx
        aspect = dy / dx if y.size > 1 else 1.0  # a 1D run is drawn as one row of cells
        if scale is None:
            scale = auto_scale(x.size)
        writers = []
        outputs = []
        for target, kind in ((movie, "movie"), (gif, "gif"), (frames, "frames")):
            if target is None:
                continue
            w = FrameFolderWriter(target) if kind == "frames" else MovieWriter(target, fps)
            writers.append(w)
            outputs.append(str(target))
        bar = None
        if progress:
            from tqdm import tqdm

            bar = tqdm(
                total=len(indices), unit="frame", desc=f"render {field}", disable=bar_disable()
            )
        size = None
        try:
            for k in indices:
                img = render_fields(
                    _snapshot(ds, k),
                    h_min,
                    field=field,
                    shade=shade,
                    scale=scale,
                    vrange=vrange,
                    colourbar=False,
                    aspect=aspect,
                )
                map_width = img.shape[1]
                img = add_colourbar(img, field, *(vrange if field != "phi" else (0.0, 1.0)))
                if annotate:
                    img = annotate_image(
                        img, float(times[k]), dx / (map_width / ds.sizes["x"]), map_width=map_width
                    )
                size = img.shape[:2]
                for w in writers:
                    w.append(img)
                if bar is not None:
                    bar.update(1)
        except BaseException:
            for w in writers:  # what was written so far stays a valid movie, if it can be
                _close_quietly(w)
            raise
        finally:
            if bar is not None:
                bar.close()
        problems = []
        for w in writers:  # every writer closed, even after another one failed
            try:
                w.close()
            except TisegError as exc:
                problems.append(exc)
        if problems:
            raise problems[0]
    finally:
        ds.close()
    return {
        "frames": len(indices),
        "size": size,
        "outputs": outputs,
        "field": field,
        "vrange": None if field == "phi" else tuple(vrange),
    }

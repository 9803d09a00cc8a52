"""What a sweep is: the sweep file (TOML) read into a `Sweep` of named runs."""

from __future__ import annotations

from ...output.names import DONE_FILE, FINGERS_FILE  # noqa: F401  (FINGERS_FILE: read from here)

import difflib
import hashlib
import itertools
import json
import logging
import math
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping


from ...errors import InputError
from ...output.paths import UNSAFE_CHARS, check_name, safe_name
from ...setup.scene import Scene, list_builtin_scenes, load_scene
from ...data import SWEEP_DIR, builtin_names
from ...data import builtin_file
from .design import Sample, member_names, parse_sample
from .probability import Probability, check_probability, parse_probability

SWEEP_KEYS = (
    "name",
    "description",
    "scene",
    "times",
    "set",
    "grid",
    "sample",
    "probability",
)
DONE_MARKER = DONE_FILE
PROGRESS_TOPIC = "tiseg-sweep-progress"
MAX_RUNS = 10_000  # a guard against a grid that multiplies out by mistake
MAX_NAME = 120  # longest run-folder name before it is shortened with a hash
MARKER_VERSION = 1

# Metrics tabulated at the final time and at each extra time (a subset of analyse_run's keys).
FINAL_METRICS = (
    "finger_count",
    "wavelength",
    "wavelength_spectral",
    "elongation",
    "x_front_max",
    "x_front_min",
    "front_speed",
    "max_channel_speed_over_u0",
    "channel_speed_over_u0",
    "channel_phi",
    "levee_speed_over_u0",
)
TIME_METRICS = (
    "finger_count",
    "wavelength",
    "wavelength_spectral",
    "elongation",
    "x_front_max",
    "x_front_min",
    "channel_speed_over_u0",
)
# The deposit's numbers (at the time the flow came to rest or settled; None where it did not),
# tabulated as deposit_<key> (tiseg.post.analysis.deposit.DEPOSIT_KEYS).
DEPOSIT_METRICS = ("run_out", "thickness_mean", "thickness_max", "stop_time")
# The numbers of a member that sweep.nc stores and whose sensitivity a Sobol' sample reports:
# name -> (long name, units). Final-time metrics of FINAL_METRICS, then the deposit's.
OUTPUTS = {
    "finger_count": ("number of fingers at the final time", "1"),
    "wavelength": ("mean finger wavelength Lambda at the final time", "m"),
    "wavelength_spectral": ("dominant cross-slope wavelength of phi at the final time", "m"),
    "elongation": ("finger elongation x_l = x_f+ - x_f- (6.12) at the final time", "m"),
    "x_front_max": ("front position x_f+ (6.10) at the final time", "m"),
    "x_front_min": ("coarse-front position x_f- (6.11) at the final time", "m"),
    "front_speed": ("speed of the front x_f+ at the final time", "m s-1"),
    "max_channel_speed_over_u0": ("largest channel speed over u0 at the final time", "1"),
    "channel_speed_over_u0": ("median channel speed over u0 at the final time", "1"),
    "channel_phi": ("mean small-particle concentration in the channels", "1"),
    "levee_speed_over_u0": ("median levee speed over u0 at the final time", "1"),
    "deposit_run_out": ("run-out: x_f+ when the flow came to rest or settled", "m"),
    "deposit_thickness_mean": ("mean deposit thickness", "m"),
    "deposit_thickness_max": ("largest deposit thickness", "m"),
    "deposit_stop_time": ("time the flow came to rest", "s"),
}
COST_COLUMNS = ("wall_s", "task_s", "steps", "rhs_evaluations", "cell_updates_per_s")
# Ensemble statistics (summary.csv): over the runs that differ only in these grid keys.
ENSEMBLE_KEYS = ("inflow.seed",)
SUMMARY_METRICS = (
    "finger_count",
    "wavelength",
    "wavelength_spectral",
    "elongation",
    "channel_speed_over_u0",
    "channel_phi",
    "levee_speed_over_u0",
)

log = logging.getLogger(__name__)


# =================================================================================================
# The sweep definition
# =================================================================================================
@dataclass(frozen=True)
class SweepRun:
    """One member of a sweep: its folder name, its grid (and sample) values and its validated
    scene."""

    name: str
    values: dict  # grid key -> value for this run (grid order), then the sample keys
    overrides: dict  # fixed overrides and grid values, as applied to the base scene
    scene: Scene
    member: int | None = None  # index in the sample design (None: a grid sweep)

    @property
    def cells(self) -> int:
        return self.scene.domain.nx * self.scene.domain.ny

    @property
    def cost(self) -> float:
        """Rough relative cost (cells x steps ~ cells x nx x t_end): longest runs start first."""
        return float(self.cells) * self.scene.domain.nx * self.scene.t_end


@dataclass(frozen=True)
class Sweep:
    """A validated sweep file (see the module docstring)."""

    name: str
    description: str
    source: str | None  # the sweep file
    scene: str  # base scene as resolved (built-in name or absolute path)
    fixed: dict  # dotted key -> value
    grid: dict  # dotted key -> list of values
    times: tuple[float, ...]
    runs: tuple[SweepRun, ...]
    sample: Sample | None = None  # the [sample] design (None: a grid only)
    probability: Probability | None = None  # the [probability] maps asked for (None: none)

    @property
    def axes(self) -> list[str]:
        """The keys that vary between runs: the grid's, then the sample's."""
        return [*self.grid, *(self.sample.keys if self.sample else [])]

    def to_dict(self) -> dict:
        """The definition as plain data (for sweep.json)."""
        return {
            "name": self.name,
            "description": self.description,
            "source": self.source,
            "scene": self.scene,
            "set": self.fixed,
            "grid": self.grid,
            "sample": None if self.sample is None else self.sample.to_dict(),
            "probability": None if self.probability is None else self.probability.to_dict(),
            "times": list(self.times),
            "runs": [r.name for r in self.runs],
        }


def list_builtin_sweeps() -> list[str]:
    """Names of the sweeps shipped in the package (``tiseg/data/sweeps``)."""

    return builtin_names(SWEEP_DIR)


def resolve_sweep_path(path) -> Path:
    """A sweep file's path: ``path`` itself, or the built-in sweep of that name (no '/' and no
    '.toml'), or the built-in an old ``assets/sweeps/<name>.toml`` path meant."""

    return builtin_file(path, SWEEP_DIR, "sweep") or Path(str(path)).expanduser()


def load_sweep(
    path, extra_overrides: Mapping | None = None, grid_overrides: Mapping | None = None
) -> Sweep:
    """Read and strictly validate a sweep file, building the scene of every combination.

    ``extra_overrides`` (``{"section.key": value}``) are added to the file's ``[set]`` table
    (a key of the grid may not be given again); ``grid_overrides`` (``{"section.key": [values]}``)
    replace a grid axis of the file or add one (e.g. fewer resolutions for a quick look).
    Raises `InputError` with one line naming the file, the key and what is allowed.
    """
    p = resolve_sweep_path(path)
    where = f"sweep file {str(p)!r}"
    try:
        data = tomllib.loads(p.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise InputError(f"{where} not found") from None
    except UnicodeDecodeError as exc:
        raise InputError(f"{where} is not UTF-8 text: {exc}") from None
    except OSError as exc:
        raise InputError(f"cannot read {where}: {exc.strerror or exc}") from None
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{where} is not valid TOML: {exc}") from None
    except RecursionError:
        raise InputError(f"{where} nests arrays or tables too deeply") from None
    return sweep_from_dict(
        data,
        default_name=p.stem,
        source=str(p),
        base_dir=p.parent,
        extra_overrides=extra_overrides,
        grid_overrides=grid_overrides,
    )


def sweep_from_dict(
    data: Mapping,
    default_name: str = "sweep",
    source: str | None = None,
    base_dir=None,
    extra_overrides: Mapping | None = None,
    grid_overrides: Mapping | None = None,
) -> Sweep:
    """Validate a sweep given as the dict a sweep file parses to (see `load_sweep`)."""
    where = f"sweep file {source!r}" if source else "sweep"

    def fail(msg: str):
        raise InputError(f"{where}: {msg}")

    if not isinstance(data, Mapping):
        fail(f"expected a table of keys, got {type(data).__name__}")
    for key in data:
        if key not in SWEEP_KEYS:
            close = difflib.get_close_matches(str(key), SWEEP_KEYS, n=1)
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            fail(f"unknown key {key!r}{hint}; allowed keys: {', '.join(SWEEP_KEYS)}")

    if "name" in data:
        try:
            name = check_name(data["name"])
        except InputError as exc:
            fail(str(exc))
    else:
        name = safe_name(default_name, "sweep")
    description = data.get("description", "")
    if not isinstance(description, str):
        fail(f"description={description!r} must be a string")

    if "scene" not in data:
        fail(
            "the key 'scene' is required: a built-in scene name "
            f"({', '.join(list_builtin_scenes())}) or a path to a scene .toml file"
        )
    scene_ref = data["scene"]
    if not isinstance(scene_ref, str) or not scene_ref.strip():
        fail(f"scene={scene_ref!r} must be a built-in scene name or a path")
    scene_ref = _resolve_scene_ref(scene_ref, base_dir)

    fixed = _flatten(data.get("set", {}), "set", fail)
    grid = _flatten(data.get("grid", {}), "grid", fail)
    for key, values in (grid_overrides or {}).items():
        grid[key] = values  # replaces the file's axis, or makes a fixed value an axis
        fixed.pop(key, None)
    for key, value in (extra_overrides or {}).items():
        fixed[key] = value
    for key, values in grid.items():
        if not isinstance(values, list) or not values:
            fail(
                f"grid key {key!r} = {_show(values)}: give a non-empty list of values, "
                f"e.g. {key} = [a, b, c]"
            )
        canon = [_canonical(v) for v in values]
        dup = next((v for v, c in zip(values, canon) if canon.count(c) > 1), None)
        if dup is not None:
            fail(f"grid key {key!r} lists the value {_show(dup)} more than once")
        if key in fixed:
            fail(f"{key!r} is both in [set] and in [grid]; give it in one of them")
    sample = None
    if "sample" in data:
        sample = parse_sample(data["sample"], fail)
        for key in sample.keys:
            if key in grid:
                fail(f"{key!r} is both in [grid] and in [sample]; give it in one of them")
            if key in fixed:
                fail(f"{key!r} is both in [set] and in [sample]; give it in one of them")
        _check_sample_keys(scene_ref, fixed, sample, fail)
    probability = None
    if "probability" in data:
        probability = parse_probability(data["probability"], fail)
    n_runs = math.prod(len(v) for v in grid.values()) * (sample.size if sample else 1)
    if n_runs > MAX_RUNS:
        fail(f"the grid multiplies out to {n_runs} runs; at most {MAX_RUNS} are allowed")

    times = data.get("times", [])
    if not isinstance(times, list) or not all(
        isinstance(t, (int, float)) and not isinstance(t, bool) and math.isfinite(t) and t >= 0
        for t in times
    ):
        fail(f"times={_show(times)} must be a list of times >= 0 [s], e.g. times = [2.5, 5.0]")
    times = tuple(sorted({float(t) for t in times}))

    # Build and validate every combination before anything runs (see the module docstring).
    keys = list(grid)
    combos = [dict(zip(keys, vals)) for vals in itertools.product(*(grid[k] for k in keys))]
    names = _run_names(combos)
    members: list[tuple[str, dict, int | None]] = [(n, c, None) for n, c in zip(names, combos)]
    if sample is not None:
        points = sample.points()
        members = [
            (m, {**c, **p}, i)
            for n, c in zip(names, combos)
            for i, (m, p) in enumerate(zip(member_names(n, len(points)), points))
        ]
    runs = []
    for run_name, values, member in members:
        overrides = {**fixed, **values}
        label = f"run {run_name!r}" if values else "the base run"
        try:
            scene = load_scene(scene_ref, overrides)
        except InputError as exc:
            problem = str(exc)
        else:
            problem = None
        if problem is not None:  # raised here, not inside except: one clean error
            fail(f"{label}: {problem}")
        for t in times:
            if t > scene.t_end * (1 + 1e-12):
                fail(f"{label}: times lists {t:g} s, after time.t_end = {scene.t_end:g} s")
            if time_index(scene.output_times, t) is None:
                fail(
                    f"{label}: times lists {t:g} s, which is not an output time of the scene; "
                    f"add it to output.times in [set]"
                )
        runs.append(SweepRun(run_name, values, overrides, scene, member))
    if probability is not None:
        check_probability(runs, fail)
    return Sweep(
        name=name,
        description=description,
        source=source,
        scene=scene_ref,
        fixed=fixed,
        grid=grid,
        times=times,
        runs=tuple(runs),
        sample=sample,
        probability=probability,
    )


def _check_sample_keys(scene_ref: str, fixed: dict, sample: Sample, fail) -> None:
    """Each sampled key must be a scene key that takes any number in its range: a float
    (not a whole-number, true/false, text or list key). One line naming the key otherwise."""
    # the base scene, else (a key the scene needs, such as flow.u0 for some friction laws)
    # the scene at the ranges' lower ends
    problem = None
    for extra in ({}, {r.key: r.lo for r in sample.ranges}):
        try:
            base = load_scene(scene_ref, {**fixed, **extra})
        except InputError as exc:
            problem = problem or str(exc)
        else:
            break
    else:
        fail(f"the base run: {problem}")
    flat: dict[str, Any] = {}

    def walk(node, prefix):
        for k, v in node.items():
            key = f"{prefix}.{k}" if prefix else k
            if isinstance(v, Mapping):
                walk(v, key)
            else:
                flat[key] = v

    walk(base.to_dict(), "")
    for r in sample.ranges:
        if r.key in flat:
            v = flat[r.key]
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                kind = "true/false" if isinstance(v, bool) else type(v).__name__
                fail(
                    f"[sample] {r.key!r} is a {kind} scene key (now {_show(v)}); only numeric "
                    f"keys can be sampled: list its values in [grid]"
                )
            if isinstance(v, int):
                fail(
                    f"[sample] {r.key!r} takes whole numbers (now {v}); a sample draws any "
                    f"number in its range: list its values in [grid]"
                )
            continue
        # a key without a value in the base scene (an optional one): try both ends
        for end in (r.lo, r.hi):
            try:
                load_scene(scene_ref, {**fixed, r.key: end})
            except InputError as exc:
                problem = str(exc)
            else:
                problem = None
            if problem is not None:
                fail(f"[sample] {r.key!r} = {end:g}: {problem}")


def _resolve_scene_ref(ref: str, base_dir) -> str:
    """A built-in name stays a name; a path is taken relative to the sweep file's folder."""
    is_name = "/" not in ref and "\\" not in ref and not ref.endswith(".toml")
    if is_name or base_dir is None:
        return ref
    p = Path(ref).expanduser()
    if not p.is_absolute():
        p = Path(base_dir) / p
    return str(p.resolve())


def _flatten(table, section: str, fail) -> dict:
    """``{"domain": {"resolution": [..]}}`` -> ``{"domain.resolution": [..]}`` (leaf values)."""
    if not isinstance(table, Mapping):
        fail(f"[{section}] must be a table of 'section.key = value' entries, got {_show(table)}")
    out: dict[str, Any] = {}

    def walk(node, prefix):
        for k, v in node.items():
            key = f"{prefix}.{k}" if prefix else str(k)
            if isinstance(v, Mapping):
                if not v:
                    fail(f"[{section}] {key!r} is an empty table")
                walk(v, key)
            else:
                if "." not in key:
                    fail(
                        f"[{section}] key {key!r} must be a dotted scene key such as "
                        f"'domain.resolution' or 'flow.nu'"
                    )
                out[key] = v

    walk(table, "")
    return out


def _canonical(v) -> str:
    return json.dumps(v, sort_keys=True, default=str)


def _show(v) -> str:
    text = _canonical(v) if not isinstance(v, str) else repr(v)
    return text if len(text) <= 60 else text[:57] + "..."


def _format_value(v) -> str:
    """A grid value as part of a folder name: short, stable, file-system safe."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return format(v, ".12g")
    if isinstance(v, str):
        return UNSAFE_CHARS.sub("_", v).strip("_") or "_"
    if isinstance(v, list):
        return "+".join(_format_value(x) for x in v) or "empty"
    return hashlib.sha256(_canonical(v).encode()).hexdigest()[:8]


def _run_names(combos: list[dict]) -> list[str]:
    """Folder names from the grid values: ``resolution-250_nu-0.01``.

    A key is shown by its last part (``flow.nu`` -> ``nu``) unless two grid keys share it, then
    in full. Names that still collide (values equal after formatting) or are too long get a
    hash of the exact values appended, so every combination has its own stable folder.
    """
    if not combos or not combos[0]:
        return ["base"] * len(combos)
    keys = list(combos[0])
    last = [k.rsplit(".", 1)[-1] for k in keys]
    labels = {k: (s if last.count(s) == 1 else k) for k, s in zip(keys, last)}
    names = [
        "_".join(f"{UNSAFE_CHARS.sub('_', labels[k])}-{_format_value(v)}" for k, v in c.items())
        for c in combos
    ]
    out = []
    for name, c in zip(names, combos):
        if names.count(name) > 1 or len(name) > MAX_NAME:
            digest = hashlib.sha256(_canonical(c).encode()).hexdigest()[:8]
            name = f"{name[: MAX_NAME - 9]}-{digest}"
        out.append(name)
    return out


def time_index(times, t) -> int | None:
    """Index of the output time equal to t (to 1e-9 relative), or None."""
    for i, s in enumerate(times):
        if abs(s - t) <= 1e-9 * max(1.0, t):
            return i
    return None

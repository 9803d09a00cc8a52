"""Problem files: read, validate, and the `Problem` they describe.

A problem file (``tiseg/data/problems/<name>.toml``; the name is the file's stem) holds::

    title = "..."                  # the study's plot title
    error_label = "..."            # what the error is
    resolution_label = "..."       # what a resolution counts
    order = 2                      # position in the study's tables

    [resolutions]
    full = [100, 200, 400]         # the study's resolutions
    quick = [100, 200]             # those of --quick

    [scene]
    builtin = "dam-break"          # a built-in scene, or an [scene.inline] table (a whole scene)
    resolution = "domain.nx"       # the key a resolution sets
    end = 0.1                      # time.t_end (or {full = .., quick = ..}; none: the scene's)
    snapshot_at_end = true         # output.interval = the end time (optional)
    unset = ["domain.Lx"]          # keys removed from the scene (optional)
    [scene.set]                    # further "section.key" overrides (optional)

    [record]                       # what the timed run keeps: tiseg.problems.scores.RECORDS
    name = "final"
    [exact]                        # the solution: tiseg.problems.solutions.SOLUTIONS
    name = "dam-break"
    [score]                        # how the run is scored: tiseg.problems.scores.SCORES
    name = "relative-l1"

with each table's parameters beside its name. A file that breaks a rule is refused with one
line naming the file, the key and the rule (an unknown name with the closest known one).
"""

from __future__ import annotations

import copy
import difflib
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from ..data import PROBLEM_DIR, SCENE_DIR, builtin_file, builtin_names
from ..errors import InputError
from ..scene import load_scene, scene_from_dict
from .scores import CUTS, RECORDS, SCORES, VALUES
from .solutions import FINER_RUN, SOLUTIONS

TOP_KEYS = ("title", "error_label", "resolution_label", "order")
SCENE_KEYS = ("builtin", "inline", "resolution", "end", "snapshot_at_end", "unset", "set")
MODES = ("full", "quick")


@dataclass(frozen=True)
class Problem:
    """A verification problem: how to build its scene at a resolution, run it (the timed
    part), and score the result against its exact or reference solution.

    ``build(res, numerics, quick)`` -> Scene; ``run(sim, on_step)`` -> raw data;
    ``score(raw, scene)`` -> (value, error). ``resolution`` means what ``resolution_label``
    says (cells per period, cells on the domain, cells per metre)."""

    name: str
    title: str
    error_label: str
    resolution_label: str
    resolutions: tuple[int, ...]
    quick_resolutions: tuple[int, ...]
    scene: dict  # the [scene] table
    record: dict  # the [record] table ("name" and its parameters)
    exact: dict  # the [exact] table
    score_by: dict  # the [score] table
    order: int = 0
    source: str | None = field(default=None, compare=False)

    @property
    def reference_resolution(self) -> dict | None:
        """{"full": r, "quick": r} of the finer run a relative problem is scored against."""
        if SOLUTIONS[self.exact["name"]].gives != FINER_RUN:
            return None
        return dict(self.exact["resolution"])

    def end(self, quick: bool) -> float | None:
        """The end time the scene is given (None: the scene's own)."""
        end = self.scene.get("end")
        return end["quick" if quick else "full"] if isinstance(end, dict) else end

    def overrides(self, res, quick: bool) -> dict:
        """The ``section.key`` overrides of the scene at resolution ``res`` (numerics aside)."""
        sc = self.scene
        over = {sc["resolution"]: res}
        end = self.end(quick)
        if end is not None:
            over["time.t_end"] = end
        over.update(sc.get("set", {}))
        if sc.get("snapshot_at_end"):
            over["output.interval"] = end
        over.update({k: None for k in sc.get("unset", ())})
        return over

    def build(self, res, numerics: dict | None = None, quick: bool = False):
        """The scene at resolution ``res`` with the numerics section's keys ``numerics``."""
        over = self.overrides(res, quick)
        over.update({f"numerics.{k}": v for k, v in (numerics or {}).items()})
        if "builtin" in self.scene:
            return load_scene(self.scene["builtin"], over)
        data = copy.deepcopy(self.scene["inline"])
        for key, value in over.items():
            section, name = key.split(".", 1)
            if value is None:
                data.get(section, {}).pop(name, None)
            else:
                data.setdefault(section, {})[name] = value
        return scene_from_dict(data, name=f"problem-{self.name}")

    def run(self, sim, on_step=None):
        """Advance ``sim`` as the record says (the timed part); the raw data."""
        params = {k: v for k, v in self.record.items() if k != "name"}
        return RECORDS[self.record["name"]].run(sim, on_step, **params)

    def solution(self, scene):
        """The exact solution on ``scene`` (None for a problem scored against a finer run)."""
        sol = SOLUTIONS[self.exact["name"]]
        if sol.compute is None:
            return None
        return sol.compute(scene, **{k: v for k, v in self.exact.items() if k != "name"})

    def score(self, raw, scene) -> tuple[float, float]:
        """(value, error) of a run's raw data on ``scene``."""
        params = {k: v for k, v in self.score_by.items() if k != "name"}
        return SCORES[self.score_by["name"]].score(raw, self.solution(scene), scene, **params)


# ---------------------------------------------------------------------------------- reading
def list_builtin_problems() -> list[str]:
    """Names of the problem files shipped in tiseg/data/problems."""
    return builtin_names(PROBLEM_DIR)


def load_problem(name_or_path) -> Problem:
    """A built-in problem by name (see `list_builtin_problems`) or a problem file."""
    builtin = builtin_file(name_or_path, PROBLEM_DIR, "problem")
    path = builtin or Path(name_or_path)
    where = str(path)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"cannot read problem file {where!r}: {exc}") from None
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"problem file {where!r} is not valid TOML: {exc}") from None
    # errors name a built-in problem by its name, any other file by its path
    label = repr(path.stem) if builtin else None
    return problem_from_dict(data, path.stem, source=where, label=label)


def builtin_problems() -> dict[str, Problem]:
    """Every shipped problem by name, in the study's order."""
    probs = [load_problem(n) for n in list_builtin_problems()]
    return {p.name: p for p in sorted(probs, key=lambda p: (p.order, p.name))}


def problem_from_dict(
    data: dict, name: str, source: str | None = None, label: str | None = None
) -> Problem:
    """Validate the table a problem file parses to; InputError with one line otherwise (naming
    the file as ``label``, else its path ``source``, else ``name``)."""
    where = f"problem file {label or repr(source or name)}"

    def fail(msg: str):
        raise InputError(f"{where}: {msg}")

    def table(d, key, known, required=()):
        t = d.get(key) if key else d
        if not isinstance(t, dict):
            fail(f"[{key}] must be a table")
        prefix = f"{key}." if key else ""
        for k in t:
            if k not in known:
                fail(f"unknown key {prefix + k!r}{_hint(k, known)}; known: {', '.join(known)}")
        for k in required:
            if k not in t:
                fail(f"missing key {prefix + k!r}")
        return t

    sections = ("resolutions", "scene", "record", "exact", "score")
    table(data, None, TOP_KEYS + sections, ("title", "error_label", "resolution_label"))
    for k in ("title", "error_label", "resolution_label"):
        if not isinstance(data[k], str) or not data[k]:
            fail(f"{k} must be a non-empty string")
    for k in sections:
        if k not in data:
            fail(f"missing table [{k}]")
    order = data.get("order", 0)
    if not isinstance(order, int) or isinstance(order, bool):
        fail(f"order must be an integer, got {order!r}")

    res = table(data, "resolutions", MODES, MODES)
    for mode in MODES:
        r = res[mode]
        if not (isinstance(r, list) and r and all(_count(v) for v in r)):
            fail(f"resolutions.{mode} must be a non-empty list of positive integers, got {r!r}")

    scene = table(data, "scene", SCENE_KEYS, ("resolution",))
    _check_scene(scene, fail)
    record = _named(data, "record", RECORDS, table, fail)
    exact = _named(data, "exact", SOLUTIONS, table, fail)
    score = _named(data, "score", SCORES, table, fail)
    _check_parts(record, exact, score, scene, fail)
    problem = Problem(
        name=name,
        title=data["title"],
        error_label=data["error_label"],
        resolution_label=data["resolution_label"],
        resolutions=tuple(res["full"]),
        quick_resolutions=tuple(res["quick"]),
        scene=scene,
        record=record,
        exact=exact,
        score_by=score,
        order=order,
        source=source,
    )
    # the scene must load as the study builds it (its own one-line error, named as this file's)
    for quick in (False, True):
        try:
            problem.build(
                (problem.quick_resolutions if quick else problem.resolutions)[0], {}, quick
            )
        except InputError as exc:
            fail(f"its scene: {exc}")
    return problem


def _hint(name, known) -> str:
    close = difflib.get_close_matches(str(name), list(known), n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""


def _count(v) -> bool:
    return isinstance(v, int) and not isinstance(v, bool) and v > 0


def _number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and v > 0


def _named(data, key, registry, table, fail) -> dict:
    """A [record] / [exact] / [score] table: a registered name and that entry's parameters."""
    kind = {"record": "record", "exact": "exact solution", "score": "score"}[key]
    t = data[key]
    if not isinstance(t, dict):
        fail(f"[{key}] must be a table")
    name = t.get("name")
    if name is None:
        fail(f"missing key '{key}.name'")
    if name not in registry:
        fail(f"unknown {kind} {name!r}{_hint(name, registry)}; known: {', '.join(registry)}")
    entry = registry[name]
    optional = getattr(entry, "optional", {})
    table(data, key, ("name", *entry.params, *optional), ("name", *entry.params))
    return {**optional, **t}


def _check_scene(scene, fail) -> None:
    if ("builtin" in scene) == ("inline" in scene):
        fail("[scene] needs one of 'builtin' (a built-in scene's name) or 'inline' (a table)")
    if "builtin" in scene:
        names = builtin_names(SCENE_DIR)
        if scene["builtin"] not in names:
            b = scene["builtin"]
            fail(
                f"unknown built-in scene {b!r}{_hint(b, names)}; built-in scenes: {', '.join(names)}"
            )
    elif not isinstance(scene["inline"], dict):
        fail("scene.inline must be a table (a whole scene)")
    if not isinstance(scene.get("set", {}), dict):
        fail("scene.set must be a table of 'section.key' = value")
    for k in (scene["resolution"], *scene.get("set", {})):
        if not isinstance(k, str) or k.count(".") != 1:
            fail(f"scene key {k!r} must read 'section.key'")
    end = scene.get("end")
    if isinstance(end, dict):
        if set(end) != set(MODES) or not all(_number(v) for v in end.values()):
            fail(f"scene.end must be a positive number or {{full = .., quick = ..}}, got {end!r}")
    elif end is not None and not _number(end):
        fail(f"scene.end must be a positive number or {{full = .., quick = ..}}, got {end!r}")
    if scene.get("snapshot_at_end") and end is None:
        fail("scene.snapshot_at_end needs scene.end")
    unset = scene.get("unset", [])
    if not (isinstance(unset, list) and all(isinstance(k, str) and "." in k for k in unset)):
        fail(f"scene.unset must be a list of 'section.key' names, got {unset!r}")


def _check_parts(record, exact, score, scene, fail) -> None:
    """The record, solution and score must fit together (one line naming the mismatch)."""
    sc, sol = SCORES[score["name"]], SOLUTIONS[exact["name"]]
    if sc.takes != sol.gives:
        fail(
            f"score {sc.name!r} compares with a {sc.takes}, but exact solution {sol.name!r} "
            f"gives a {sol.gives}"
        )
    if sc.record != record["name"]:
        fail(f"score {sc.name!r} needs record {sc.record!r}, not {record['name']!r}")
    if record["name"] == "final":
        fields = record["fields"]
        if not (isinstance(fields, list) and fields and all(isinstance(f, str) for f in fields)):
            fail(f"record.fields must be a non-empty list of field names, got {fields!r}")
        if record["cut"] not in CUTS:
            fail(f"record.cut {record['cut']!r}: choose {', '.join(CUTS)}")
        if score["field"] not in fields:
            fail(f"score.field {score['field']!r} is not among record.fields {fields!r}")
    if record["name"] == "mode-amplitude":
        if not _number(record["flow_times"]):
            fail(f"record.flow_times must be a positive number, got {record['flow_times']!r}")
        if not (_count(record["samples"]) and record["samples"] >= 3):
            fail(f"record.samples must be an integer >= 3, got {record['samples']!r}")
        d = score["discard"]
        if not (isinstance(d, int) and 0 <= d <= record["samples"] - 2):
            fail(f"score.discard must be an integer in [0, record.samples - 2], got {d!r}")
    if score.get("value", "none") not in VALUES:
        fail(f"score.value {score['value']!r}: choose {', '.join(VALUES)}")
    if sol.gives == FINER_RUN:
        r = exact["resolution"]
        if not (
            isinstance(r, dict) and set(r) == set(MODES) and all(_count(v) for v in r.values())
        ):
            fail(
                f"exact.resolution must be {{full = .., quick = ..}} of positive integers, got {r!r}"
            )
    if sol.name == "transport-characteristics":
        for k in sol.params:
            if not isinstance(exact[k], (int, float)) or isinstance(exact[k], bool):
                fail(f"exact.{k} must be a number, got {exact[k]!r}")

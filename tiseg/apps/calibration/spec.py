"""What a calibration is: the command line's parameters, targets and scene, validated."""

from __future__ import annotations

import itertools
import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Mapping

from ...errors import InputError
from ...post.analysis.deposit import DEPOSIT_KEYS
from ...post.analysis.fingers import RUN_KEYS
from ...setup.scene import Scene, load_scene
from ...setup.table import check_underflow, toml_float
from ..sweep.design import Range, Sample
from ..sweep.spec import SweepRun, _check_sample_keys, _resolve_scene_ref, _run_names, time_index

# Per-time numbers of `tiseg fingers --json`, read at the calibration's time (--time T).
TIME_TARGETS = tuple(k for k in RUN_KEYS if k != "time")
# Per-time numbers that exist only where the run has phi (segregation).
FINGER_TARGETS = tuple(
    k for k in TIME_TARGETS if k not in ("x_front_max", "front_speed", "front_speed_over_u0")
)
# The numbers of its "deposit" block (not its settings, flags or text), named "deposit.<key>".
DEPOSIT_TARGETS = tuple(
    k
    for k in DEPOSIT_KEYS
    if k
    not in ("rest_speed", "settle_fraction", "stopped", "settled", "basis", "run_out_at_domain_end")
)
# Other spellings accepted for a deposit number: the sweep table's and the bare key.
ALIASES = {
    "runout": "deposit.run_out",
    **{f"deposit_{k}": f"deposit.{k}" for k in DEPOSIT_TARGETS},
    **{k: f"deposit.{k}" for k in DEPOSIT_TARGETS},
}
DIGITS = 10  # significant digits of a parameter value: a point's folder name holds it exactly
DEFAULT_BUDGET_PER_PARAM = 12
SEED_KEYS = ("inflow.seed", "initial.seed")


def target_names() -> list[str]:
    """Every valid target name (canonical spelling)."""
    return [*TIME_TARGETS, *(f"deposit.{k}" for k in DEPOSIT_TARGETS)]


@dataclass(frozen=True)
class Param:
    """One calibrated scene key and its range, searched uniformly (or in its log with ``log``)."""

    key: str
    lo: float
    hi: float
    log: bool = False

    def value(self, u: float) -> float:
        """The value at unit coordinate ``u`` in [0, 1], rounded to `DIGITS` significant
        digits (so that the member folder named after it holds exactly the value run)."""
        u = min(1.0, max(0.0, float(u)))
        if self.log:
            v = math.exp(math.log(self.lo) + u * (math.log(self.hi) - math.log(self.lo)))
        else:
            v = self.lo + u * (self.hi - self.lo)
        return min(self.hi, max(self.lo, float(f"{v:.{DIGITS}g}")))

    def unit(self, v: float) -> float:
        """The unit coordinate of the value ``v``."""
        if self.log:
            return (math.log(v) - math.log(self.lo)) / (math.log(self.hi) - math.log(self.lo))
        return (v - self.lo) / (self.hi - self.lo)

    def to_dict(self) -> dict:
        return {"key": self.key, "lo": self.lo, "hi": self.hi, "log": self.log}


@dataclass(frozen=True)
class Target:
    """One number to reproduce: its canonical name, the value, and an optional tolerance (the
    value's uncertainty, in the target's units)."""

    name: str
    value: float
    tolerance: float | None = None

    @property
    def deposit(self) -> bool:
        return self.name.startswith("deposit.")

    @property
    def scale(self) -> float:
        """What a residual is divided by in the misfit: the tolerance, else |value| (a relative
        residual), else 1."""
        if self.tolerance:
            return self.tolerance
        return abs(self.value) or 1.0

    def to_dict(self) -> dict:
        return {"name": self.name, "value": self.value, "tolerance": self.tolerance}


@dataclass(frozen=True)
class Calibration:
    """A validated calibration: the base scene (a built-in name or an absolute path), the fixed
    overrides, the parameters and targets, the time of the per-time targets, the budget of
    search runs, the number of seeds for the targets' spread and the design's seed."""

    scene: str
    fixed: dict
    params: tuple[Param, ...]
    targets: tuple[Target, ...]
    time: float | None
    budget: int
    seeds: int = 0
    seed_key: str | None = None
    base_seed: int = 0
    design_seed: int = 0

    @property
    def keys(self) -> list[str]:
        return [p.key for p in self.params]

    def run(self, values: Mapping) -> SweepRun:
        """The member that runs the scene at ``values`` (parameter keys, and the seed key for
        a seed member), named after them like a sweep's run folder."""
        name = _run_names([dict(values)])[0]
        overrides = {**self.fixed, **values}
        return SweepRun(name, dict(values), overrides, load_scene(self.scene, overrides))

    def to_dict(self) -> dict:
        return {
            "scene": self.scene,
            "set": self.fixed,
            "params": [p.to_dict() for p in self.params],
            "targets": [t.to_dict() for t in self.targets],
            "time": self.time,
            "budget": self.budget,
            "seeds": self.seeds,
            "seed_key": self.seed_key,
            "design_seed": self.design_seed,
        }


_NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
_PARAM = re.compile(rf"^\s*([^=\s]+)\s*=\s*({_NUMBER})\s*:\s*({_NUMBER})\s*(?::\s*(log))?\s*$")
_TARGET = re.compile(rf"^\s*([^=\s]+)\s*=\s*({_NUMBER})\s*(?:(?:\+-|±)\s*({_NUMBER}))?\s*$")


def _number(what: str, text: str) -> float:
    """The float of ``text``, refused (one line) when a non-zero number underflows: 1e-400
    would be read as 0, a bound or target the user did not write, as in a scene file."""
    v = toml_float(text)
    check_underflow(what, v)
    return float(v)


def parse_param(text: str) -> Param:
    """``KEY=LO:HI`` (or ``KEY=LO:HI:log``) into a `Param`; one-line `InputError` otherwise."""
    m = _PARAM.match(text)
    if not m:
        raise InputError(
            f"--param {text!r}: give SECTION.KEY=LO:HI (optionally :log), "
            "e.g. --param effects.coulomb_mu=0.1:0.3"
        )
    key, log = m.group(1), bool(m.group(4))
    lo, hi = _number(f"--param {key}", m.group(2)), _number(f"--param {key}", m.group(3))
    if "." not in key:
        raise InputError(f"--param {text!r}: {key!r} is not a dotted scene key such as 'flow.nu'")
    if not (math.isfinite(lo) and math.isfinite(hi)) or lo >= hi:
        raise InputError(f"--param {text!r}: the range needs LO < HI (got {lo:g} : {hi:g})")
    if log and lo <= 0:
        raise InputError(f"--param {text!r}: a log range needs LO > 0")
    return Param(key, lo, hi, log)


def parse_target(text: str) -> Target:
    """``NAME=VALUE`` (or ``NAME=VALUE+-TOL``) into a `Target`; one-line `InputError` for a
    malformed one or a name `tiseg fingers --json` does not report."""
    m = _TARGET.match(text)
    if not m:
        raise InputError(
            f"--target {text!r}: give NAME=VALUE or NAME=VALUE+-TOLERANCE, "
            "e.g. --target deposit.run_out=0.22"
        )
    name = m.group(1)
    value = _number(f"--target {name}", m.group(2))
    tol = None if m.group(3) is None else _number(f"--target {name} tolerance", m.group(3))
    name = ALIASES.get(name, name)
    if name not in target_names():
        raise InputError(
            f"--target {text!r}: unknown target {m.group(1)!r}; valid names: "
            f"{', '.join(target_names())}"
        )
    if not math.isfinite(value):
        raise InputError(f"--target {text!r}: the value must be a finite number")
    if tol is not None and not (math.isfinite(tol) and tol > 0):
        raise InputError(f"--target {text!r}: the tolerance must be a number > 0")
    return Target(name, value, tol)


def calibration_from_args(
    scene_ref: str,
    params: list[str],
    targets: list[str],
    *,
    time: float | None = None,
    fixed: Mapping | None = None,
    budget: int | None = None,
    seeds: int = 0,
    design_seed: int = 0,
    base_dir=None,
) -> Calibration:
    """Parse and validate a calibration before anything runs: every range, target, override
    and budget, the scene at the corners of the box of the ranges (at each range's ends when
    there are more than 4 parameters), and the time of the per-time targets. Raises
    `InputError` with one line."""
    if not params:
        raise InputError("give at least one --param SECTION.KEY=LO:HI")
    if not targets:
        raise InputError("give at least one --target NAME=VALUE")
    ps = [parse_param(t) for t in params]
    ts = [parse_target(t) for t in targets]
    for group, what in ((ps, "--param"), (ts, "--target")):
        names = [getattr(x, "key", getattr(x, "name", None)) for x in group]
        dup = next((n for n in names if names.count(n) > 1), None)
        if dup is not None:
            raise InputError(f"{what} {dup!r} is given more than once")
    budget = DEFAULT_BUDGET_PER_PARAM * len(ps) if budget is None else budget
    if budget < 2:
        raise InputError(f"--budget {budget}: give at least 2 runs")
    if seeds < 0 or seeds == 1:
        raise InputError(f"--seeds {seeds}: give 0 (no seed runs) or at least 2 seeds")
    if not 0 <= design_seed < 2**63:  # what numpy's generators take
        raise InputError(f"--design-seed {design_seed}: give a whole number from 0 to 2**63 - 1")
    fixed = dict(fixed or {})
    for p in ps:
        if p.key in fixed:
            raise InputError(f"{p.key!r} is both in --set and in --param; give it in one of them")
    ref = _resolve_scene_ref(scene_ref, Path.cwd() if base_dir is None else base_dir)

    def fail(msg: str):
        # the sweeps' words for a key that cannot be sampled, said of a calibration
        msg = msg.replace("[sample] ", "--param ")
        msg = msg.replace(
            "a sample draws any number in its range: list its values in [grid]",
            "a calibration needs a key that takes any number in its range",
        )
        msg = msg.replace(
            "only numeric keys can be sampled: list its values in [grid]",
            "only numeric keys can be calibrated",
        )
        raise InputError(msg)

    # the sweeps' own check: a numeric key that takes any number in its range
    sample = Sample("lhs", 2, 0, tuple(Range(p.key, p.lo, p.hi, p.log) for p in ps))
    _check_sample_keys(ref, fixed, sample, fail)
    if len(ps) <= 4:
        corners = [
            dict(zip([p.key for p in ps], c))
            for c in itertools.product(*((p.lo, p.hi) for p in ps))
        ]
    else:
        mid = {p.key: p.value(0.5) for p in ps}
        corners = [{**mid, p.key: end} for p in ps for end in (p.lo, p.hi)]
    scenes = []
    for c in corners:
        try:
            scenes.append(load_scene(ref, {**fixed, **c}))
        except InputError as exc:
            problem = str(exc)
        else:
            continue
        at = ", ".join(f"{k} = {v:g}" for k, v in c.items())
        raise InputError(f"the scene at {at}: {problem}")

    base = scenes[0]
    if any(not t.deposit for t in ts):
        if time is None:
            time = base.output_times[-1] if base.output_times else base.t_end
        for s in scenes:
            if time_index(s.output_times, time) is None:
                raise InputError(
                    f"--time {time:g}: not an output time of the scene; add it to "
                    f"output.times (--set 'output.times=[{time:g}]') or give one of "
                    f"{', '.join(f'{t:g}' for t in s.output_times[-5:])}"
                )
    elif time is not None and not (math.isfinite(time) and time >= 0):
        raise InputError(f"--time {time!r}: give a time in seconds >= 0")
    if not _segregation(base):
        need = [t.name for t in ts if t.name in FINGER_TARGETS]
        if need:
            raise InputError(
                f"--target {need[0]}: a finger number needs phi, and this scene has no "
                "segregation (effects.segregation = false); its targets are x_front_max, "
                "front_speed and the deposit.* numbers"
            )
    seed_key, base_seed = None, 0
    if seeds:
        seed_key = _seed_key(base)
        if seed_key is None:
            raise InputError(
                f"--seeds {seeds}: the scene's runs do not depend on a seed (no inflow.noise "
                "and no noisy initial state); leave --seeds out or give a tolerance"
            )
        if seed_key in {p.key for p in ps}:
            raise InputError(f"--seeds: {seed_key!r} cannot also be a --param")
        base_seed = int(_flat(base.to_dict()).get(seed_key) or 0)
    return Calibration(
        scene=ref,
        fixed=fixed,
        params=tuple(ps),
        targets=tuple(ts),
        time=None if time is None else float(time),
        budget=int(budget),
        seeds=int(seeds),
        seed_key=seed_key,
        base_seed=base_seed,
        design_seed=int(design_seed),
    )


def _flat(d: Mapping, prefix: str = "") -> dict:
    out = {}
    for k, v in d.items():
        key = f"{prefix}.{k}" if prefix else k
        if isinstance(v, Mapping):
            out.update(_flat(v, key))
        else:
            out[key] = v
    return out


def _segregation(scene: Scene) -> bool:
    return bool(_flat(scene.to_dict()).get("effects.segregation", True))


def _seed_key(scene: Scene) -> str | None:
    """The key whose value draws the scene's random realisation, if its runs have one."""
    flat = _flat(scene.to_dict())
    if flat.get("inflow.noise"):
        return "inflow.seed"
    if flat.get("initial.mode") in ("noise", "h-noise"):
        return "initial.seed"
    return None

"""Sampling designs of a sweep: the ``[sample]`` table read into a `Sample` and its points.

A sample draws ``n`` points in the box of the given key ranges, each coordinate uniform on its
range or, with ``log = true``, uniform in its logarithm (a range of positive values)::

    [sample]
    method = "sobol"            # "lhs" (Latin hypercube), "sobol" (Saltelli design), "random"
    n = 16                      # points ("sobol": base points, a power of 2; see below)
    seed = 1                    # the same seed draws the same design (default 0)
    "flow.nu" = {range = [0.005, 0.05], log = true}
    "flow.h0" = [0.0015, 0.0025]

The sequences are scipy.stats.qmc's: ``lhs`` its `LatinHypercube`, ``random`` uniform draws of
a NumPy generator, ``sobol`` its scrambled `Sobol` sequence in 2d dimensions read as two
matrices A and B of n rows, followed by the d matrices AB_i (A with column i taken from B):
the design of Saltelli et al. (2010), section 5, from which `tiseg.apps.sweep.sensitivity`
estimates first-order and total Sobol' indices. It has n (d + 2) members, in the order A, B,
AB_1, ..., AB_d.
"""

from __future__ import annotations

import difflib
import math
from dataclasses import dataclass
from typing import Any, Callable, Mapping

import numpy as np

METHODS = ("lhs", "sobol", "random")
SAMPLE_KEYS = ("method", "n", "seed")
RANGE_KEYS = ("range", "log")


@dataclass(frozen=True)
class Range:
    """The range of one sampled key: uniform on [lo, hi], or log-uniform with ``log``."""

    key: str
    lo: float
    hi: float
    log: bool = False

    def scale(self, u: np.ndarray) -> np.ndarray:
        """Map unit-interval coordinates onto the range."""
        if self.log:
            a, b = math.log(self.lo), math.log(self.hi)
            return np.exp(a + np.asarray(u) * (b - a))
        return self.lo + np.asarray(u) * (self.hi - self.lo)

    def to_dict(self) -> dict:
        return {"range": [self.lo, self.hi], "log": self.log}


@dataclass(frozen=True)
class Sample:
    """A validated ``[sample]`` table (see the module docstring)."""

    method: str
    n: int
    seed: int
    ranges: tuple[Range, ...]

    @property
    def keys(self) -> list[str]:
        return [r.key for r in self.ranges]

    @property
    def size(self) -> int:
        """Members of the design: n, or n (d + 2) for "sobol"."""
        d = len(self.ranges)
        return self.n * (d + 2) if self.method == "sobol" else self.n

    def to_dict(self) -> dict:
        return {
            "method": self.method,
            "n": self.n,
            "seed": self.seed,
            "ranges": {r.key: r.to_dict() for r in self.ranges},
        }

    def unit_points(self) -> np.ndarray:
        """The design in the unit cube, shape (size, d), in member order."""
        d = len(self.ranges)
        if self.method == "random":
            return np.random.default_rng(self.seed).random((self.n, d))
        from scipy.stats import qmc

        if self.method == "lhs":
            return qmc.LatinHypercube(d=d, seed=self.seed).random(self.n)
        ab = qmc.Sobol(d=2 * d, scramble=True, seed=self.seed).random(self.n)
        a, b = ab[:, :d], ab[:, d:]
        blocks = [a, b]
        for i in range(d):
            abi = a.copy()
            abi[:, i] = b[:, i]
            blocks.append(abi)
        return np.concatenate(blocks, axis=0)

    def points(self) -> list[dict]:
        """The members' values ``{key: value}`` (Python floats), in member order."""
        u = self.unit_points()
        cols = [r.scale(u[:, j]) for j, r in enumerate(self.ranges)]
        return [{r.key: float(c[i]) for r, c in zip(self.ranges, cols)} for i in range(len(u))]

    def block(self, member: int) -> str:
        """The Saltelli block of a "sobol" member: "A", "B" or "AB<i>" (A with the column of
        the i-th key, counted from 1, taken from B); "" for the other methods."""
        if self.method != "sobol":
            return ""
        k = member // self.n
        return "A" if k == 0 else "B" if k == 1 else f"AB{k - 1}"


def parse_sample(table: Any, fail: Callable[[str], None]) -> Sample:
    """Validate a ``[sample]`` table; ``fail(msg)`` raises the caller's one-line error."""
    if not isinstance(table, Mapping):
        fail(f"[sample] must be a table of method, n, seed and key ranges, got {table!r}")
    method = table.get("method")
    if method not in METHODS:
        close = difflib.get_close_matches(str(method), METHODS, n=1)
        hint = f" (did you mean {close[0]!r}?)" if close else ""
        fail(f"[sample] method={method!r}{hint}: give one of {', '.join(map(repr, METHODS))}")
    n = table.get("n")
    if not isinstance(n, int) or isinstance(n, bool) or n < 2:
        fail(f"[sample] n={n!r}: give a whole number of points >= 2")
    if method == "sobol" and n & (n - 1):
        fail(
            f"[sample] n={n}: method 'sobol' takes a power of 2 base points (2, 4, 8, 16, ...); "
            f"it runs n (d + 2) members"
        )
    seed = table.get("seed", 0)
    if not isinstance(seed, int) or isinstance(seed, bool) or seed < 0:
        fail(f"[sample] seed={seed!r}: give a whole number >= 0")

    ranges = []

    def walk(node, prefix):
        for k, v in node.items():
            key = f"{prefix}.{k}" if prefix else str(k)
            if not prefix and key in SAMPLE_KEYS:
                continue
            if isinstance(v, Mapping) and "range" not in v:
                walk(v, key)
            else:
                ranges.append(_parse_range(key, v, fail))

    walk(table, "")
    if not ranges:
        fail(
            '[sample] names no key to vary: add ranges such as "flow.nu" = [0.005, 0.05] '
            'or "flow.nu" = {range = [0.005, 0.05], log = true}'
        )
    return Sample(method=method, n=n, seed=seed, ranges=tuple(ranges))


def _number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _parse_range(key: str, v, fail) -> Range:
    if "." not in key:
        fail(f"[sample] key {key!r} must be a dotted scene key such as 'flow.nu'")
    log = False
    if isinstance(v, Mapping):
        unknown = [k for k in v if k not in RANGE_KEYS]
        if unknown:
            fail(
                f"[sample] {key!r} has the unknown entry {unknown[0]!r}; "
                f"give {{range = [LO, HI], log = true|false}}"
            )
        log = v.get("log", False)
        if not isinstance(log, bool):
            fail(f"[sample] {key!r}: log={log!r} must be true or false")
        v = v["range"]
    if not isinstance(v, list) or len(v) != 2 or not all(_number(x) for x in v):
        fail(f"[sample] {key!r} = {v!r}: give a range [LO, HI] of two finite numbers")
    lo, hi = float(v[0]), float(v[1])
    if lo >= hi:
        fail(f"[sample] {key!r} = [{lo:g}, {hi:g}]: LO must be below HI")
    if log and lo <= 0:
        fail(f"[sample] {key!r} = [{lo:g}, {hi:g}] with log = true: the range must be positive")
    return Range(key, lo, hi, log)


def member_names(prefix: str, count: int) -> list[str]:
    """Folder names of a sample's members: ``member-0000`` (after the grid part, if any)."""
    width = max(4, len(str(count - 1)))
    head = f"{prefix}_" if prefix and prefix != "base" else ""
    return [f"{head}member-{i:0{width}d}" for i in range(count)]

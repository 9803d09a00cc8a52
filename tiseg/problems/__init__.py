"""Verification problems as data: files naming a scene, an exact or reference solution and a
score, which ``tiseg bench accuracy``, the tests and the examples all load.

The files live in ``tiseg/data/problems/<name>.toml`` (format: `tiseg.problems.reader`);
the solutions they name are Python functions in `tiseg.problems.solutions`, the records
(what a timed run keeps) and scores in `tiseg.problems.scores`. A problem file only
chooses among these and sets their parameters, so a new problem on an existing solution is a
new file; a new kind of solution is one registry entry.

    >>> from tiseg.problems import load_problem
    >>> p = load_problem("ritter")
    >>> scene = p.build(200)                  # the scene at 200 cells
    >>> sim = Simulation(scene); raw = p.run(sim)
    >>> value, error = p.score(raw, scene)
"""

from .reader import Problem, builtin_problems, list_builtin_problems, load_problem
from .scores import RECORDS, SCORES, front_position
from .solutions import SOLUTIONS, transport_exact

__all__ = [
    "Problem",
    "RECORDS",
    "SCORES",
    "SOLUTIONS",
    "builtin_problems",
    "front_position",
    "list_builtin_problems",
    "load_problem",
    "transport_exact",
]

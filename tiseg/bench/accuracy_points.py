"""The points of the accuracy study: the numerics it varies, the problems it runs (the files in
tiseg/data/problems, see `tiseg.problems`) and the plan that combines them."""

from __future__ import annotations

from typing import Sequence

from ..errors import InputError
from ..problems import Problem, builtin_problems

RECONSTRUCTIONS = ("first-order", "minmod", "weno")
STEPPERS = ("rkc", "ssprk3", "euler")
PRECISIONS = ("f32", "f64")
DEFAULT_COMBO = {
    "reconstruction": "weno",
    "flux": "kt",
    "phi_flux": "upwind",
    "stepper": "rkc",
    "precision": "f64",
    "backend": "cpu",
    "cfl": 0.25,
}
# numerics a point leaves unset take these (theta only matters for minmod)
DEFAULT_SCHEME = {
    "reconstruction": "weno",
    "theta": 1.5,
    "flux": "kt",
    "phi_flux": "upwind",
    "cfl": 0.25,
}
# what rows from before the flux options (no theta / flux / phi_flux columns) were run with
LEGACY_SCHEME = {"theta": 1.5, "flux": "kt", "phi_flux": "central"}

# the study's problems, in the order of its tables (each file's ``order``)
PROBLEMS: dict[str, Problem] = builtin_problems()

NUMERICS_KEYS = ("reconstruction", "theta", "flux", "phi_flux", "stepper", "cfl")


def _numerics(point: dict, stepper: str | None = None) -> dict:
    """The scene's numerics section of a point (its stepper replaced by ``stepper`` if given)."""
    num = {k: point.get(k, DEFAULT_SCHEME[k]) for k in NUMERICS_KEYS if k != "stepper"}
    num["stepper"] = stepper or point["stepper"]
    return num


QUICK_RECONSTRUCTIONS = ("minmod", "weno")
QUICK_STEPPERS = ("rkc", "ssprk3")


def plan_points(
    quick: bool,
    problems: Sequence[str] | None = None,
    reconstructions: Sequence[str] | None = None,
    steppers: Sequence[str] | None = None,
    cfls: Sequence[float] = (0.25,),
    fluxes: Sequence[str] = ("kt",),
    phi_fluxes: Sequence[str] = ("upwind",),
    thetas: Sequence[float] = (1.5,),
) -> list[dict]:
    """Every (problem, resolution, reconstruction [x theta for minmod], flux, phi_flux, stepper,
    cfl) of the study, plus the reference run of each problem measured against a finer run
    (flag ``reference``).

    ``quick``: two resolutions per problem and, unless given, minmod/weno x rkc/ssprk3."""
    reconstructions = reconstructions or (QUICK_RECONSTRUCTIONS if quick else RECONSTRUCTIONS)
    steppers = steppers or (QUICK_STEPPERS if quick else STEPPERS)
    names = list(problems) if problems else list(PROBLEMS)
    for n in names:
        if n not in PROBLEMS:
            raise InputError(f"problem {n!r} is not known; choose from {', '.join(PROBLEMS)}")
    schemes = []
    for rec in reconstructions:
        for th in thetas if rec == "minmod" else (DEFAULT_SCHEME["theta"],):
            for fl in fluxes:
                for pf in phi_fluxes:
                    schemes.append(
                        {"reconstruction": rec, "theta": float(th), "flux": fl, "phi_flux": pf}
                    )
    pts = []
    for n in names:
        p = PROBLEMS[n]
        for res in p.quick_resolutions if quick else p.resolutions:
            for sch in schemes:
                for st in steppers:
                    for cfl in cfls:
                        pts.append(
                            {
                                "problem": n,
                                "resolution": res,
                                **sch,
                                "stepper": st,
                                "cfl": float(cfl),
                                "reference": False,
                            }
                        )
        if p.reference_resolution:
            pts.append(
                {
                    "problem": n,
                    "resolution": p.reference_resolution["quick" if quick else "full"],
                    **{
                        k: DEFAULT_SCHEME[k]
                        for k in ("reconstruction", "theta", "flux", "phi_flux")
                    },
                    "stepper": DEFAULT_COMBO["stepper"],
                    "cfl": DEFAULT_COMBO["cfl"],
                    "reference": True,
                }
            )
    return pts


def scheme_label(row: dict) -> str:
    """Short name of a point's spatial scheme: the reconstruction (with theta for minmod), then
    '+cu' for the central-upwind flux and '+up' for the upwind h phi flux."""
    rec = row["reconstruction"]
    th = float(row.get("theta", LEGACY_SCHEME["theta"]))
    name = f"minmod{th:g}" if rec == "minmod" else rec
    if row.get("flux", "kt") == "central-upwind":
        name += "+cu"
    if row.get("phi_flux", LEGACY_SCHEME["phi_flux"]) == "upwind":
        name += "+up"
    return name

"""`tiseg figures SET`: regenerate the paper's figures; SET is a nested sub-command.

Only ``stability`` (figures 8-11) exists so far; further sets (e.g. ``fingers``) register next to
it in :data:`FIGURE_SETS`.
"""
from __future__ import annotations

import shutil
from pathlib import Path

from .common import add_material_options, material_from_args

# repository assets folder (exists in a source checkout / editable install)
ASSETS_DIR = Path(__file__).resolve().parents[2] / "assets" / "figures"


def _run_stability(args) -> int:
    from ..figures.stability import make_all
    from ..errors import require

    require(20 <= args.dpi <= 600, f"--dpi={args.dpi!r} must lie in [20, 600]")
    m = material_from_args(args)
    m.require_finger_range()      # the figures are about the segregation-mobility model (3.10)
    paths = make_all(args.out, m, dpi=args.dpi)
    for p in paths:
        print(p)
    if args.assets:
        ASSETS_DIR.mkdir(parents=True, exist_ok=True)
        for p in paths:
            shutil.copy2(p, ASSETS_DIR / p.name)
            print(ASSETS_DIR / p.name)
    return 0


FIGURE_SETS = {
    "stability": ("figures 8-11: F(h0, phi0), growth rates sigma_M(k), sigma_Max(F) and k_c(F)",
                  _run_stability),
}


def register(sub) -> None:
    p = sub.add_parser("figures", help="regenerate figures of the paper as PNG files",
                       description="Regenerate the paper's figures. Choose a set of figures.")
    sets = p.add_subparsers(dest="figure_set", metavar="SET")
    sets.required = True
    for name, (text, func) in FIGURE_SETS.items():
        q = sets.add_parser(name, help=text, description=text)
        q.add_argument("--out", required=True, metavar="DIR", help="output folder for the PNGs")
        q.add_argument("--dpi", type=int, default=90, help="resolution (default 90)")
        q.add_argument("--assets", action="store_true",
                       help=f"also copy the PNGs into the repository's {ASSETS_DIR}")
        add_material_options(q)
        q.set_defaults(func=func)

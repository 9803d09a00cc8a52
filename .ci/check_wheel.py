"""What the wheel must hold: the tiseg package with its built-in scenes, sweeps, problems and
example relief, and no other top-level package (the source checkout's ``viewer`` alias stays out)."""

import sys
import zipfile

names = zipfile.ZipFile(sys.argv[1]).namelist()
top = {n.split("/")[0] for n in names if not n.split("/")[0].endswith((".dist-info", ".data"))}
problems = []
if top != {"tiseg"}:
    problems.append(f"top-level entries {sorted(top)}, expected only 'tiseg'")
for need in (
    "tiseg/data/scenes/fingers.toml",
    "tiseg/data/scenes/channel.toml",
    "tiseg/data/sweeps/grid-study.toml",
    "tiseg/data/problems/ritter.toml",
    "tiseg/data/scenes/obstacle.toml",
    "tiseg/data/terrain/channel-hollow.asc",  # the relief of examples/relief.py
    "tiseg/apps/viewer/app.py",
):
    if need not in names:
        problems.append(f"missing {need}")
if problems:
    sys.exit("wheel check failed: " + "; ".join(problems))
print(f"wheel ok: {len(names)} files, scenes, sweeps and problems included")

"""fields.nc against the CF conventions (1.8), through two checkers that read them differently.

* cfchecks (the CF community's checker, package cfchecker) must report no error. It runs
  offline: the standard-name table is the one the IOOS checker ships, and the area-type and
  region tables, which fields.nc does not use, are empty stand-ins.
* The IOOS compliance checker must report nothing to fix but one finding: it takes any variable
  *named* ``time`` for a time coordinate (its section 5.1 check, a heuristic of that checker),
  while tiseg's ``time`` is model time in seconds with no reference date, a plain coordinate in
  CF's terms (CF 4.4 tells a time coordinate by its units). Any other finding fails.

Usage: python check_cf.py FILE.nc (the Python of a venv with compliance-checker and cfchecker).
"""

import json
import re
import subprocess
import sys
import tempfile
from pathlib import Path

import compliance_checker

# the one IOOS finding accepted, on a coordinate named time whose units carry no date
ACCEPTED = ("§5.1", "Coordinate variable 'time' should have standard_name='time', found: 'None'")

EMPTY_AREA = (
    '<?xml version="1.0"?>\n<area_type_table><version_number>0</version_number>'
    "<date>none</date></area_type_table>\n"
)
EMPTY_REGIONS = (
    '<?xml version="1.0"?>\n<standardized_region_list><version_number>0</version_number>'
    "<date>none</date></standardized_region_list>\n"
)


def ioos_findings(path: str, tmp: Path) -> list[str]:
    """The IOOS checker's failed checks other than the accepted one, as lines."""
    report = tmp / "ioos.json"
    subprocess.run(
        [str(Path(sys.executable).with_name("compliance-checker")), "--test", "cf:1.8",
         "-f", "json", "-o", str(report), path],
        capture_output=True, text=True, timeout=600, check=False,
    )  # fmt: skip
    result = json.loads(report.read_text())["cf:1.8"]
    found = []
    for check in result["all_priorities"]:
        scored, possible = check["value"]
        if scored == possible:
            continue
        msgs = set(check["msgs"])
        if check["name"].startswith(ACCEPTED[0]) and msgs == {ACCEPTED[1]}:
            continue
        found.append(f"IOOS {check['name']}: {sorted(msgs)}")
    return found


def cfchecks_errors(path: str, tmp: Path) -> list[str]:
    """cfchecks' errors (its warnings are printed, not counted)."""
    names = Path(compliance_checker.__file__).parent / "data" / "cf-standard-name-table.xml"
    area, regions = tmp / "area.xml", tmp / "regions.xml"
    area.write_text(EMPTY_AREA)
    regions.write_text(EMPTY_REGIONS)
    out = subprocess.run(
        [str(Path(sys.executable).with_name("cfchecks")), "-v", "1.8", "-s", str(names),
         "-a", str(area), "-r", str(regions), path],
        capture_output=True, text=True, timeout=600, check=False,
    )  # fmt: skip
    text = out.stdout + out.stderr
    count = re.search(r"ERRORS detected: (\d+)", text)
    if count is None:
        return [f"cfchecks gave no verdict:\n{text[-3000:]}"]
    for line in text.splitlines():
        if line.startswith("WARN:"):
            print(f"cfchecks: {line}")
    return [f"cfchecks {line}" for line in text.splitlines() if line.startswith("ERROR:")]


def main() -> None:
    path = sys.argv[1]
    with tempfile.TemporaryDirectory() as tmp:
        problems = ioos_findings(path, Path(tmp)) + cfchecks_errors(path, Path(tmp))
    if problems:
        sys.exit("CF check failed:\n" + "\n".join(problems))
    print(f"CF-1.8: cfchecks no error; IOOS checker nothing but its name heuristic ({path})")


if __name__ == "__main__":
    main()

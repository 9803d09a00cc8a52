"""The README's two timing claims against what this CI run measured.

The README states how long its two commands take on 2 cores ("about 1 minute", "about 7
minutes"). CI times the same work: the set-up and the demo, and the test command. A test
command more than ``FAIL`` times off its claim (either way) fails the run: a stale number, not
noise, since a quiet 2-core machine reproduces it to about 25 %. The set-up only warns: most of
it is the download of the packages, which depends on the network CI has, not on tiseg. Off by
more than ``WARN``, either prints a warning with the number to write instead.

Usage: python check_readme_timings.py --setup SECONDS --tests SECONDS [README]
"""

import argparse
import re
import sys
from pathlib import Path

WARN = 1.25
FAIL = 2.0

# the two claims, as the README words them
CLAIMS = {
    "setup": re.compile(r"set up and run the demo.*?\(about (\d+(?:\.\d+)?) minutes?", re.S),
    "tests": re.compile(r"Run the tests \(about (\d+(?:\.\d+)?) minutes?"),
}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--setup", type=float, required=True, help="set-up + demo wall time [s]")
    ap.add_argument("--tests", type=float, required=True, help="test command wall time [s]")
    ap.add_argument("readme", nargs="?", default=Path(__file__).parents[1] / "README.md")
    args = ap.parse_args()
    text = Path(args.readme).read_text(encoding="utf-8")
    failed = []
    for name, pattern in CLAIMS.items():
        found = pattern.search(text)
        if found is None:
            failed.append(f"the README states no time for its {name} command")
            continue
        claim = 60.0 * float(found.group(1))
        took = getattr(args, name)
        ratio = took / claim
        line = f"README {name}: claims {claim / 60:g} min, took {took / 60:.1f} min ({ratio:.2f}x)"
        print(line)
        if name == "tests" and not 1 / FAIL <= ratio <= FAIL:
            failed.append(line)
        elif not 1 / WARN <= ratio <= WARN:
            print(f"warning: {line}; write about {round(took / 60)} minutes")
    if failed:
        sys.exit("README test timing off by more than 2x:\n" + "\n".join(failed))


if __name__ == "__main__":
    main()

"""``python -m tiseg``: the `tiseg` command line (`tiseg.apps.cli.main`)."""

import sys

from tiseg.apps.cli import main

if __name__ == "__main__":
    sys.exit(main())

"""Cell-updates per second of the operator: now part of ``tiseg bench throughput``.

    python benchmarks/operator_throughput.py [--nx 1125 --ny 375] [--quick]

is the same as ``tiseg bench throughput --json [--nx ...] [--ny ...]``: every precision in its
own process, each effect switched off in turn, the NumPy reference and a memory-bandwidth bound
measured in the same run (see :mod:`tiseg.apps.bench.throughput` and benchmarks/README.md).
"""

import sys

from tiseg.apps.cli import main

if __name__ == "__main__":
    sys.exit(main(["bench", "throughput", "--json", *sys.argv[1:]]))

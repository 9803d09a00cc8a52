"""``python -m viewer SCENE ...`` from the repository root: the same as ``tiseg view SCENE``."""

import sys

from tiseg.apps.viewer.app import main

sys.exit(main())

"""``python -m tiseg.apps.viewer SCENE [--set k=v] [--arch cpu] [--frames N] ...``"""

import sys

from .app import main

sys.exit(main())

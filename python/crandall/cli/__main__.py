"""``python -m crandall.cli``: the ``crandall`` command line."""

import sys

from . import main

sys.exit(main())

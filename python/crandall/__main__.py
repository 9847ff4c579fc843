"""``python -m crandall``: the main job, ``crandall run`` on the paper's scene.

With arguments it is the ``crandall`` command line (``python -m crandall analytic``).
"""

import sys

from .cli import main

if __name__ == "__main__":
    sys.exit(main(sys.argv[1:] or ["run"]))

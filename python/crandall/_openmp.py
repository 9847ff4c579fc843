"""OpenMP's wait policy for the core, set before the core loads (crandall/__init__.py imports
this first).

Between two parallel loops an idle thread of GNU's OpenMP runtime spins (300000 pauses,
milliseconds) before it sleeps. On a machine shared with other work those spins take the cores
the work needs: with other work on a 2-core machine, runs on every core took up to several
times as long as on one thread (issue 30). With the passive policy an idle thread sleeps at
once; waking it costs microseconds, nothing next to the least work a thread of the core is
given (kThreadWork, cpp/include/crandall/run.hpp). A policy the user set (OMP_WAIT_POLICY, or
the runtimes' own GOMP_SPINCOUNT, KMP_BLOCKTIME) is kept.

The runtime reads the policy when it is loaded, which is when the core is first imported: the
variable is set for that import only, so child processes see the user's environment (a
process that imports crandall gets the policy itself). A runtime another module loaded first
keeps the policy it read; the core's rule for small loops (run.hpp) does not depend on it.
"""

from __future__ import annotations

import os

#: Set by the user: then the runtime's policy is theirs.
USER_SETTINGS = ("OMP_WAIT_POLICY", "GOMP_SPINCOUNT", "KMP_BLOCKTIME")

if any(name in os.environ for name in USER_SETTINGS):
    from . import _core  # noqa: F401
else:
    os.environ["OMP_WAIT_POLICY"] = "passive"
    try:
        from . import _core  # noqa: F401
    finally:
        del os.environ["OMP_WAIT_POLICY"]

"""The ``crandall`` command line: ``crandall run [SCENE]``, ``crandall tail [SCENE]``,
``crandall fragility [SCENE]``, ``crandall analytic [SCENE]``, ``crandall scenes`` (the shipped scenes, by name) and
``crandall newmark RECORD`` (Newmark's sliding block on a recorded ground motion) and
``crandall suite RECORD ...`` (a suite of records as a fragility curve).

``crandall run`` without a scene file simulates the paper's setting (``crandall.paper``) and
prints it beside the analytic layer; ``python -m crandall`` does the same.

The package's modules: ``parser`` (the arguments), ``outputs`` (the output folders, their
manifests and the files written into them), ``simulation`` (``crandall run`` and
``crandall analytic``), ``suite`` (``crandall suite``), ``commands`` (the other subcommands and :func:`main`). The names below
are the ones other modules and tests reach as ``crandall.cli.<name>``; a name is looked up where
its module uses it, so a test replaces it there (``crandall.cli.simulation.simulate``).
"""

from .commands import (fragility_command, main, newmark_command, scenes_command,
                       tail_command)
from .outputs import (DEFAULT_FILE_PATHS, DEFAULT_OUT, DEFAULT_TAIL_OUT, MANIFEST, PAPER_SEED,
                      TAIL_MANIFEST)
from .parser import _parser
from .suite import suite_command
from .simulation import QUANTILES, _analytic_table, analytic_command, quantile_table, run

__all__ = ["main", "run", "PAPER_SEED", "DEFAULT_OUT", "DEFAULT_TAIL_OUT"]

"""Recorded ground motions and Newmark's sliding block on them (docs/records.md).

A :class:`Record` is a ground acceleration sampled every ``dt`` seconds (read from a
two-column time/acceleration text file, a single column with a given ``dt``, or a PEER NGA
``.AT2`` file). :func:`newmark` slides a rigid block on it:

- ``ky`` (in g): one-way downslope sliding above the yield acceleration ky g, the rigid block
  of SLAMMER and pySLAMMER;
- ``mu`` (and ``mu_static``): two-way sliding on a flat surface, crandall's own model with the
  record in place of white noise;
- ``kd`` and ``ku`` (in g): two-way sliding on an incline, downslope above kd g and upslope
  above ku g.

``method="exact"`` integrates the record joined by straight lines exactly (its error is the
record's, not the integrator's); ``method="slammer"`` is pySLAMMER 0.2.2's recursion, bit for
bit. Arrays of yields and ``polarity="both"`` (and a list of records) sweep every combination
in the compiled core, across threads; the numbers do not depend on the thread count.

g is standard gravity, 9.80665 m/s^2 (:data:`G`), as in the PEER files and pySLAMMER.

The package's modules: ``record`` (:class:`Record` and the files it reads), ``sweep``
(:func:`newmark`), ``result`` (:class:`NewmarkResult` and :func:`load_newmark`). The names
below are the ones other modules and tests reach as ``crandall.records.<name>``.
"""

from .record import FILE_FORMAT, G, METHODS, POLARITIES, UNITS, Record
from .result import SWEEP_SAMPLES, NewmarkResult, load_newmark
from .sweep import newmark

__all__ = ["G", "UNITS", "METHODS", "POLARITIES", "Record", "NewmarkResult", "newmark",
           "load_newmark"]

"""Statistics of a run: means, variances, standard errors, mixed moments, a summary.

The package's modules: ``common`` (the warning, ``Stat``, ``Accumulators``, the moments' layout
and the numbers' formatting), ``result`` (the fixed-step ``Result`` and the bias hook
``set_bias_estimator``), ``histograms`` and ``tables`` (the parts of ``Result`` that answer
from histograms and that build its statistics table, show and save it), ``accuracy``
(``AccuracyResult``), ``table`` (the table every result's shown forms render) and
``render_text`` (its text). The names below
are the package's public face and the ones other modules and tests reach as
``crandall.results.<name>``; a name is looked up where its module uses it, so a test replaces
it there (``crandall.results.result._bias_estimator``).
"""

from .accuracy import AccuracyResult
from .common import (FEW_MARK, MIN_CARRIERS, MONOMIALS, Accumulators, Stat, StatisticsWarning, _e,
                     z_of)
from .result import Result, set_bias_estimator

__all__ = ["Result", "Accumulators", "StatisticsWarning", "MIN_CARRIERS"]

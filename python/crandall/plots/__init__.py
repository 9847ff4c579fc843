"""The paper's figures: simulated statistics with their error bars, the analytic curves and
the residuals where the paper's closed forms hold, densities against histograms.

Every function returns a :class:`matplotlib.figure.Figure` (drawn with the Agg canvas, never
through pyplot's global state, so it works without a display and in threads);
:func:`write_figures` writes them all (PNG, PDF or SVG). The moment figures are in the scene's
units (s, m, J for an SI scene) or, with ``units="scaled"``, the paper's scaled units (eq3,
eq8); the densities of the paper's scene are in scaled units.

Needs the ``plots`` extra: ``pip install crandall[plots]`` (matplotlib).

The package's modules: ``common`` (the figure, the styles and the units), ``moments`` (the
moment figures), ``samples`` (stored paths and the densities drawn from fresh samples),
``histograms`` (the stop quantities' distributions), ``figures`` (a run's set of figures and
their files), ``engineering`` (Newmark's block and fragility curves). The names below are the
ones other modules and tests reach as ``crandall.plots.<name>``.
"""

from .common import FORMATS, UNITS, Z95
from .engineering import fragility, newmark, newmark_sweep
from .figures import figures, write_figures
from .histograms import SHOWN_MASS, STOP_DISTRIBUTIONS, _analytic_law, _shown_range, distribution
from .moments import displacement_var, distance_mean, distance_var, velocity_var
from .samples import paths, stop_time_density, velocity_density

__all__ = [
    "distance_mean",
    "velocity_var",
    "displacement_var",
    "distance_var",
    "velocity_density",
    "stop_time_density",
    "distribution",
    "STOP_DISTRIBUTIONS",
    "figures",
    "write_figures",
    "paths",
    "newmark",
    "newmark_sweep",
    "fragility",
    "UNITS",
    "FORMATS",
]

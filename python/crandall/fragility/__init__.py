"""Fragility curves: P(Q > threshold) over a grid of intensities or frictions, a lognormal fit
and the annual rate of exceedance under a site's hazard curve (docs/fragility.md).

Each grid point is a :func:`crandall.tail` run (splitting by default), with its 95 % interval.
On the paper's scene (from rest, one intensity until t0) the scaling of eq8 is exact
(:data:`crandall.model.SCALING`): in scaled units P(Q > q) depends only on q over its scaled
unit and on tau0 = t0 (mu g)^2 / (2 h^2), so grid points (h, mu) with the same tau0 share one
scaled run at the union of their scaled thresholds. Where the scene holds an effect that
identity does not support (a start in motion, a piecewise schedule, an envelope), each grid
point is run on its own scene.

The package's modules: ``grid`` (the axes, each point's scene, the plan that shares scaled
runs and the runs), ``entry`` (:func:`fragility` and a one-axis grid's result), ``result``
(:class:`FragilityResult` and :func:`load`), ``hazard`` (the fit's and the hazard's results
and a site's hazard curve). The names below are the ones other modules and tests reach as
``crandall.fragility.<name>`` (``crandall.fragility`` in the package is the function;
``importlib.import_module("crandall.fragility")`` is the package).
"""

from .entry import fragility, run_grid
from .grid import (_KIND, _LABEL, _SHORT, _SIGN, _Z95, AXES, _grid, plan, point_scene,
                   scene_intensity)
from .hazard import Hazard, LognormalFit, hazard_csv, read_hazard_curve
from .result import FragilityResult, load

__all__ = ["fragility", "FragilityResult", "LognormalFit", "Hazard", "load", "AXES",
           "read_hazard_curve", "hazard_csv"]

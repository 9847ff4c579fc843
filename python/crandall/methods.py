"""The simulation methods the engine offers, the default one, and the default step."""

__all__ = ["METHODS", "DEFAULT_METHOD", "DEFAULT_DT_TAU", "DEFAULT_STEPS_FREE"]

#: Method names accepted by ``simulate(method=...)``:
#: "exact": velocity exact in law for any step; displacement and distance by the trapezoid
#: rule on the exact skeleton. "euler": Euler-Maruyama (weak order 1), for comparison.
#: "richardson": the exact skeleton with trapezoid integrals on the grid and on every 2nd and
#: every 4th point of it (the same path), every moment extrapolated to step 0 assuming a bias
#: c1 h^1.5 + c2 h^2 (docs/methods/richardson.md). "richardson2": the same on two grids (h, 2h),
#: assuming c h^1.5. "refine": the exact skeleton, with steps that start within 2 standard
#: deviations of 0 taken as 8 exact substeps (docs/methods/refine.md).
METHODS = ("exact", "euler", "richardson", "richardson2", "refine")

#: The method ``simulate`` uses when none is given.
DEFAULT_METHOD = "exact"

#: Default internal step in scaled time (tau), where time integrals are observed. Its measured
#: bias is reported by bench/bias.py.
DEFAULT_DT_TAU = 0.01

#: Without friction there is no natural time scale: the default step is the horizon over this.
DEFAULT_STEPS_FREE = 2000

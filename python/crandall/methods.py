"""The simulation methods the engine offers, the default one, and the default step."""

__all__ = ["METHODS", "DEFAULT_METHOD", "DEFAULT_DT_TAU", "DEFAULT_STEPS_FREE"]

#: Method names accepted by ``simulate(method=...)``:
#: "exact": velocity exact in law for any step; displacement and distance by the trapezoid
#: rule on the exact skeleton. "euler": Euler-Maruyama (weak order 1), for comparison.
METHODS = ("exact", "euler")

#: The method ``simulate`` uses when none is given.
DEFAULT_METHOD = "exact"

#: Default internal step in scaled time (tau), where time integrals are observed. Its measured
#: bias is reported by bench/bias.py.
DEFAULT_DT_TAU = 0.01

#: Without friction there is no natural time scale: the default step is the horizon over this.
DEFAULT_STEPS_FREE = 2000

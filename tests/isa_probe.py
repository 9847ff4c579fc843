"""Run small simulations of every method and observable set and print their statistics as hex
(with the kernel variant that ran), as JSON: tests/test_isa.py compares these across
CRANDALL_ISA settings, emulated CPUs and cluster workers. Not a test module itself."""

import json
import sys

import crandall
from crandall import _core

METHODS = ["exact", "euler", "richardson", "richardson2", "refine"]
OBSERVE = [["velocity"], ["velocity", "stop"], ["velocity", "displacement"],
           ["velocity", "distance"], ["velocity", "stop", "displacement", "distance"]]


def hex_statistics(result) -> dict:
    out = {}
    for name in result.names:
        for what, value in (("mean", result.mean(name)), ("var", result.var(name))):
            values = [value] if isinstance(value, float) else list(value)
            out[f"{name}.{what}"] = [float(v).hex() for v in values]
    return out


def probe(paths: int) -> dict:
    stats = {}
    for method in METHODS:
        for observe in OBSERVE:
            scene = crandall.Scene.scaled(tau0=1.0, times=[0.5, 1.0, 1.5], observe=observe)
            r = crandall.simulate(scene, paths=paths, seed=17, dt=0.05, method=method, threads=1,
                                  progress=False)
            stats[f"{method}/{'+'.join(observe)}"] = hex_statistics(r)
        # Pauses between shocks, where bodies come to rest: the steps without noise take the
        # scalar exact step and the coast's integrals (kernel.hpp, step_distance).
        pauses = crandall.Scene(mu=0.3, h=[1.0, 0.0, 1.0], t0=[0.5, 1.5, 1.75], v0=0.5,
                                times=[0.25, 1.0, 2.0], observe=OBSERVE[-1])
        r = crandall.simulate(pauses, paths=paths, seed=17, dt=0.05, method=method, threads=1,
                              progress=False)
        stats[f"{method}/pauses"] = hex_statistics(r)
    return {"isa": _core.build_info()["isa"], "available": _core.build_info()["isa_available"],
            "stats": stats, "newmark": newmark_probe(), "split": split_probe()}


def split_probe() -> dict:
    """Splitting replicas in the core (its particles in the variant's vector lanes) with the
    plain and the normalised score: their estimates and info, as hex."""
    import numpy as np

    from crandall.tail.problem import _Problem
    from crandall.tail.splitting import _splitting_replica

    scene = crandall.Scene.scaled(tau0=2.0, times=[2.0])
    out = {}
    for quantity, levels in (("stop_time", [3.0, 4.0]), ("distance_at_stop", [6.0])):
        est, info = _splitting_replica(_Problem(scene, quantity, None, 0.05),
                                       np.array(levels), 30, 3, 11, 1, 1, 5000)
        out[quantity] = [float(x).hex() for x in est] + [
            float(info["log_weight"]).hex(), info["iterations"], info["steps"]]
    return out


def newmark_probe() -> dict:
    """Newmark's block, exact and slammer, on a record made with +, -, x, / only (no libm, whose
    results may depend on the CPU): the displacements and slips as hex."""
    import numpy as np

    i = np.arange(3000, dtype=float)
    record = ((i * 7919.0) % 1000.0 - 500.0) / 1000.0 * 0.6 * (1.0 - i / 3000.0)
    rec = crandall.Record(record, 0.01)
    out = {}
    for method in ("exact", "slammer"):
        r = crandall.newmark(rec, ky=[0.05, 0.1, 0.2], polarity="both", method=method, threads=1)
        out[method] = [float(x).hex() for x in np.ravel(r.table)]
    r = crandall.newmark(rec, kd=0.1, ku=0.15, polarity="both", threads=1)
    out["incline"] = [float(x).hex() for x in np.ravel(r.table)]
    r = crandall.newmark(rec, mu=0.1, mu_static=0.12, polarity="both", threads=1)
    out["flat"] = [float(x).hex() for x in np.ravel(r.table)]
    return out


if __name__ == "__main__":
    print(json.dumps(probe(int(sys.argv[1]) if len(sys.argv) > 1 else 600)))

"""``python -m crandall``: the main job, the paper's scene against the analytic layer."""

import sys
import time

from .paper import DEFAULT_PATHS, comparison, default_scene
from .simulate import simulate


def main() -> int:
    scene = default_scene()
    print(f"crandall: {scene!r}")
    print(f"simulating {DEFAULT_PATHS:,} paths ...", flush=True)
    start = time.perf_counter()
    result = simulate(scene, paths=DEFAULT_PATHS, seed=20261121)
    elapsed = time.perf_counter() - start
    print(comparison(result))
    print(f"\n{DEFAULT_PATHS:,} paths x {result.steps_per_path} steps in {elapsed:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())

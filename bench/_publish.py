"""Where a bench script's results go: bench/out/STEM.{json,png}, and with --publish also
bench/results/ (the figures the README quotes). Shared by the bench scripts."""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from typing import Any, Callable, Optional

HERE = Path(__file__).resolve().parent


def write(stem: str, data: Any, plot: Callable[[Any, Path], None], *, publish: bool,
          default: Optional[Callable[[Any], Any]] = None) -> Path:
    """Write data as JSON and plot(data, path) as PNG under bench/out/; copy both to
    bench/results/ when publish. Returns the JSON's path in bench/out/."""
    out = HERE / "out"
    out.mkdir(exist_ok=True)
    (out / f"{stem}.json").write_text(json.dumps(data, indent=1, default=default))
    plot(data, out / f"{stem}.png")
    if publish:
        dest = HERE / "results"
        dest.mkdir(exist_ok=True)
        for ext in ("json", "png"):
            shutil.copy(out / f"{stem}.{ext}", dest / f"{stem}.{ext}")
    return out / f"{stem}.json"

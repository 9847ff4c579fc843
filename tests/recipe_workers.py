"""What the recipes' tests (docs/architecture.md, "How to add ...") do to a Dask worker's
process: the change a recipe makes to the package's source (a row of ``QUANTITIES``, a kind
in ``excitation.KINDS``, an effect in ``model.SIMULATED`` and an identity's ``supports``) is
made in the test by patching the client's modules, which a worker's process does not share.
``on_workers`` makes the same patches there and undoes them when the block ends, so that a
recipe's Dask leg goes through real worker processes (``simulate(..., client=)``,
``crandall.tail(..., client=)``) as the real change would.

A worker imports what a test sends it by name (this module's functions, a stub class or a
task function defined in a test module, which Dask pickles by reference) from this folder,
which ``conftest.worker_client`` puts on the worker's path."""

from __future__ import annotations

import contextlib
import dataclasses
import importlib
from typing import Any, Iterator, List, Sequence, Tuple

#: One patch: (where, name, value). ``where`` is "module" or "module:attr.attr" (an object
#: reached from a module, looked up in the worker's process); ``name`` an attribute of it,
#: or "[key]" for an item of a dict.
Change = Tuple[str, str, Any]

#: What a worker keeps to undo the patches (an attribute of the Worker object).
_UNDO = "_recipe_undo"
#: What an undo records for an attribute or item that was not there (compared by value, not
#: by identity, so that it does not matter how the worker came by this module).
_MISSING = "<recipe_workers: missing>"


def _resolve(where: str) -> Any:
    module, _, path = where.partition(":")
    obj = importlib.import_module(module)
    for part in path.split(".") if path else ():
        obj = getattr(obj, part)
    return obj


def _set(obj: Any, name: str, value: Any) -> None:
    if name.startswith("["):
        if value == _MISSING:
            del obj[name[1:-1]]
        else:
            obj[name[1:-1]] = value
    elif value == _MISSING:
        delattr(obj, name)
    elif dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        object.__setattr__(obj, name, value)  # a frozen model.Identity
    else:
        setattr(obj, name, value)


def _get(obj: Any, name: str) -> Any:
    if name.startswith("["):
        return obj.get(name[1:-1], _MISSING)
    # A class's own attribute (a property is read as the property, not its value).
    return obj.__dict__.get(name, _MISSING) if isinstance(obj, type) else getattr(obj, name)


def _apply(changes: Sequence[Change], dask_worker=None) -> int:
    undo: List[Tuple[Any, str, Any]] = getattr(dask_worker, _UNDO, [])
    setattr(dask_worker, _UNDO, undo)  # kept as it grows: a failed change undoes the others
    for where, name, value in changes:
        obj = _resolve(where)
        undo.append((obj, name, _get(obj, name)))
        _set(obj, name, value)
    return len(undo)


def _undo(dask_worker=None) -> int:
    undo = getattr(dask_worker, _UNDO, [])
    for obj, name, old in reversed(undo):
        _set(obj, name, old)
    setattr(dask_worker, _UNDO, [])
    return len(undo)


@contextlib.contextmanager
def on_workers(client, changes: Sequence[Change]) -> Iterator[None]:
    """Every worker of ``client`` patched by ``changes`` for the block, then restored."""
    client.run(_apply, list(changes))
    try:
        yield
    finally:
        client.run(_undo)


def refusing(name: str):
    """A stand-in for the core's path-drawing function ``name`` that fails the test."""
    def call(*args, **kwargs):
        raise AssertionError(f"_core.{name} drew paths of a refused scene on a worker")
    return call


#: The core's functions that draw paths: none may run for a refused scene.
DRAWING = ("run_chunk", "run_samples", "extend_paths", "extend_filtered_paths", "split_replica",
           "exact_steps")


def no_path_drawn() -> List[Change]:
    """The changes that make every path-drawing function of a worker's core fail."""
    return [("crandall._core", name, refusing(name)) for name in DRAWING]

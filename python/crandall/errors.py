"""The error a bad parameter raises: a ValueError that carries the parameter's name."""

from __future__ import annotations

from typing import Any, Tuple

__all__ = ["ParameterError", "UnresolvableGrid"]


class ParameterError(ValueError):
    """A bad value of one parameter (or of a few, named together).

    A ``ValueError`` (callers that catch ValueError are unchanged) whose message names the
    parameter, and whose :attr:`name` says which one, so that a caller can map it to where
    the value came from (a scene file's key) without reading the message.

    Parameters
    ----------
    name : str
        The parameter ("times", "mu"), or several separated by ", " ("mu, g").
    message : str
        The whole message, starting with the parameter's name.
    """

    def __init__(self, name: str, message: str) -> None:
        super().__init__(message)
        self.name = name

    def __reduce__(self) -> Tuple[Any, Tuple[Any, ...]]:
        # Pickled with both arguments (a Dask worker's error comes back to the client so).
        return type(self), (self.name, str(self))


class UnresolvableGrid(ParameterError):
    """The integrals a scene observes (``integrals``: their observables) would need more
    internal steps than a grid can hold (2^53), while the rest of the scene needs none."""

    def __init__(self, integrals, message: str) -> None:
        super().__init__("observe", message)
        self.integrals = tuple(integrals)

    def __reduce__(self) -> Tuple[Any, Tuple[Any, ...]]:
        return type(self), (self.integrals, str(self))


"""The built-in table: every family module registers its functions here with `@builtin` or `register`.

A built-in is `f(ctx, *args, **kwargs)` where `ctx` is the calling script thread's ThreadContext (controller, cancel
event, waiting helpers). The interpreter resolves a call's name in `BUILTINS` at compile time.
"""
from collections.abc import Callable
from typing import Any, TypeVar, overload

Builtin = Callable[..., Any]
F = TypeVar("F", bound=Builtin)

BUILTINS: dict[str, Builtin] = {}


def register(name: str, function: Builtin) -> None:
    """Add `function` as the URScript built-in `name` (a second registration of a name is a programming error)."""
    if name in BUILTINS:
        raise ValueError(f"URScript built-in {name!r} is registered twice")
    BUILTINS[name] = function


@overload
def builtin(function: F) -> F: ...
@overload
def builtin(*names: str) -> Callable[[F], F]: ...


def builtin(*names):
    """Register the decorated function as a built-in.

    `@builtin` uses the function's name without a trailing underscore (`pow_` is `pow`, avoiding Python's own);
    `@builtin("freedrive_mode", "teach_mode")` registers it under each of the given names.
    """
    if len(names) == 1 and callable(names[0]):
        function = names[0]
        register(function.__name__.rstrip("_"), function)
        return function

    def decorate(function):
        for name in names:
            register(name, function)
        return function

    return decorate

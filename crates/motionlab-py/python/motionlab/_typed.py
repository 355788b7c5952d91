"""One function per registered plugin, grouped by kind (``motionlab.segmenters.clasp(m, …)``),
each with the plugin's documentation — the text ``motionlab describe NAME`` prints, from the
params struct's doc comments — as its docstring and its parameters as keyword arguments.

Built from the registry at import, so they are always the plugins of this build;
``_typed.pyi`` (written by ``python -m motionlab._stubgen`` when the wheel is built, see
``build_backend/motionlab_build.py``) gives type checkers the same functions."""

from __future__ import annotations

import inspect
import keyword
from types import SimpleNamespace

from . import _motionlab as _native

from ._kinds import KINDS, takes_rate


def _function(plugin, positional, generic):
    from . import _api

    name = plugin["name"]
    call = getattr(_api, generic)
    keys = [p["name"] for p in plugin["params"] if not keyword.iskeyword(p["name"])]

    if generic == "load":
        def f(*args, **params):
            bound = sig.bind(*args, **params)
            a = dict(bound.arguments)
            return call(a.pop("path"), name, **a)
    else:
        def f(*args, **params):
            bound = sig.bind(*args, **params)
            a = dict(bound.arguments)
            pos = [a.pop(p) for p in positional]
            return call(name, *pos, **a)

    sig = inspect.Signature(
        [inspect.Parameter(p, inspect.Parameter.POSITIONAL_OR_KEYWORD) for p in positional]
        + ([inspect.Parameter("rate", inspect.Parameter.KEYWORD_ONLY, default=None)] if takes_rate(positional) else [])
        + [inspect.Parameter(k, inspect.Parameter.KEYWORD_ONLY, default=None) for k in keys]
        + ([inspect.Parameter("pandas", inspect.Parameter.KEYWORD_ONLY, default=False)] if generic == "evaluate" else [])
    )
    f.__name__ = f.__qualname__ = name
    f.__signature__ = sig
    f.__doc__ = _native.describe(name)
    return f


def namespaces():
    """``{namespace: SimpleNamespace of functions}`` for every kind with a plugin."""
    out = {ns: SimpleNamespace() for ns, _, _ in KINDS.values()}
    for plugin in _native.plugins():
        if plugin["kind"] not in KINDS:
            continue  # a kind declared by a crate this package does not know how to call
        ns, positional, generic = KINDS[plugin["kind"]]
        setattr(out[ns], plugin["name"], _function(plugin, positional, generic))
    return out


globals().update(namespaces())

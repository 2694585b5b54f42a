"""The solve is a program JAX's persistent compilation cache keeps: no host callback in
it, whatever equinox's on-error mode (a program with one is never written to the cache,
so every new process would compile the solve again)."""

import jax

import jaxchain as jc
from jaxchain._deps import _eqx_errors as eqx_errors  # equinox's, through jaxchain's wrapper

from helpers import tooth_period


def _callbacks(jaxpr) -> list[str]:
    """Names of the callback primitives anywhere in ``jaxpr`` (sub-jaxprs included)."""
    found = []
    for eqn in jaxpr.eqns:
        if "callback" in eqn.primitive.name:
            found.append(eqn.primitive.name)
        for param in eqn.params.values():
            for sub in param if isinstance(param, (list, tuple)) else (param,):
                inner = getattr(sub, "jaxpr", sub)
                inner = getattr(inner, "jaxpr", inner)
                if hasattr(inner, "eqns"):
                    found += _callbacks(inner)
    return found


def test_the_solve_has_no_host_callback(monkeypatch):
    """With equinox raising on errors (its default), diffrax's checks of the traced times
    would be host callbacks; the solve traces them without any."""
    monkeypatch.setattr(eqx_errors, "EQX_ON_ERROR", "raise")
    scene = jc.scenes.engagement("08B", 18, n_entry=2, model=jc.scenes.ChainModel(settle=False))
    t1 = tooth_period(1000, 18)
    # a save count no other test uses: a trace of this solve cached earlier in the process
    # (another test's, under the test run's "nan" mode) would hide a callback
    traced = jax.make_jaxpr(
        lambda s: jc.simulate(s, t1, n_save=17, throw=False).peak_contact_force
    )(scene)
    assert _callbacks(traced.jaxpr) == []
    assert eqx_errors.EQX_ON_ERROR == "raise"  # restored after the solve's trace

"""Stacking scenes: one scene whose array leaves carry a leading member axis, and taking
one member back out (shared by ensembles, design objectives and the multi-process split)."""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .._numerics import stack as stack_arrays
from .._scene import Scene

__all__ = ["stack", "take"]


def _first_difference(a, b, path: str) -> str | None:
    """Where two scene pytrees stop sharing one structure ("" path = the scene)."""
    here = path or "scene"
    if type(a) is not type(b):
        return f"{here}: {type(a).__name__} vs {type(b).__name__}"
    if isinstance(a, eqx.Module):
        for f in dataclasses.fields(a):
            sub = f"{path}.{f.name}" if path else f.name
            d = _first_difference(getattr(a, f.name), getattr(b, f.name), sub)
            if d:
                return d
        return None
    if isinstance(a, (tuple, list)):
        if len(a) != len(b):
            return f"{here}: {len(a)} vs {len(b)} entries"
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            d = _first_difference(x, y, f"{path}[{i}]")
            if d:
                return d
        return None
    if isinstance(a, dict):
        if a.keys() != b.keys():
            return f"{here}: keys {sorted(a)} vs {sorted(b)}"
        for k in a:
            d = _first_difference(a[k], b[k], f"{path}[{k!r}]")
            if d:
                return d
        return None
    if eqx.is_array(a):
        if np.shape(a) != np.shape(b):
            return f"{here}: shape {np.shape(a)} vs {np.shape(b)}"
        if jnp.result_type(a) != jnp.result_type(b):
            return f"{here}: dtype {jnp.result_type(a)} vs {jnp.result_type(b)}"
        return None
    # static fields and non-array leaves (counts, kinds, regularization widths) are part
    # of the compiled structure: they must agree
    try:
        same = bool(a == b)
    except Exception:  # noqa: BLE001 - objects without a boolean equality
        same = a is b
    return None if same else f"{here}: {a!r} vs {b!r} (a non-array field must agree)"


def stack(scenes: Sequence[Scene]) -> Scene:
    """One :class:`~jaxchain.Scene` whose array leaves carry a leading member axis.

    Every scene must share one structure: the same bodies, pairs and sprockets (counts,
    tooth numbers, fidelity, contact slots, laws) — only array values (speeds, loads,
    profiles, masses, initial states, …) may differ.

    Raises:
        ValueError: naming the first field whose structure or shape differs.
    """
    scenes = list(scenes)
    if not scenes:
        raise ValueError("stack needs at least one scene")
    for i, s in enumerate(scenes):
        if not isinstance(s, Scene):
            raise TypeError(f"scene {i} is a {type(s).__name__}, not a jaxchain Scene")
        if np.ndim(s.q0) != 2:
            raise ValueError(f"scene {i} is already stacked (q0 has shape {np.shape(s.q0)})")
    for i, s in enumerate(scenes[1:], start=1):
        d = _first_difference(scenes[0], s, "")
        if d:
            raise ValueError(
                f"scene {i} does not share scene 0's structure, so they cannot be stacked: {d}"
            )
    return jax.tree_util.tree_map(
        lambda *xs: stack_arrays(xs) if eqx.is_array(xs[0]) else xs[0], *scenes
    )


def take(tree, index):
    """Member ``index`` of a stacked pytree (array leaves indexed, the rest kept)."""
    return jax.tree_util.tree_map(lambda x: x[index] if eqx.is_array(x) else x, tree)

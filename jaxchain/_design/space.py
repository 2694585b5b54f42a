"""The design space: a smooth, box-bounded map from unconstrained coordinates onto valid
tooth profiles (see :mod:`jaxchain.design`)."""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .. import _checks as checks
from .._chain import ChainSpec
from .._observers.base import (
    EXP_CAP as EXP_CAP,
    window_weight as window_weight,
)
from .._profiles.base import AbstractProfile
from .._profiles.freeform import FreeformProfile
from .._profiles.iso import ToothProfile, flank_meeting_diameter, iso606_limits
from .sprocket import SprocketDesign, profile_of

__all__ = ["PARAMETERS", "DesignSpace", "coordinate"]


PARAMETERS = ("seating_radius", "seating_angle", "flank_radius", "tip_diameter")


class DesignSpace(eqx.Module):
    """Tooth-profile parameters inside a box, reached through a smooth unconstrained
    coordinate ``u``: ``x = lower + (upper − lower)·sigmoid(u)``.

    Every ``u`` gives a profile inside the box, so an unconstrained optimizer (optax)
    can never leave it; the map is smooth with finite derivatives everywhere. ``u = 0``
    is the middle of the box.

    By default the box holds the four ISO 606 parameters of a :class:`ToothProfile`
    (``PARAMETERS``). :meth:`select` chooses any leaves of a tooth profile instead
    (``"seating_radius"``, ``"ccw.curvature"``, ``"cw.seat_angle"``, ``"phase"``, …), each
    a scalar, a (K,) flank leaf or one value per gap, with its own bounds: ``u`` is then
    the concatenation of every chosen leaf's entries, in the order given. With a
    :class:`SprocketDesign` as the template the paths reach its tooth and its cushion
    ring (``"profile.seating_radius"``, ``"cushion.radius"``): :meth:`design` gives the
    whole design, :meth:`profile` its tooth.

    Attributes:
        template: the profile (or :class:`SprocketDesign`) whose other fields are kept.
        lower, upper: (n,) box of the chosen entries (SI units).
        names: the chosen leaves (dotted paths into the profile; static).
        shapes: their shapes (static).
    """

    template: ToothProfile | FreeformProfile | SprocketDesign
    lower: Float[Array, " n"]
    upper: Float[Array, " n"]
    names: tuple[str, ...] = eqx.field(static=True)
    shapes: tuple[tuple[int, ...], ...] = eqx.field(static=True)

    def __init__(
        self,
        template: ToothProfile | FreeformProfile | SprocketDesign,
        lower: ArrayLike,
        upper: ArrayLike,
        names: Sequence[str] = PARAMETERS,
        shapes: Sequence[tuple[int, ...]] | None = None,
    ):
        names = tuple(names)
        checks.instance(
            "template", template, (AbstractProfile, SprocketDesign),
            "a jc.ToothProfile, jc.FreeformProfile or another jc.AbstractProfile, or a "
            "jc.design.SprocketDesign",
        )  # fmt: skip
        iso_box = names == PARAMETERS
        if iso_box:  # the ISO 606 four: leaves of the template's own
            missing = [n for n in names if not _is_leaf(template, n)]
            if missing:
                raise TypeError(
                    f"the default design box needs the ISO 606 parameters {PARAMETERS}; this "
                    f"{type(template).__name__} has no {missing}: choose its leaves with "
                    "DesignSpace.select(template, {path: (lower, upper)})"
                )
        shapes = tuple(tuple(s) for s in shapes) if shapes is not None else ((),) * len(names)
        n = sum(math.prod(s) for s in shapes)
        lo = np.asarray(lower, dtype=float)
        hi = np.asarray(upper, dtype=float)
        if lo.shape != (n,) or hi.shape != (n,):
            raise ValueError(f"lower and upper must have shape ({n},) for {names}")
        if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):
            raise ValueError(f"lower and upper must be finite, got {lo.tolist()}, {hi.tolist()}")
        if not np.all(hi > lo):
            bad = [e for e, a, b in zip(_entries(names, shapes), lo, hi, strict=True) if not b > a]
            raise ValueError(f"upper must exceed lower for every parameter; not for {bad}")
        self.template = template
        self.lower = jnp.asarray(lo)
        self.upper = jnp.asarray(hi)
        self.names = names
        self.shapes = shapes
        if iso_box:
            _check_box(template, lo, hi)
        else:
            _check_box_sampled(self)

    @classmethod
    def iso606(cls, chain: ChainSpec | str, teeth: int) -> DesignSpace:
        """The ISO 606 minimum/maximum limits of ``chain`` on a ``teeth``-tooth sprocket."""
        lim = iso606_limits(chain, teeth)
        template = ToothProfile.iso606(chain, teeth, "mid")
        return cls(template, [lim[n][0] for n in PARAMETERS], [lim[n][1] for n in PARAMETERS])

    @classmethod
    def select(
        cls,
        template: ToothProfile | FreeformProfile | SprocketDesign,
        bounds: dict[str, tuple[ArrayLike, ArrayLike]],
    ) -> DesignSpace:
        """A box over the chosen leaves of ``template``: ``{path: (lower, upper)}``. Each
        bound is a scalar or an array; the leaf takes the broadcast shape of its
        template value and both bounds (bounds of shape (z,) on a uniform leaf make it a
        per-gap pattern). Example: ``{"seating_radius": (ri_lo·ones(z), ri_hi·ones(z)),
        "ccw.curvature": (k_lo, k_hi)}``. Checked: the box's corners (all of them up to
        6 coordinates; else its middle, its two extreme corners and 64 seeded random
        corners) are valid profiles."""
        checks.instance(
            "template", template, (AbstractProfile, SprocketDesign),
            "a jc.ToothProfile, jc.FreeformProfile or another jc.AbstractProfile, or a "
            "jc.design.SprocketDesign",
        )  # fmt: skip
        if not isinstance(bounds, dict) or not bounds:
            raise TypeError("bounds must be a non-empty dict {leaf path: (lower, upper)}")
        names, shapes, lows, highs = [], [], [], []
        for name, pair in bounds.items():
            leaf = _leaf(template, name)
            lo, hi = checks.pair(f"bounds[{name!r}]", pair, 2, "bounds (lower, upper)")
            for side, v in (("lower", lo), ("upper", hi)):
                checks.real_values(f"bounds[{name!r}]'s {side}", v, "a real number or array")
                if not np.all(np.isfinite(np.asarray(v, dtype=float))):
                    raise ValueError(f"bounds[{name!r}]'s {side} must be finite, got {v!r}")
            try:
                shape = np.broadcast_shapes(np.shape(leaf), np.shape(lo), np.shape(hi))
            except ValueError:
                raise ValueError(
                    f"bounds[{name!r}]: the bounds' shapes {np.shape(lo)} and {np.shape(hi)} do "
                    f"not broadcast with the leaf's {np.shape(leaf)} (give scalars, or arrays "
                    "of the leaf's shape)"
                ) from None
            names.append(name)
            shapes.append(tuple(shape))
            lows.append(np.broadcast_to(np.asarray(lo, dtype=float), shape).ravel())
            highs.append(np.broadcast_to(np.asarray(hi, dtype=float), shape).ravel())
        return cls(template, np.concatenate(lows), np.concatenate(highs), names, shapes)

    @property
    def size(self) -> int:
        """n, the number of coordinates."""
        return int(self.lower.shape[0])

    def values(self, u: ArrayLike) -> Float[Array, " n"]:
        """The parameters (SI) at coordinate ``u``."""
        return self.lower + (self.upper - self.lower) * jax.nn.sigmoid(self._u(u))

    def profile(self, u: ArrayLike) -> ToothProfile | FreeformProfile:
        """The tooth profile at coordinate ``u`` (traceable)."""
        return profile_of(self.design(u))

    def design(self, u: ArrayLike) -> ToothProfile | FreeformProfile | SprocketDesign:
        """The design at coordinate ``u``: the template with the chosen leaves set
        (traceable); the tooth profile itself unless the template is a
        :class:`SprocketDesign`."""
        x = self.values(u)
        parts, at = [], 0
        for shape in self.shapes:
            size = math.prod(shape)
            parts.append(x[at : at + size].reshape(shape))
            at += size
        return eqx.tree_at(
            lambda p: [_get(p, n) for n in self.names], self.template, parts,
            is_leaf=lambda v: v is None,
        )  # fmt: skip

    def coordinates(self, profile: ToothProfile | ArrayLike, margin: float = 1e-6) -> Array:
        """The coordinate ``u`` of a design (a profile, or a :class:`SprocketDesign` of
        a space over one) or of the parameter values in the box; values on or beyond a
        bound are pulled ``margin`` (as a fraction of the range) inside."""
        checks.real("margin", margin, lo=0.0, hi=0.5, lo_open=True, hi_open=True)
        if isinstance(profile, AbstractProfile | SprocketDesign):
            if isinstance(profile, SprocketDesign) != isinstance(self.template, SprocketDesign):
                raise TypeError(
                    f"coordinates: this space designs a {type(self.template).__name__}; "
                    f"got a {type(profile).__name__}"
                )
            t, tooth = profile_of(self.template), profile_of(profile)
            if tooth.teeth != t.teeth or not np.allclose(
                [tooth.pitch, tooth.roller_diameter], [t.pitch, t.roller_diameter]
            ):
                raise ValueError(
                    f"coordinates: the profile ({tooth.teeth} teeth, pitch "
                    f"{float(tooth.pitch):.6g} m) is not of this design space's sprocket "
                    f"({t.teeth} teeth, pitch {float(t.pitch):.6g} m)"
                )
            x = jnp.concatenate(
                [jnp.broadcast_to(_leaf(profile, n), s).ravel()
                 for n, s in zip(self.names, self.shapes, strict=True)]
            )  # fmt: skip
        else:
            x = self._u(profile, "the parameter values")
        frac = jnp.clip((x - self.lower) / (self.upper - self.lower), margin, 1 - margin)
        return jnp.log(frac) - jnp.log1p(-frac)

    def fraction(self, u: ArrayLike) -> Float[Array, " n"]:
        """Where each parameter sits in its range (0 = lower, 1 = upper)."""
        return jax.nn.sigmoid(self._u(u))

    def _u(self, u, what: str = "u") -> Array:
        return coordinate(u, what, self.size, self.names)


def _get(obj, name: str):
    for part in name.split("."):
        obj = getattr(obj, part)
    return obj


def _leaf(profile, name: str):
    """The array leaf at dotted path ``name`` of a tooth profile, or ``ValueError``
    listing the leaves there are."""
    obj = profile
    for part in name.split("."):
        obj = None if part.startswith("_") else getattr(obj, part, None)
    if not isinstance(obj, jax.Array | np.ndarray):
        raise ValueError(
            f"{name!r} is not a leaf of this {type(profile).__name__}: use one of "
            f"{_leaf_names(profile)}"
        )
    return obj


def _is_leaf(profile, name: str) -> bool:
    try:
        _leaf(profile, name)
    except ValueError:
        return False
    return True


def _leaf_names(profile) -> list[str]:
    paths = jax.tree_util.tree_flatten_with_path(profile)[0]
    return [".".join(str(k.name) for k in path) for path, _ in paths]


def _entries(names, shapes) -> list[str]:
    """One label per coordinate: ``name`` or ``name[i, j]``."""
    out = []
    for n, s in zip(names, shapes, strict=True):
        out += [n] if s == () else [f"{n}{list(i)}" for i in np.ndindex(s)]
    return out


def coordinate(u, what: str = "u", n: int = 4, names=PARAMETERS) -> Array:
    """``u`` as a float array of shape (n,), or ``ValueError`` saying how to batch."""
    u = jnp.asarray(u)
    if u.shape != (n,):
        hint = "; for many points use jax.vmap over u" if u.shape[-1:] == (n,) else ""
        per = f"one value per parameter {names}" if n == len(names) else f"the entries of {names}"
        raise ValueError(f"{what} must have shape ({n},), {per}, got shape {u.shape}{hint}")
    if not (jnp.issubdtype(u.dtype, jnp.floating) or jnp.issubdtype(u.dtype, jnp.integer)):
        raise TypeError(f"{what} must be real, got dtype {u.dtype}")
    return u.astype(jnp.result_type(float)) if jnp.issubdtype(u.dtype, jnp.integer) else u


def _check_box_sampled(space: DesignSpace) -> None:
    """The box's corners must be valid profiles (constructing one validates it): all
    corners up to 6 coordinates, else the middle, the two extreme corners and 64 seeded
    random corners."""
    n = space.size
    if n <= 6:
        picks = np.array(list(itertools.product((0, 1), repeat=n)), dtype=float)
    else:
        rng = np.random.default_rng(0)
        picks = np.concatenate(
            [np.full((1, n), 0.5), np.zeros((1, n)), np.ones((1, n)),
             rng.integers(0, 2, (64, n)).astype(float)]
        )  # fmt: skip
    eps = 1e-9
    what = "designs" if isinstance(space.template, SprocketDesign) else "tooth profiles"
    for pick in picks:
        frac = np.clip(pick, eps, 1 - eps)
        u = np.log(frac) - np.log1p(-frac)
        try:
            d = space.design(jnp.asarray(u))
            for part in (profile_of(d), getattr(d, "cushion", None)):
                if part is not None:
                    type(part).__check_init__(part)
        except (ValueError, FloatingPointError) as e:
            corner = (
                "middle"
                if np.all(pick == 0.5)
                else ", ".join(
                    f"{lab} {'upper' if b else 'lower'}"
                    for lab, b in zip(_entries(space.names, space.shapes), pick, strict=True)
                )
            )
            if len(corner) > 300:
                corner = corner[:300] + " …"
            raise ValueError(
                f"the design box reaches outside valid {what}: at its corner ({corner}) {e}"
            ) from None


def _check_box(template: ToothProfile, lo: np.ndarray, hi: np.ndarray) -> None:
    """Every corner of the box must be a valid profile once its tip circle is lowered to
    where the flanks meet (what the traced geometry does): a box reaching outside the
    profile's own validity (a seat smaller than the roller, an angle in degrees) would
    hand the optimizer outlines that do not exist."""
    for pick in itertools.product((0, 1), repeat=4):
        vals = {n: (lo, hi)[i][k] for k, (n, i) in enumerate(zip(PARAMETERS, pick, strict=True))}
        kw = dict(
            teeth=template.teeth,
            pitch=float(template.pitch),
            roller_diameter=float(template.roller_diameter),
            **vals,
        )
        try:
            reach = flank_meeting_diameter(**kw)
            kw["tip_diameter"] = min(vals["tip_diameter"], reach * (1 - 1e-9))
            ToothProfile(**kw)
        except (ValueError, FloatingPointError) as e:
            corner = ", ".join(
                f"{n} {'upper' if i else 'lower'}" for n, i in zip(PARAMETERS, pick, strict=True)
            )
            raise ValueError(
                f"the design box reaches outside valid tooth profiles: at its corner ({corner}) {e}"
            ) from None

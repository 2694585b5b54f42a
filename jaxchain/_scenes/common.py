"""Helpers the scene builders share: chain lookup, sprocket inertia and contact slots,
argument checks, and the stretch of a chain under tension."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import numpy as np

from .. import _checks as checks
from .._chain import ChainSpec
from .._loads import AbstractLoad
from .._numerics import is_concrete
from .._profiles.base import AbstractProfile
from .._profiles.iso import ToothProfile

__all__ = [
    "disc_inertia",
    "contact_slots",
    "check_profile",
    "worn",
    "as_gravity",
]


def disc_inertia(chain: ChainSpec, profile: ToothProfile, density: float = 7850.0) -> float:
    """Polar inertia of a steel disc of the pitch diameter, 0.9·b1 thick [kg·m²]."""
    r = float(profile.pitch_radius)
    return density * math.pi * 0.9 * chain.inner_width * r**4 / 2


def contact_slots(wrap: int, n_rollers: int, profile=None) -> int | None:
    """Contact slots of a sprocket wrapped by ``wrap`` rollers: the wrap, on each side the
    span rollers that lie within the reach circle (tip radius + 1.05 roller radii: a span
    leaving the pitch circle tangentially stays within it for √(reach² − r_p²), about two
    pitches on an 18-tooth sprocket, three on a 42-tooth one), one more each side for the
    spans' vibration and the wrap's rounding; None (check all) unless that skips at least
    half the rollers: picking the nearest rollers (a sort, a gather, a scatter) costs about
    what evaluating the rest would. ``profile``: the sprocket's (None: three span rollers
    a side)."""
    side = 3
    dims = (
        None if profile is None else (profile.pitch_diameter, profile.reach_radius, profile.pitch)
    )
    if dims is not None and is_concrete(*dims):
        d, reach, p = float(np.min(dims[0])), float(np.max(dims[1])), float(dims[2])
        side = math.ceil(math.sqrt(max(reach**2 - (d / 2) ** 2, 0.0)) / p) + 1
    slots = math.ceil(wrap) + 2 * side
    return None if 2 * slots > n_rollers else slots


def check_below_strength(chain: ChainSpec, what: str, tension: float, fix: str) -> None:
    """A static tension must stay below the chain's tensile strength (the ISO 606 minimum):
    beyond it the chain breaks, and its joints' stiffness law has no meaning."""
    if tension >= chain.tensile_strength:
        raise ValueError(
            f"{what} is {tension:.4g} N, at or above the chain's tensile strength "
            f"{chain.tensile_strength:.4g} N (ISO 606 minimum; a real chain breaks): {fix}"
        )


def check_profile(chain: ChainSpec, profile: ToothProfile, what: str = "profile") -> None:
    """A tooth profile must be cut for this chain: the same pitch and roller diameter (a
    profile of another chain puts rollers into the teeth: forces of hundreds of kN)."""
    for name in ("pitch", "roller_diameter"):
        have, want = float(np.asarray(getattr(profile, name))), float(getattr(chain, name))
        if not abs(have - want) <= 1e-6 * want:  # float32 profiles round to ~1e-7
            raise ValueError(
                f"{what} has {name} {have * 1e3:.4g} mm but chain {chain.name} has "
                f"{want * 1e3:.4g} mm: build the profile for this chain, e.g. "
                f"ToothProfile.iso606(chain, teeth, form)"
            )


def worn(chain: ChainSpec, elongation: float) -> ChainSpec:
    """``chain`` with its pitch worn longer by the fraction ``elongation`` (wear of the
    pins and bushes lengthens every link; the rest of the chain is unchanged)."""
    if elongation == 0.0:
        return chain
    return dataclasses.replace(chain, pitch=chain.pitch * (1.0 + elongation))


def as_gravity(gravity) -> np.ndarray | None:
    """``gravity`` checked: None (none), a scalar g [m/s²] ≥ 0 pointing along −y, or a
    vector (gx, gy) [m/s²]; returns None or (2,)."""
    if gravity is None:
        return None
    g = np.asarray(gravity, dtype=float) if not isinstance(gravity, (str, bytes)) else None
    if g is None or g.shape not in ((), (2,)) or not np.all(np.isfinite(g)):
        raise ValueError(
            f"gravity must be None, a scalar g >= 0 m/s² (pointing along −y) or a finite "
            f"vector (gx, gy) [m/s²], got {gravity!r}"
        )
    if g.shape == ():
        if g < 0:
            raise ValueError(f"gravity as a scalar must be >= 0 m/s² (along −y), got {float(g)}")
        return np.array([0.0, -float(g)])
    return g


def as_load(name: str, value, speed: float) -> tuple[AbstractLoad | float, float]:
    """A builder's ``load_torque`` for one driven sprocket turning at ``speed`` [rad/s] in
    its running direction: (what its :class:`Sprocket` takes, the torque the statics hold
    at the start [N·m]). A number must be finite and ≥ 0; a load's start value finite."""
    if isinstance(value, AbstractLoad):
        held = float(value.torque(0.0, 0.0, speed))
        if not math.isfinite(held):
            raise ValueError(f"{name}: the load's torque at the start is {held}; it must be finite")
        return value, held
    value = checks.real(name, value, lo=0.0, unit="N·m (or a jc.loads load)")
    return value, value


def per_driven(name: str, value, n: int) -> list[tuple[str, object]]:
    """(name, value) for each of the ``n`` driven sprockets: one value for every one, or a
    sequence of one per driven sprocket (its length checked; names indexed)."""
    if isinstance(value, Sequence | np.ndarray) and not isinstance(value, (str, bytes)):
        if len(value) != n:
            raise ValueError(
                f"{name} must be one value for every driven sprocket or one per driven "
                f"sprocket ({n} for {n + 1} sprockets), got {len(value)}: {tuple(value)!r}"
            )
        return [(f"{name}[{k}]", v) for k, v in enumerate(value)]
    return [(name, value)] * n


def as_loads(name: str, value, speeds) -> tuple[tuple, tuple[float, ...]]:
    """``load_torque`` for the driven sprockets turning at ``speeds`` [rad/s]: one number or
    load for every one, or one per driven sprocket. (loads, torques held at the start)."""
    given = zip(per_driven(name, value, len(speeds)), speeds, strict=True)
    pairs = [as_load(label, v, w) for (label, v), w in given]
    return tuple(p[0] for p in pairs), tuple(p[1] for p in pairs)


def check_load_ramp(loads, load_ramp) -> None:
    """``load_ramp`` ramps numbers in; a load object carries its own time dependence."""
    if load_ramp and any(isinstance(v, AbstractLoad) for v in loads):
        raise ValueError(
            "load_ramp applies to a number load_torque; a jc.loads load carries its own time "
            "dependence (jc.loads.Ramped(value, duration) ramps one in): leave load_ramp out"
        )


def as_profiles(chain: ChainSpec, profiles, teeth: tuple[int, ...], form: str) -> tuple:
    """One tooth profile per sprocket, checked: any kind, cut for ``chain``, with the
    sprockets' ``teeth``; None: ISO 606 profiles of ``form``."""
    n = len(teeth)
    if profiles is None:
        profiles = tuple(ToothProfile.iso606(chain, z, form) for z in teeth)
    what = "tooth profiles (driver, driven)" if n == 2 else "tooth profiles, one per sprocket"
    profiles = checks.pair("profiles", profiles, n, what)
    for k, p in enumerate(profiles):
        checks.instance(
            f"profiles[{k}]", p, AbstractProfile,
            "a tooth profile (jc.ToothProfile, jc.FreeformProfile, any jc.AbstractProfile)",
        )  # fmt: skip
        check_profile(chain, p, f"profiles[{k}]")
    got = tuple(p.teeth for p in profiles)
    if got != tuple(teeth):
        shown = "/".join(map(str, got)) if n == 2 else str(got)
        raise ValueError(f"profiles have {shown} teeth, teeth={teeth}")
    return tuple(profiles)


def sprocket_inertias(chain: ChainSpec, profiles, driven_inertia) -> tuple[float, ...]:
    """Every sprocket's moment of inertia [kg·m²]: the driver's a steel disc of its pitch
    diameter; the driven ones' ``driven_inertia`` (one value for every one, or one per
    driven sprocket, each > 0), or steel discs when None."""
    if driven_inertia is None:
        return tuple(disc_inertia(chain, p) for p in profiles)
    given = [
        checks.real(label, v, lo=0.0, lo_open=True, unit="kg·m²")
        for label, v in per_driven("driven_inertia", driven_inertia, len(profiles) - 1)
    ]
    return (disc_inertia(chain, profiles[0]), *given)

"""A closed chain over several sprockets: the loop branch of :func:`~jaxchain.scenes.drive`
(arguments shared with the two-sprocket drive are checked there)."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from .. import _checks as checks
from .._chain import ChainSpec
from .._contact.base import AbstractContactLaw
from .._contact.friction import CoulombFriction
from .._freeform import FreeformProfile
from .._profile import MAX_TEETH, ToothProfile
from .._scene import Scene, Sprocket
from .build import assemble, chain_bodies, roller_law
from .common import (
    check_below_strength,
    check_profile,
    contact_slots,
    disc_inertia,
    stretch_of,
)
from .layout import transport_velocity
from .loop import _as_centres, loop_layout
from .statics import equilibrate

__all__ = ["loop_drive", "span_tensions"]


def _per_driven(name: str, value, n: int, unit: str, *, lo_open: bool) -> tuple[float, ...]:
    """A scalar for every driven sprocket, or one value per driven sprocket (n of them)."""
    if isinstance(value, Sequence | np.ndarray) and not isinstance(value, (str, bytes)):
        if len(value) != n:
            raise ValueError(
                f"{name} must be one value for every driven sprocket or one per driven "
                f"sprocket ({n} for {n + 1} sprockets), got {len(value)}: {tuple(value)!r}"
            )
        return tuple(
            checks.real(f"{name}[{k}]", v, lo=0.0, lo_open=lo_open, unit=unit)
            for k, v in enumerate(value)
        )
    return (checks.real(name, value, lo=0.0, lo_open=lo_open, unit=unit),) * n


def span_tensions(
    loads: Sequence[float], radii: Sequence[float], pretension: float, take_up: int
) -> np.ndarray:
    """(N,) static tensions [N] of spans 0 … N − 1 of a loop (span j from sprocket j to
    j + 1): each driven sprocket k takes load_k/R_k out of the tension, T_k − T_{k−1} =
    load_k/R_k, and the take-up sprocket m's two spans share 2·pretension, T_{m−1} + T_m =
    2·pretension. ``loads``, ``radii``: (N,) with the driver's entries unused."""
    steps = np.concatenate([[0.0], np.cumsum(np.asarray(loads[1:]) / np.asarray(radii[1:]))])
    t0 = pretension - 0.5 * (steps[take_up - 1] + steps[take_up])
    return t0 + steps


def loop_drive(
    chain: ChainSpec,
    teeth,
    centres,
    *,
    outside: Sequence[int],
    take_up_sprocket: int | None,
    n_links: int | None,
    speed_rpm: float,
    load_torque,
    pretension: float,
    fidelity: str,
    form: str,
    profiles,
    restitution: float,
    friction: CoulombFriction | None,
    joint_friction: CoulombFriction | None,
    driven_inertia,
    load_ramp: float | None,
    impact_speed: float,
    rollers_on_bush: str,
    roller_contact: AbstractContactLaw | None,
    settle: bool,
    link_damping: float,
) -> Scene:
    """The drive over N sprockets (see :func:`~jaxchain.scenes.drive`)."""
    if isinstance(teeth, (str, bytes)) or not isinstance(teeth, Sequence | np.ndarray):
        raise TypeError(f"teeth must be a sequence of tooth counts, got {teeth!r}")
    n = len(teeth)
    if n < 2:
        raise ValueError(f"teeth must hold at least 2 tooth counts (driver first), got {n}")
    teeth = tuple(checks.integer(f"teeth[{k}]", z, lo=7, hi=MAX_TEETH) for k, z in enumerate(teeth))
    centres = _as_centres(centres, n)
    loads = (0.0, *_per_driven("load_torque", load_torque, n - 1, "N·m", lo_open=False))
    pretension = checks.real("pretension", pretension, lo=0.0, unit="N")
    if load_ramp is not None:
        load_ramp = checks.real("load_ramp", load_ramp, lo=0.0, unit="s")
    if profiles is None:
        profiles = tuple(ToothProfile.iso606(chain, z, form) for z in teeth)
    profiles = checks.pair("profiles", profiles, n, "tooth profiles, one per sprocket")
    for k, p in enumerate(profiles):
        checks.instance(
            f"profiles[{k}]", p, (ToothProfile, FreeformProfile),
            "a jc.ToothProfile or jc.FreeformProfile",
        )  # fmt: skip
        check_profile(chain, p, f"profiles[{k}]")
    if tuple(p.teeth for p in profiles) != teeth:
        raise ValueError(f"profiles have {tuple(p.teeth for p in profiles)} teeth, teeth={teeth}")
    radii = [float(p.pitch_radius) for p in profiles]
    m = n - 1 if take_up_sprocket is None else take_up_sprocket
    m = checks.integer("take_up_sprocket", m, lo=1, hi=n - 1)
    tension = span_tensions(loads, radii, pretension, m)
    check_below_strength(
        chain,
        "the tight span's static tension",
        float(tension.max()),
        "lower load_torque or pretension, or choose a larger chain",
    )
    if settle and tension.min() < 0:
        need = pretension - float(tension.min())
        raise ValueError(
            f"no static equilibrium: the take-up sprocket {m}'s spans share 2·pretension = "
            f"{2 * pretension:.4g} N, and the loads (Σ load_k/R_k = "
            f"{float(tension[-1] - tension[0]):.4g} N between the tight and the slack span) "
            f"would leave span {int(np.argmin(tension))} pushing with "
            f"{-float(tension.min()):.4g} N; use pretension >= {need:.4g} N, a smaller "
            "load_torque, a take-up on the slack side (take_up_sprocket=1), or settle=False "
            "(start from the layout, load ramped in)"
        )
    stretch = stretch_of(chain, fidelity, pretension)
    lay = loop_layout(
        chain.pitch,
        teeth,
        centres,
        outside,
        n_links=n_links,
        link_pitch=chain.pitch + stretch,
        take_up_sprocket=m,
        tip_radii=[float(p.tip_diameter) / 2 for p in profiles],
        roller_radius=chain.roller_diameter / 2,
    )
    if driven_inertia is None:
        inertias = tuple(disc_inertia(chain, p) for p in profiles)
    else:
        given = _per_driven("driven_inertia", driven_inertia, n - 1, "kg·m²", lo_open=True)
        inertias = (disc_inertia(chain, profiles[0]), *given)
    omega1 = speed_rpm * 2 * math.pi / 60
    bodies = chain_bodies(
        chain,
        lay.rollers,
        transport_velocity(lay, omega1),
        closed=True,
        fidelity=fidelity,
        restitution=restitution,
        rollers_on_bush=rollers_on_bush,
        damping_ratio=link_damping,
        joint_friction=joint_friction,
        link_load=float(tension.max()),
    )
    if load_ramp is None:  # a settled start carries the full load already
        load_ramp = 0.0 if settle else 2 * math.pi / omega1
    sprockets = tuple(
        Sprocket(
            profiles[k],
            lay.centres[k],
            omega1 * teeth[0] / teeth[k] * int(lay.sense[k]),
            inertia=inertias[k],
            load_torque=loads[k] * int(lay.sense[k]),  # opposes the sprocket's own turning
            angle0=lay.theta[k],
            load_ramp=load_ramp if k else 0.0,
            driven=k > 0,
            contact_slots=contact_slots(lay.wrap[k], lay.n_links),
            take_up_vector=lay.take_up_vector if k == m else np.zeros(2),
        )
        for k in range(n)
    )
    scene = assemble(
        bodies,
        sprockets=sprockets,
        anchors=None,
        roller_contact=roller_contact or roller_law(chain, restitution),
        friction=friction,
        impact_speed=impact_speed,
        fidelity=fidelity,
        tensile_strength=chain.tensile_strength,
    )
    return equilibrate(scene, take_up=2 * pretension) if settle else scene

"""What the fidelities build chains from and the builders assemble scenes with: the
contact laws of the teeth and joints (:func:`roller_law`, :func:`joint_law`), the link
stiffness, the default friction laws, the chain's bodies (:class:`ChainBodies`, made by a
fidelity, :mod:`.fidelity`) and :func:`assemble`, which puts bodies, sprockets and
elements into a :class:`~jaxchain.Scene`."""

from __future__ import annotations

import math
from typing import Literal, NamedTuple

import jax.numpy as jnp
import numpy as np

from .. import _checks as checks
from .._chain import ChainSpec, as_chain
from .._contact.base import AbstractContactLaw
from .._contact.dahl import DahlFriction
from .._contact.friction import CoulombFriction
from .._contact.friction_base import AbstractFrictionLaw
from .._contact.johnson import JohnsonCylinder
from .._elements.anchors import Anchors
from .._elements.gravity import Gravity
from .._elements.joint_friction import JointFriction
from .._elements.pairs import ClearanceJoints, PairGroup
from .._elements.rollers import RollerTeeth
from .._elements.shoes import Shoes
from .._elements.tensioners import Tensioners
from .._materials import STEEL, Material, effective_modulus
from .._scene import Scene, Sprocket

__all__ = [
    "assemble",
    "ChainBodies",
    "joint_law",
    "roller_law",
    "link_stiffness",
    "JOINT_FRICTION",
    "CLEARANCE_JOINT_FRICTION",
    "rollers_on_bush_of",
    "BUSH_TOOTH_FRICTION",
    "default_tooth_friction",
]

#: Friction in the chain's joints (pin/bush, bush/roller): lubricated steel on steel,
#: μ = 0.1 (boundary lubrication of hardened steel, 0.05–0.15), regularized over a
#: sliding speed of 2 mm/s at the pin's surface (a joint articulating at 1 rad/s slides
#: at about 2 mm/s; the moment reaches 76 % of μ·N·r there).
JOINT_FRICTION = CoulombFriction(coefficient=0.1, slip_velocity=2e-3)

#: The same friction in the clearance chain's joint contacts (pin/bush, bush/roller), with
#: a pre-sliding state (Dahl): μ = 0.1, pre-sliding displacement 5 µm at the contact. A
#: velocity-regularized law there acts on a roller of about a gram as a damper of time
#: constant ~15 ns (m·v_s/(μ·N) at 1 kN), which alone would set an explicit solver's step;
#: the pre-sliding state bounds that stiffness by the length x_s instead
#: (``benchmarks/joint_friction.py``).
CLEARANCE_JOINT_FRICTION = DahlFriction(
    coefficient=0.1, presliding=5e-6, creep_velocity=1e-4, damping=5e-6
)


#: Friction of a bush chain's bush sliding on the tooth (``friction="default"``):
#: lubricated steel, μ = 0.1, with the joints' pre-sliding state (5 µm), so that the
#: design loop's fixed steps stay stable (a velocity-regularized law there damps the
#: link's rotation in microseconds). A roller chain's roller rolls: no default friction.
BUSH_TOOTH_FRICTION = DahlFriction(
    coefficient=0.1, presliding=5e-6, creep_velocity=1e-4, damping=5e-6
)


def default_tooth_friction(bush_chain: bool) -> AbstractFrictionLaw | None:
    """The tooth friction a builder uses by default (``friction="default"``):
    :data:`BUSH_TOOTH_FRICTION` for a bush chain, None (frictionless) for a roller
    chain."""
    return BUSH_TOOTH_FRICTION if bush_chain else None


class ChainBodies(NamedTuple):
    mass: np.ndarray
    inertia: np.ndarray
    pairs: tuple[PairGroup, ...]
    roller_body: np.ndarray
    roller_offset: np.ndarray
    q0: np.ndarray
    v0: np.ndarray
    link_weights: np.ndarray
    joint_friction: JointFriction | None = None
    #: (R, 2) a bush chain's two bushes (roller indices) of the inner link each bush is
    #: part of; None for a roller chain (``Scene.bush_link``)
    bush_link: np.ndarray | None = None


def joint_law(
    chain: ChainSpec,
    which: Literal["pin", "roller"],
    restitution: float,
    material: Material = STEEL,
    *,
    width: float | None = None,
) -> JohnsonCylinder:
    """Johnson's conformal law for the pin/bush (``"pin"``) or bush/roller pair;
    ``width``: its contact-onset regularization half-width [m] (default the law's)."""
    chain = as_chain(chain)
    checks.choice("which", which, ("pin", "roller"))
    estar = effective_modulus(material, material)
    clearance = chain.pin_clearance if which == "pin" else chain.roller_clearance
    length = _length(chain, which)
    return JohnsonCylinder(
        clearance=jnp.asarray(clearance),
        length=jnp.asarray(length),
        modulus=jnp.asarray(estar),
        restitution=jnp.asarray(restitution),
        **_width(width),
    )


def _width(width: float | None) -> dict:
    if width is None:
        return {}
    width = checks.real("width", width, lo=0.0, unit="m (the contact-onset half-width)")
    return {"width": jnp.asarray(width, dtype=float)}


def roller_law(
    chain: ChainSpec,
    restitution: float,
    material: Material = STEEL,
    *,
    width: float | None = None,
) -> JohnsonCylinder:
    """Default roller/tooth law: Johnson's cylinder law with a fixed effective clearance,
    the ISO 606 mid seat clearance of this chain (0.005·d1 + 0.0345·∛d1, independent of
    z and of the profile being designed, so the law never changes with the design). In a
    bush chain d1 is the bush's diameter; the contact length 0.95·b1 is then about the
    tooth's face width (ISO 606: 0.93·b1 up to p = 12.7 mm), which bounds it there too.

    One law over the whole outline keeps the force continuous across the seat/flank
    junction. Johnson's internal law is exact for the (conformal) seat; for the convex
    flank the line-contact approach has the same F·[ln(C/F) − 1] form (Johnson §5.6) with
    a different constant C, so the error there is logarithmic, not a stiffness that
    swings with the clearance as Hertz δ^1.5 with R* = r·ri/(ri − r) would.

    ``width``: the contact-onset regularization half-width [m] (default the law's 10 nm;
    a design model may resolve the onset over a few µm, see ``python -m optimize``).
    """
    chain = as_chain(chain)
    d1 = chain.roller_diameter
    clearance = 0.005 * d1 + 0.0345e-3 * (1e3 * d1) ** (1 / 3)
    return JohnsonCylinder(
        clearance=jnp.asarray(clearance),
        length=jnp.asarray(0.95 * chain.inner_width),
        modulus=jnp.asarray(effective_modulus(material, material)),
        restitution=jnp.asarray(restitution),
        **_width(width),
    )


def link_stiffness(chain: ChainSpec, load: float, material: Material = STEEL) -> float:
    """Axial stiffness of one lumped link [N/m]: its plates in series with two pin/bush
    contacts (Johnson's tangent stiffness at ``load``, taken ≥ 5 % of the tensile
    strength so a slack chain is not modelled as infinitely soft)."""
    e = material.youngs_modulus
    hole = chain.bush_diameter
    k_plates = e * 2 * chain.plate_thickness * (chain.plate_height - hole) / chain.pitch
    law = joint_law(chain, "pin", 1.0, material)
    k_joint = float(law.tangent_stiffness(max(load, 0.05 * chain.tensile_strength)))
    return 1.0 / (1.0 / k_plates + 2.0 / k_joint)


def _link_frames(rollers: np.ndarray, vel: np.ndarray, closed: bool):
    nxt = np.roll(rollers, -1, axis=0) if closed else rollers[1:]
    nxv = np.roll(vel, -1, axis=0) if closed else vel[1:]
    cur, cuv = (rollers, vel) if closed else (rollers[:-1], vel[:-1])
    d = nxt - cur
    mid = 0.5 * (cur + nxt)
    phi = np.arctan2(d[:, 1], d[:, 0])
    vmid = 0.5 * (cuv + nxv)
    dv = nxv - cuv
    omega = (d[:, 0] * dv[:, 1] - d[:, 1] * dv[:, 0]) / np.sum(d * d, axis=1)
    return np.column_stack([mid, phi]), np.column_stack([vmid, omega])


def _tension_weights(n_links: int, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    w = np.zeros((n_links, len(a)))
    for e, (i, j) in enumerate(zip(a, b, strict=True)):
        w[i, e] += 1.0
        w[j, e] += 1.0
    return w / np.maximum(w.sum(axis=1, keepdims=True), 1.0)


def rollers_on_bush_of(chain: ChainSpec, rollers_on_bush: str | None) -> str:
    """The clearance chain's roller model for ``chain``: ``rollers_on_bush`` as given, or
    the chain's own for None (a roller chain's ``"joint"``; a bush chain's ``"lumped"``,
    its bush part of its link, with no roller mass to add). A bush chain has no roller to
    put on a joint: ``"joint"`` is refused."""
    if rollers_on_bush is None:
        return "joint" if chain.has_roller else "lumped"
    checks.choice("rollers_on_bush", rollers_on_bush, ("joint", "lumped"))
    if rollers_on_bush == "joint" and not chain.has_roller:
        raise ValueError(
            f"rollers_on_bush='joint': chain {chain.name} is a bush chain (no roller; its bush, "
            "part of the inner link, engages the teeth), so there is no roller to put on a "
            "bush/roller joint; leave rollers_on_bush out (None: the chain's own model) or "
            "give a roller chain"
        )
    return rollers_on_bush


def _bush_link(n: int, closed: bool) -> np.ndarray:
    """(n, 2) the two bushes of each bush's inner link: bushes 2k and 2k + 1 share one
    (the clearance chain's roller links are the even links); an odd last bush of a closed
    loop shares one with bush 0, of an open strand with the bush before it."""
    i = np.arange(n)
    a = i - i % 2
    b = a + 1
    last = b >= n
    if closed:
        b = np.where(last, 0, b)
    else:
        a, b = np.where(last, a - 1, a), np.where(last, a, b)
    return np.column_stack([a, b])


def _lumped_joint_friction(
    chain: ChainSpec, n: int, closed: bool, law: AbstractFrictionLaw | None
) -> JointFriction | None:
    """Joint friction of a lumped chain of ``n`` rollers: a joint at every roller between
    two links (link e runs from roller e to roller e + 1)."""
    if law is None:
        return None
    joint = np.arange(n) if closed else np.arange(1, n - 1)
    return JointFriction(
        before=jnp.asarray((joint - 1) % n),
        joint=jnp.asarray(joint),
        after=jnp.asarray((joint + 1) % n),
        link_before=jnp.asarray((joint - 1) % n),
        link_after=jnp.asarray(joint),
        law=law,
        pin_radius=jnp.asarray(chain.pin_diameter / 2),
        load_width=jnp.asarray(1e-3 * chain.tensile_strength),
    )


def _clearance(
    law: AbstractContactLaw, radius: float, friction, film=None, length: float = 0.0
) -> ClearanceJoints:
    return ClearanceJoints(
        law=law,
        clearance=law.clearance,
        friction=friction,
        radius=jnp.asarray(radius),
        film=film,
        length=jnp.asarray(length),
    )


def _length(chain: ChainSpec, which: Literal["pin", "roller"]) -> float:
    """Axial length of the pin/bush (the bush, between the outer plates) or bush/roller
    (the roller, 95 % of the inner width) contact [m]."""
    if which == "pin":
        return chain.inner_width + 2 * chain.plate_thickness
    return 0.95 * chain.inner_width


def assemble(
    bodies: ChainBodies,
    *,
    sprockets: tuple[Sprocket, ...],
    anchors: Anchors | None,
    roller_contact: AbstractContactLaw,
    friction: AbstractFrictionLaw | str | None,
    impact_speed: float,
    fidelity,
    tensile_strength: float,
    horizon: float = math.inf,
    gravity=None,
    tensioners: Tensioners | None = None,
    shoes: Shoes | None = None,
) -> Scene:
    """A :class:`Scene` from chain bodies, sprockets and boundary conditions; ``gravity``:
    (2,) [m/s²] (None: none); ``friction="default"``: :func:`default_tooth_friction`."""
    if isinstance(friction, str):
        friction = default_tooth_friction(bodies.bush_link is not None)
    g = jnp.zeros(2) if gravity is None else jnp.asarray(gravity, dtype=float)
    elements = (
        *bodies.pairs, bodies.joint_friction, anchors, RollerTeeth(roller_contact, friction),
        shoes, tensioners, Gravity(g),
    )  # fmt: skip
    return Scene(
        mass=jnp.asarray(bodies.mass),
        inertia=jnp.asarray(bodies.inertia),
        roller_body=jnp.asarray(bodies.roller_body),
        roller_offset=jnp.asarray(bodies.roller_offset),
        sprockets=sprockets,
        impact_speed=jnp.asarray(impact_speed, dtype=float),
        q0=jnp.asarray(bodies.q0),
        v0=jnp.asarray(bodies.v0),
        link_weights=jnp.asarray(bodies.link_weights),
        horizon=jnp.asarray(horizon, dtype=float),
        tensile_strength=jnp.asarray(tensile_strength, dtype=float),
        fidelity=str(fidelity),  # its name (a fidelity object or the name itself)
        elements=elements,
        bush_link=None if bodies.bush_link is None else jnp.asarray(bodies.bush_link),
    )

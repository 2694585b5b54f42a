"""The fidelity of a chain: how a scene builder models its links, rollers and joints.

A fidelity is an object (:class:`Lumped`, :class:`Clearance`, :class:`SpanLevel`) that the
builders ask what they need of it: the chain's bodies and joints for a layout of roller
centres (:meth:`AbstractFidelity.bodies`), the stretch its links take under a tension
(for the layout), the joint friction it uses by default, and which chain-model fields it
can use (:meth:`AbstractFidelity.check`). Every builder takes a fidelity as the object
or by its name (``fidelity="clearance"``); :func:`as_fidelity` turns a name into the
object, and a fidelity compares equal to its name.

``Lumped()``: each roller is a point mass carrying half of each adjacent link, joined to
its neighbours by elastic links (spring-dampers of rest length p).

``Clearance()``: the source paper's model. Rigid roller links (inner plates + bushes) and
pin links (outer plates + pins), 3 DOF each, alternate along the chain; every articulation
is a pin/bush revolute clearance joint, and each roller is a body of its own on its bush,
held by a second (bush/roller) clearance joint. Both joints use Johnson's conformal law.
With ``rollers_on_bush="lumped"`` the roller is fixed to its bush instead (its mass and
inertia added to the roller link): the cheaper variant, compared in ``benchmarks/``.

``SpanLevel()``: no rollers, links or joints; the free spans as axial springs between the
sprockets' pitch curves (:class:`jc.elements.Spans <jaxchain.elements.Spans>`), a
fidelity of closed drives only.

A bush chain (``ChainSpec.kind == "bush"``) has no roller: its bushes, part of the inner
(roller) links, engage the teeth. The clearance chain is then the source paper's bushing
chain, pin links and bushing links joined by pin/bush clearance joints only, each bush's
circle (d1) in the tooth contact; the lumped chain's points are the bushes, their angle
unused. Either way a bush turns with its inner link (``ChainBodies.bush_link``), so it
slides on the tooth where a roller would roll (:mod:`jaxchain._elements.rollers`).
"""

from __future__ import annotations

import math
from typing import ClassVar, Literal

import jax.numpy as jnp
import numpy as np

from .. import _checks as checks
from .._chain import ChainSpec
from .._contact.base import AbstractContactLaw
from .._contact.film_base import AbstractFilmLaw
from .._contact.friction_base import AbstractFrictionLaw
from .._elements.pairs import LinkSprings, PairGroup
from .build import (
    CLEARANCE_JOINT_FRICTION,
    JOINT_FRICTION,
    ChainBodies,
    _bush_link,
    _clearance,
    _length,
    _link_frames,
    _lumped_joint_friction,
    _tension_weights,
    joint_law,
    link_stiffness,
    rollers_on_bush_of,
)
from .model import _DEFAULTS, ChainModel, _is_default

__all__ = [
    "AbstractFidelity",
    "Lumped",
    "Clearance",
    "SpanLevel",
    "FIDELITIES",
    "as_fidelity",
    "chain_bodies",
    "default_joint_friction",
]


class AbstractFidelity:
    """How a builder models the chain (see the module's docstring). Compares equal to its
    :attr:`name`, so ``scene_fidelity == "clearance"`` reads as before."""

    #: the name builders take for it (``fidelity="lumped"``)
    name: ClassVar[str]
    #: whether the chain has rollers and links (a meshing strand, contacts with teeth)
    has_links: ClassVar[bool] = True

    def __eq__(self, other) -> bool:
        if isinstance(other, str):
            return other == self.name
        return type(other) is type(self)

    def __hash__(self) -> int:
        return hash(self.name)

    def __repr__(self) -> str:
        return f"{type(self).__name__}()"

    def __str__(self) -> str:
        return self.name

    def joint_friction(self) -> AbstractFrictionLaw:
        """The friction in the joints a builder uses by default (``"default"``)."""
        return JOINT_FRICTION

    def stretch(self, chain: ChainSpec, tension: float) -> float:
        """Roller spacing minus pitch of the chain under ``tension`` [m] (the layout's)."""
        return tension / link_stiffness(chain, tension)

    def check(self, model: ChainModel) -> None:
        """Refuse what of ``model`` this fidelity cannot model (default: an oil film,
        which needs clearance joints)."""
        if model.lubrication is not None:
            raise ValueError(
                f"lubrication: an oil film acts in the pin/bush and bush/roller clearance "
                f"joints of fidelity='clearance'; fidelity={self.name!r} has no clearance "
                "joints (use fidelity='clearance', or lubrication=None)"
            )

    def even_rollers(self, n: int) -> int:
        """The roller count a strand of ``n`` rollers is built with (the clearance chain
        alternates roller and pin links: an even count)."""
        return n

    def bodies(
        self,
        chain: ChainSpec,
        rollers: np.ndarray,
        velocities: np.ndarray,
        *,
        closed: bool,
        restitution: float,
        rollers_on_bush: Literal["joint", "lumped"],
        link_load: float,
        damping_ratio: float,
        pin_law: AbstractContactLaw | None,
        bush_law: AbstractContactLaw | None,
        joint_friction: AbstractFrictionLaw | None,
        lubrication: AbstractFilmLaw | None,
    ) -> ChainBodies:
        """Bodies and force elements of a chain whose roller centres are ``rollers`` (n, 2),
        ordered along the chain, moving at ``velocities`` (n, 2) (see
        :func:`chain_bodies`)."""
        raise ValueError(
            f"fidelity={self.name!r} has no rollers, links or joints to build; use "
            "fidelity='lumped' or 'clearance'"
        )


class Lumped(AbstractFidelity):
    """Rollers as point masses on elastic links (the fast fidelity, for design)."""

    name = "lumped"

    def bodies(self, chain, rollers, velocities, *, closed, link_load, damping_ratio,
               joint_friction, **unused) -> ChainBodies:  # fmt: skip
        return _lumped_bodies(
            chain, rollers, velocities, closed=closed, link_load=link_load,
            damping_ratio=damping_ratio, joint_friction=joint_friction,
        )  # fmt: skip


class Clearance(AbstractFidelity):
    """Rigid links on pin/bush clearance joints, each roller on its own bush/roller joint
    (the source paper's model)."""

    name = "clearance"

    def joint_friction(self) -> AbstractFrictionLaw:
        return CLEARANCE_JOINT_FRICTION

    def stretch(self, chain: ChainSpec, tension: float) -> float:
        law = joint_law(chain, "pin", 1.0)
        # mean of p (roller links) and p + 2·eccentricity (pin links)
        return float(law.clearance) + float(law.deflection(tension))

    def check(self, model: ChainModel) -> None:
        pass  # an oil film acts in its joints

    def even_rollers(self, n: int) -> int:
        return n + n % 2

    def bodies(self, chain, rollers, velocities, *, closed, restitution, rollers_on_bush,
               pin_law, bush_law, joint_friction, lubrication, **unused):  # fmt: skip
        return _clearance_bodies(
            chain, rollers, velocities, closed=closed, restitution=restitution,
            rollers_on_bush=rollers_on_bush, pin_law=pin_law, bush_law=bush_law,
            joint_friction=joint_friction, lubrication=lubrication,
        )  # fmt: skip


#: what the span-level chain has no use for: chain-model fields left at their defaults
_NOT_SPANS = (
    "restitution", "friction", "joint_friction", "impact_speed", "rollers_on_bush",
    "roller_contact", "settle", "shoe_contact",
)  # fmt: skip


class SpanLevel(AbstractFidelity):
    """No rollers: the free spans as axial springs between the sprockets' pitch curves,
    for a drive's tensions and speeds over many revolutions (closed drives only)."""

    name = "spans"
    has_links = False

    def check(self, model: ChainModel) -> None:
        super().check(model)
        given = [n for n in _NOT_SPANS if not _is_default(getattr(model, n), _DEFAULTS[n])]
        if given:
            raise ValueError(
                f"fidelity='spans' has no rollers, links or joints and does not use "
                f"{', '.join(given)} (its spans are axial springs between the sprockets' "
                "pitch curves, its start always settled, its shoes frictionless circles): "
                "leave them at their defaults, or use fidelity='lumped' or 'clearance'"
            )
        if model.cushion is not None:
            raise ValueError(
                "cushion: fidelity='spans' has no links for a cushion ring's plates to press "
                "on; use fidelity='lumped' or 'clearance' with cushion rings (or cushion=None)"
            )


#: the fidelities by name
FIDELITIES: dict[str, AbstractFidelity] = {f.name: f for f in (Lumped(), Clearance(), SpanLevel())}


def as_fidelity(fidelity: str | AbstractFidelity) -> AbstractFidelity:
    """``fidelity`` as the object: given so, or by its name (``"lumped"``,
    ``"clearance"``, ``"spans"``)."""
    if isinstance(fidelity, AbstractFidelity):
        return fidelity
    if isinstance(fidelity, str):
        return FIDELITIES[checks.choice("fidelity", fidelity, tuple(FIDELITIES))]
    raise TypeError(
        f"fidelity must be one of {', '.join(map(repr, FIDELITIES))} or a fidelity "
        f"(jc.scenes.Lumped(), Clearance(), SpanLevel()), got {fidelity!r}"
    )


def default_joint_friction(fidelity: str | AbstractFidelity) -> AbstractFrictionLaw:
    """The joint friction a builder uses by default (``joint_friction="default"``):
    :data:`~jaxchain.scenes.JOINT_FRICTION` in the lumped chain,
    :data:`~jaxchain.scenes.CLEARANCE_JOINT_FRICTION` in the clearance chain."""
    return as_fidelity(fidelity).joint_friction()


def chain_bodies(
    chain: ChainSpec,
    rollers: np.ndarray,
    velocities: np.ndarray,
    *,
    closed: bool,
    fidelity: str | AbstractFidelity,
    restitution: float,
    rollers_on_bush: Literal["joint", "lumped"] | None = None,
    link_load: float = 0.0,
    damping_ratio: float = 0.05,
    pin_law: AbstractContactLaw | None = None,
    bush_law: AbstractContactLaw | None = None,
    joint_friction: AbstractFrictionLaw | str | None = None,
    lubrication: AbstractFilmLaw | None = None,
) -> ChainBodies:
    """Bodies and force elements of a chain whose roller centres are ``rollers`` (n, 2),
    ordered along the chain, moving at ``velocities`` (n, 2), modelled by ``fidelity``.
    See the module docstring.

    ``rollers_on_bush``: the clearance chain's roller on its own clearance joint
    (``"joint"``) or fixed to its bush (``"lumped"``); None: the chain's own model
    (:func:`rollers_on_bush_of`: a roller chain's ``"joint"``, a bush chain's bush in its
    link).

    ``joint_friction``: friction in the joints (None: frictionless joints; ``"default"``:
    the fidelity's :meth:`~AbstractFidelity.joint_friction`). The lumped chain carries it as
    a friction moment between consecutive links (:class:`~jaxchain._scene.JointFriction`,
    pin radius d2/2); the clearance chain at the contacts of its pin/bush and bush/roller
    joints. ``lubrication``: an oil film in the clearance chain's joints (None: dry), over
    the length of each joint's contact (:func:`joint_law`)."""
    fidelity = as_fidelity(fidelity)
    if isinstance(joint_friction, str):
        joint_friction = fidelity.joint_friction()
    return fidelity.bodies(
        chain, rollers, velocities, closed=closed, restitution=restitution,
        rollers_on_bush=rollers_on_bush_of(chain, rollers_on_bush), link_load=link_load,
        damping_ratio=damping_ratio, pin_law=pin_law, bush_law=bush_law,
        joint_friction=joint_friction, lubrication=lubrication,
    )  # fmt: skip


def _along(chain: ChainSpec, rollers, velocities, closed: bool):
    """What both chains count along their rollers: the rollers' centres and velocities as
    arrays, their count n, the links' count and indices, a bush chain's bushes' links."""
    rollers = np.asarray(rollers, dtype=float)
    n = len(rollers)
    n_links = n if closed else n - 1
    bush_link = None if chain.has_roller else _bush_link(n, closed)
    return rollers, np.asarray(velocities, float), n, n_links, np.arange(n_links), bush_link


def _lumped_bodies(
    chain, rollers, velocities, *, closed, link_load, damping_ratio, joint_friction
) -> ChainBodies:
    """:class:`Lumped`'s bodies: point masses on spring-damper links."""
    rollers, velocities, n, n_links, idx, bush_link = _along(chain, rollers, velocities, closed)
    p = chain.pitch
    nxt = (idx + 1) % n
    zero2 = np.zeros((n_links, 2))
    m = chain.roller_mass + 0.5 * (chain.roller_link_mass + chain.pin_link_mass)
    mass = np.full(n, m)
    if not closed:  # end rollers carry only half of one link
        mass[[0, -1]] = chain.roller_mass + 0.25 * (chain.roller_link_mass + chain.pin_link_mass)
    k = link_stiffness(chain, link_load)
    c = 2 * damping_ratio * math.sqrt(k * m / 2)
    springs = PairGroup(
        a=jnp.asarray(idx),
        b=jnp.asarray(nxt),
        ra=jnp.asarray(zero2),
        rb=jnp.asarray(zero2),
        element=LinkSprings(
            stiffness=jnp.asarray(k), damping=jnp.asarray(c), rest_length=jnp.asarray(p)
        ),
    )
    q0 = np.column_stack([rollers, np.zeros(n)])
    v0 = np.column_stack([velocities, np.zeros(n)])
    # a point's angle carries no torque (a roller spins free; a bush turns with its
    # inner link, whose rotation the points' positions carry): a bush chain's point
    # gets the inertia of a disc of the bush's radius only to keep that unused
    # equation finite
    spin_inertia = chain.roller_inertia if chain.has_roller else m * chain.roller_radius**2 / 2
    return ChainBodies(
        mass=mass,
        inertia=np.full(n, spin_inertia),
        pairs=(springs,),
        roller_body=np.arange(n),
        roller_offset=np.zeros((n, 2)),
        q0=q0,
        v0=v0,
        link_weights=np.eye(n_links),
        joint_friction=_lumped_joint_friction(chain, n, closed, joint_friction),
        bush_link=bush_link,
    )


def _clearance_bodies(
    chain, rollers, velocities, *, closed, restitution, rollers_on_bush, pin_law, bush_law,
    joint_friction, lubrication,
) -> ChainBodies:  # fmt: skip
    """:class:`Clearance`'s bodies: rigid links on clearance joints."""
    rollers, velocities, n, n_links, idx, bush_link = _along(chain, rollers, velocities, closed)
    p = chain.pitch
    if n % 2:
        raise ValueError(
            f"the clearance model alternates roller and pin links, so it needs an even number "
            f"of rollers (two per roller link), got {n}"
        )
    q_link, v_link = _link_frames(rollers, velocities, closed)
    is_roller_link = idx % 2 == 0
    half = np.array([p / 2, 0.0])
    pin_law = pin_law or joint_law(chain, "pin", restitution)
    # pin links (odd) carry pins at ±p/2 in the bushes of the neighbouring roller links
    # (an open strand of even roller count starts and ends with roller links, so every
    # pin link has both neighbours)
    pl = idx[~is_roller_link]
    a = np.concatenate([pl, pl])
    b = np.concatenate([pl - 1, (pl + 1) % n_links])
    ra = np.concatenate([np.tile(-half, (len(pl), 1)), np.tile(half, (len(pl), 1))])
    rb = -ra
    pin_joints = PairGroup(
        a=jnp.asarray(a),
        b=jnp.asarray(b),
        ra=jnp.asarray(ra),
        rb=jnp.asarray(rb),
        element=_clearance(
            pin_law, chain.pin_diameter / 2, joint_friction, lubrication, _length(chain, "pin")
        ),
    )
    m_link = np.where(is_roller_link, chain.roller_link_mass, chain.pin_link_mass)
    j_link = np.where(is_roller_link, chain.roller_link_inertia, chain.pin_link_inertia)
    # rollers: on the bushes of roller link i (even): roller i at −p/2, roller i+1 at +p/2
    host = np.where(np.arange(n) % 2 == 0, np.arange(n), np.arange(n) - 1)
    side = np.where(np.arange(n) % 2 == 0, -1.0, 1.0)
    offs = side[:, None] * half
    c, s = np.cos(q_link[host, 2]), np.sin(q_link[host, 2])
    arm = np.column_stack([c * offs[:, 0] - s * offs[:, 1], s * offs[:, 0] + c * offs[:, 1]])
    bush_x = q_link[host, :2] + arm
    bush_v = v_link[host, :2] + v_link[host, 2:3] * np.column_stack([-arm[:, 1], arm[:, 0]])
    pairs = [pin_joints]
    if rollers_on_bush == "lumped":
        m_link = m_link + np.where(is_roller_link, 2 * chain.roller_mass, 0.0)
        j_link = j_link + np.where(
            is_roller_link, 2 * (chain.roller_inertia + chain.roller_mass * (p / 2) ** 2), 0.0
        )
        mass, inertia = m_link, j_link
        q0, v0 = q_link, v_link
        roller_body, roller_offset = host, offs
    elif rollers_on_bush == "joint":
        bush_law = bush_law or joint_law(chain, "roller", restitution)
        rbody = n_links + np.arange(n)
        pairs.append(
            PairGroup(
                a=jnp.asarray(host),
                b=jnp.asarray(rbody),
                ra=jnp.asarray(offs),
                rb=jnp.asarray(np.zeros((n, 2))),
                element=_clearance(
                    bush_law,
                    chain.bush_diameter / 2,
                    joint_friction,
                    lubrication,
                    _length(chain, "roller"),
                ),
                carries_tension=False,
            )
        )
        mass = np.concatenate([m_link, np.full(n, chain.roller_mass)])
        inertia = np.concatenate([j_link, np.full(n, chain.roller_inertia)])
        q0 = np.concatenate([q_link, np.column_stack([bush_x, np.zeros(n)])])
        v0 = np.concatenate([v_link, np.column_stack([bush_v, np.zeros(n)])])
        roller_body, roller_offset = rbody, np.zeros((n, 2))
    else:
        raise ValueError(f"rollers_on_bush must be 'joint' or 'lumped', got {rollers_on_bush!r}")
    return ChainBodies(
        mass=mass,
        inertia=inertia,
        pairs=tuple(pairs),
        roller_body=roller_body,
        roller_offset=roller_offset,
        q0=q0,
        v0=v0,
        link_weights=_tension_weights(n_links, a, b),
        bush_link=bush_link,
    )

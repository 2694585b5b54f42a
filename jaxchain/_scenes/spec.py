"""Drives and strands described as data: :class:`DriveSpec` (a closed chain over its
sprockets, each a :class:`SprocketSpec` with its profile and load) and :class:`StrandSpec`
(the meshing strand of :func:`~jaxchain.scenes.engagement`). A spec is a frozen
dataclass: ``spec.replace(speed_rpm=2000)`` makes the next operating point of a sweep,
``spec.build()`` the scene. :func:`~jaxchain.scenes.drive` and
:func:`~jaxchain.scenes.engagement` take the same data as keyword arguments; a spec
builds exactly the scene those give, checked by the same rules."""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Literal

import numpy as np

from .. import _checks as checks
from .._chain import ChainSpec, as_chain
from .._contact.base import AbstractContactLaw
from .._elements.base import AbstractElement
from .._elements.cushion import CushionRing, as_cushions
from .._loads import AbstractLoad
from .._profiles.base import MAX_TEETH, AbstractProfile
from .._profiles.iso import ToothProfile
from .._scene import Scene
from .common import disc_inertia, per_driven
from .drive import build_drive, two_sprockets
from .engagement import build_engagement
from .fidelity import AbstractFidelity
from .loop import as_centres, as_outside
from .model import MODEL_FIELDS, ChainModel, DriveArgs, ModelFields, model_of, rad_per_s
from .shoes import Guide, Tensioner

__all__ = ["SprocketSpec", "DriveSpec", "StrandSpec"]


@dataclasses.dataclass(frozen=True)
class SprocketSpec:
    """One sprocket of a drive.

    Attributes:
        teeth: tooth count, 7 to 150.
        centre: its axis (x, y) [m]; None on every sprocket: the two-sprocket drive on the
            x axis (driver at the origin, the driven one at ``DriveSpec.centre_distance``).
        profile: its tooth profile (any kind); None: ISO 606 of ``DriveSpec.form``.
        load: the torque resisting a driven sprocket's rotation, a number [N·m] ≥ 0 or a
            ``jc.loads`` load (default 0: an idler); None for the driver, which turns at the
            drive's speed.
        inertia: a driven sprocket's moment of inertia [kg·m²]; None: a steel disc of its
            pitch diameter.
        outside: the chain wraps it from outside the loop (an idler on the chain's back).
        cushion: a :class:`jc.elements.CushionRing <jaxchain.elements.CushionRing>` beside
            its teeth, or None (none).
    """

    teeth: int
    centre: tuple[float, float] | None = None
    profile: AbstractProfile | None = None
    load: float | AbstractLoad | None = 0.0
    inertia: float | None = None
    outside: bool = False
    cushion: CushionRing | None = None

    def __post_init__(self):
        if self.cushion is not None and not isinstance(self.cushion, CushionRing):
            raise TypeError(
                "SprocketSpec.cushion must be a jc.elements.CushionRing or None, got "
                f"{type(self.cushion).__name__} {self.cushion!r}"
            )
        checks.integer("SprocketSpec.teeth", self.teeth, lo=7, hi=MAX_TEETH)
        if self.centre is not None:
            axis = checks.pair("SprocketSpec.centre", self.centre, 2, "coordinates (x, y) [m]")
            for k, x in enumerate(axis):
                checks.real(f"SprocketSpec.centre[{k}]", x, unit="m")
        if self.profile is not None:
            checks.instance(
                "SprocketSpec.profile", self.profile, AbstractProfile,
                "a tooth profile (jc.ToothProfile, jc.FreeformProfile, any "
                "jc.AbstractProfile) or None (ISO 606 of DriveSpec.form)",
            )  # fmt: skip
            if self.profile.teeth != self.teeth:
                raise ValueError(
                    f"SprocketSpec.profile has {self.profile.teeth} teeth but teeth="
                    f"{self.teeth}: give the profile of this sprocket (or teeth="
                    f"{self.profile.teeth})"
                )
        if self.load is not None and not isinstance(self.load, AbstractLoad):
            checks.real(
                "SprocketSpec.load", self.load, lo=0.0,
                unit="N·m (or a jc.loads load; None for the driver)",
            )  # fmt: skip
        if self.inertia is not None:
            checks.real("SprocketSpec.inertia", self.inertia, lo=0.0, lo_open=True, unit="kg·m²")
        checks.flag("SprocketSpec.outside", self.outside)

    def replace(self, **changes) -> SprocketSpec:
        """A copy with ``changes`` (field=value)."""
        return dataclasses.replace(self, **changes)


@dataclasses.dataclass(frozen=True)
class _Operating:
    """The chain, its speed and the fidelity: the first fields of a spec."""

    chain: ChainSpec | str = "08B"
    speed_rpm: float = 1000.0
    fidelity: Literal["lumped", "clearance"] | AbstractFidelity = "lumped"


@dataclasses.dataclass(frozen=True)
class _ChainModel(ModelFields, _Operating):
    """How the chain and its contacts are modelled: what drives and strands share (each
    field as in :func:`~jaxchain.scenes.drive`): the chain, speed and fidelity, then the
    :class:`ChainModel` fields a spec carries flat."""

    #: force elements of the user's own, added to the built scene
    #: (:meth:`~jaxchain.Scene.add_elements`; the settled start is the built-in elements').
    elements: tuple[AbstractElement, ...] = ()

    def replace(self, **changes):
        """A copy with ``changes`` (field=value)."""
        return dataclasses.replace(self, **changes)

    @classmethod
    def _flat(cls, model: ChainModel) -> dict:
        """The fields of ``model`` (a :class:`ChainModel`, or a spec) that this spec class
        carries flat, by name: what :attr:`model` gathers, and what a builder's model gives
        its spec."""
        own = {f.name for f in dataclasses.fields(cls)}
        return {name: getattr(model, name) for name in MODEL_FIELDS if name in own}

    @property
    def model(self) -> ChainModel:
        """How the spec models the chain: its :class:`ChainModel` fields as one object."""
        return ChainModel(**self._flat(self))

    def _model(self, **model) -> dict:
        """The builders' keywords the chain model sets: chain, speed, fidelity and the
        :attr:`model` (with ``model``'s fields changed)."""
        return {
            "chain": self.chain,
            "speed_rpm": self.speed_rpm,
            "fidelity": self.fidelity,
            "model": self.model.replace(**model) if model else self.model,
        }

    def _with_elements(self, scene: Scene) -> Scene:
        if not len(self.elements):
            return scene
        scene = scene.add_elements(*self.elements)
        checks.element_coordinates(scene, "build")
        return scene


def _default_sprockets() -> tuple[SprocketSpec, ...]:
    return (SprocketSpec(18, load=None), SprocketSpec(36, load=20.0))


@dataclasses.dataclass(frozen=True)
class DriveSpec(_ChainModel):
    """A closed chain drive as data: the chain and its model, the sprockets (driver first)
    with their profiles and loads, the tension, and optionally a tensioner, guides and
    elements of the user's own. ``build()`` gives the scene of
    :func:`~jaxchain.scenes.drive` (which documents every field).

    ``sprockets``: the driver first (its ``load`` None), then the driven ones in the order
    the chain passes them (counter-clockwise). Give every ``centre``, or none (two
    sprockets on the x axis, ``centre_distance`` apart). ``take_up_sprocket``: the index
    of the sprocket that closes the loop (with centres; default the last).

    >>> spec = jc.scenes.DriveSpec(sprockets=(
    ...     jc.scenes.SprocketSpec(18, load=None),
    ...     jc.scenes.SprocketSpec(36, load=jc.loads.Harmonic(20.0, ((2, 5.0, 0.0),))),
    ... ), speed_rpm=1500)
    >>> scenes = [spec.replace(speed_rpm=r).build() for r in (1000, 2000, 3000)]
    """

    sprockets: tuple[SprocketSpec, ...] = dataclasses.field(default_factory=_default_sprockets)
    pretension: float = 200.0
    centre_distance: float | None = None
    n_links: int | None = None
    take_up_sprocket: int | None = None
    load_ramp: float | None = None
    tensioner: Tensioner | None = None
    guides: tuple[Guide, ...] = ()
    shoe_contact: AbstractContactLaw | None = None

    def __post_init__(self):
        sprockets = tuple(self.sprockets)
        bad = [s for s in sprockets if not isinstance(s, SprocketSpec)]
        if len(sprockets) < 2 or bad:
            raise ValueError(
                "DriveSpec.sprockets must hold 2 or more jc.scenes.SprocketSpec (the driver "
                f"first), got {self.sprockets!r}"
            )
        if sprockets[0].load is not None:
            raise ValueError(
                "sprockets[0] is the driver: it turns at speed_rpm and takes no load; give "
                f"it load=None (got load={sprockets[0].load!r})"
            )
        missing = [k for k, s in enumerate(sprockets[1:], 1) if s.load is None]
        if missing:
            raise ValueError(
                f"sprockets{missing} are driven: give each a load (0 for an idler), got None"
            )
        if sprockets[0].outside:
            raise ValueError("sprockets[0] is the driver: it cannot be outside the loop")
        placed = [s.centre is not None for s in sprockets]
        if any(placed) and not all(placed):
            raise ValueError(
                "give the centre of every sprocket, or of none (two sprockets on the x axis); "
                f"sprockets{[k for k, p in enumerate(placed) if not p]} have none"
            )
        object.__setattr__(self, "sprockets", sprockets)
        object.__setattr__(self, "guides", tuple(self.guides))
        object.__setattr__(self, "elements", tuple(self.elements))

    def with_sprocket(self, index: int, **changes) -> DriveSpec:
        """A copy whose sprocket ``index`` has ``changes`` (``SprocketSpec`` fields)."""
        n = len(self.sprockets)
        index = checks.integer("with_sprocket: index", index, lo=-n, hi=n - 1)
        sprockets = list(self.sprockets)
        sprockets[index] = sprockets[index].replace(**changes)
        return self.replace(sprockets=tuple(sprockets))

    def arguments(self) -> dict:
        """The keyword arguments of :func:`~jaxchain.scenes.drive` this spec stands for."""
        sp, driven = self.sprockets, self.sprockets[1:]
        placed = sp[0].centre is not None
        rings = tuple(s.cushion for s in sp)
        args = self._model(cushion=rings) if any(r is not None for r in rings) else self._model()
        args.update(
            teeth=tuple(s.teeth for s in sp),
            pretension=self.pretension,
            centre_distance=self.centre_distance,
            n_links=self.n_links,
            tensioner=self.tensioner,
            guides=self.guides,
            load_torque=tuple(s.load for s in driven) if len(driven) > 1 else driven[0].load,
        )
        if placed:
            args["centres"] = tuple(tuple(s.centre) for s in sp)
            args["outside"] = tuple(k for k, s in enumerate(sp) if s.outside)
            args["take_up_sprocket"] = self.take_up_sprocket
        elif any(s.outside for s in sp) or self.take_up_sprocket is not None:
            args["outside"] = tuple(k for k, s in enumerate(sp) if s.outside)
            args["take_up_sprocket"] = self.take_up_sprocket  # refused there: needs centres
        if any(s.profile is not None for s in sp):
            chain = as_chain(self.chain)
            args["profiles"] = tuple(
                s.profile
                if s.profile is not None
                else ToothProfile.iso606(chain, s.teeth, self.form)
                for s in sp
            )
        inertia = [s.inertia for s in driven]
        if any(i is not None for i in inertia):
            if any(i is None for i in inertia):
                chain = as_chain(self.chain)
                profiles = args.get("profiles") or tuple(
                    ToothProfile.iso606(chain, s.teeth, self.form) for s in sp
                )
                inertia = [
                    disc_inertia(chain, profiles[k]) if i is None else i
                    for k, i in enumerate(inertia, 1)
                ]
            args["driven_inertia"] = tuple(inertia) if len(inertia) > 1 else inertia[0]
        return args

    def build(self) -> Scene:
        """The scene this spec describes (what :func:`~jaxchain.scenes.drive` of
        :meth:`arguments` gives), with ``elements`` added."""
        args = self.arguments()
        model = args.pop("model")
        a = DriveArgs(
            chain=as_chain(args.pop("chain")), omega=rad_per_s(args.pop("speed_rpm")),
            teeth=args.pop("teeth"), centres=args.pop("centres", None),
            outside=args.pop("outside", ()), take_up_sprocket=args.pop("take_up_sprocket", None),
            profiles=args.pop("profiles", None), driven_inertia=args.pop("driven_inertia", None),
            **args,
        )  # fmt: skip
        return self._with_elements(build_drive(a, model))

    @classmethod
    def of(
        cls,
        chain: ChainSpec | str = "08B",
        teeth: Sequence[int] = (18, 36),
        *,
        centres: Sequence[tuple[float, float]] | None = None,
        outside: Sequence[int] = (),
        load_torque: float | AbstractLoad | Sequence[float | AbstractLoad] = 20.0,
        profiles: Sequence[AbstractProfile] | None = None,
        driven_inertia: float | Sequence[float] | None = None,
        cushion: Sequence[CushionRing | None] | None = None,
        **rest,
    ) -> DriveSpec:
        """The spec of ``jc.scenes.drive(chain, teeth, ...)``: the same arguments, the
        per-sprocket ones (``teeth``, ``centres``, ``outside``, ``load_torque``,
        ``profiles``, ``driven_inertia``, ``cushion``) gathered into
        :class:`SprocketSpec` s."""
        if centres is None and (rest.get("tensioner") is not None or rest.get("guides")):
            teeth = two_sprockets(teeth)  # the tensioner or guides place the two sprockets
        elif centres is None:
            teeth = two_sprockets(teeth, outside, rest.get("take_up_sprocket"))
        else:
            if isinstance(teeth, (str, bytes)) or not isinstance(teeth, Sequence | np.ndarray):
                raise TypeError(f"teeth must be a sequence of tooth counts, got {teeth!r}")
            teeth = tuple(
                checks.integer(f"teeth[{k}]", z, lo=7, hi=MAX_TEETH) for k, z in enumerate(teeth)
            )
        n = len(teeth)
        if n < 2:
            raise ValueError(f"teeth must hold at least 2 tooth counts (driver first), got {n}")
        # each per-sprocket argument checked in the words of drive()'s keywords
        loads = [None]
        for label, v in per_driven("load_torque", load_torque, n - 1):
            if not isinstance(v, AbstractLoad):
                v = checks.real(label, v, lo=0.0, unit="N·m (or a jc.loads load)")
            loads.append(v)
        inertias = [None]
        if driven_inertia is not None:
            inertias += [
                checks.real(label, v, lo=0.0, lo_open=True, unit="kg·m²")
                for label, v in per_driven("driven_inertia", driven_inertia, n - 1)
            ]
        else:
            inertias += [None] * (n - 1)
        what = "tooth profiles (driver, driven)" if n == 2 else "tooth profiles, one per sprocket"
        shapes = (None,) * n if profiles is None else checks.pair("profiles", profiles, n, what)
        axes = (None,) * n if centres is None else tuple(map(tuple, as_centres(centres, n)))
        if isinstance(outside, (int, np.integer)) and not isinstance(outside, bool):
            outside = (outside,)
        if isinstance(outside, (str, bytes)) or not isinstance(outside, Sequence | np.ndarray):
            raise TypeError(
                f"outside must be a sequence of sprocket indices in [1, {n - 1}], got {outside!r}"
            )
        out = set(as_outside(outside, n))
        rings = as_cushions(cushion, n)
        sprockets = tuple(
            SprocketSpec(
                teeth=z,
                centre=None if c is None else tuple(float(x) for x in c),
                profile=p,
                load=w,
                inertia=i,
                outside=k in out,
                cushion=r,
            )
            for k, (z, c, p, w, i, r) in enumerate(
                zip(teeth, axes, shapes, loads, inertias, rings, strict=True)
            )
        )
        if "elements" in rest:
            rest["elements"] = tuple(rest["elements"])
        if isinstance(rest.get("guides"), Guide):  # one guide, as drive() takes it
            rest["guides"] = (rest["guides"],)
        return cls(chain=chain, sprockets=sprockets, **rest)


@dataclasses.dataclass(frozen=True)
class StrandSpec(_ChainModel):
    """The meshing strand of :func:`~jaxchain.scenes.engagement` as data: one sprocket
    (``sprocket``: its teeth and profile; its load is not used) drawing an open strand in
    from a tight entry span and letting it out into a slack one. ``build()`` gives that
    scene (which documents every field).

    >>> spec = jc.scenes.StrandSpec(sprocket=jc.scenes.SprocketSpec(18, load=None))
    >>> scenes = [spec.replace(tension=t).build() for t in (500.0, 1000.0, 2000.0)]
    """

    sprocket: SprocketSpec = SprocketSpec(18, load=None)
    tension: float = 1000.0
    slack_tension: float = 100.0
    wrap: int | None = None
    n_entry: int = 8
    n_exit: int = 4
    span_stiffness: float | None = None
    #: a cushion ring on the sprocket (the same as ``sprocket.cushion``: give it in one of
    #: the two places), or None
    cushion: CushionRing | None = None

    def __post_init__(self):
        if not isinstance(self.sprocket, SprocketSpec):
            raise ValueError(
                f"StrandSpec.sprocket must be a jc.scenes.SprocketSpec, got {self.sprocket!r}"
            )
        if self.cushion is not None and not isinstance(self.cushion, CushionRing):
            raise TypeError(
                "StrandSpec.cushion must be a jc.elements.CushionRing or None, got "
                f"{type(self.cushion).__name__} {self.cushion!r}"
            )
        sp = self.sprocket
        unused = {
            "load": (sp.load is not None and not (isinstance(sp.load, float | int) and
                                                  sp.load == 0), "StrandSpec.tension sets it"),
            "centre": (sp.centre is not None, "the strand is laid out about the axis"),
            "inertia": (sp.inertia is not None, "the strand's driver turns at its set speed"),
            "outside": (sp.outside, "the strand meshes on the sprocket's teeth"),
        }  # fmt: skip
        given = [f"{name} ({why})" for name, (set_, why) in unused.items() if set_]
        if given:
            raise ValueError(
                "StrandSpec: the meshing strand does not use its sprocket's "
                + ", ".join(given)
                + ": leave them at None (load=None, outside=False), or use a DriveSpec, "
                "whose sprockets use them"
            )
        ring = self.sprocket.cushion
        if self.cushion is not None and ring is not None and ring is not self.cushion:
            raise ValueError(
                "StrandSpec: two cushion rings for its one sprocket (StrandSpec.cushion and "
                "StrandSpec.sprocket.cushion); give the ring in one of the two places"
            )
        object.__setattr__(self, "elements", tuple(self.elements))

    def arguments(self) -> dict:
        """The keyword arguments of :func:`~jaxchain.scenes.engagement` this spec stands
        for."""
        ring = self.cushion if self.cushion is not None else self.sprocket.cushion
        args = self._model(cushion=ring)
        args.update(
            teeth=self.sprocket.teeth,
            profile=self.sprocket.profile,
            tension=self.tension,
            slack_tension=self.slack_tension,
            wrap=self.wrap,
            n_entry=self.n_entry,
            n_exit=self.n_exit,
            span_stiffness=self.span_stiffness,
        )
        return args

    def build(self) -> Scene:
        """The scene this spec describes (what :func:`~jaxchain.scenes.engagement` of
        :meth:`arguments` gives), with ``elements`` added."""
        args = self.arguments()
        m = args.pop("model")
        return self._with_elements(
            build_engagement(args.pop("chain"), args.pop("teeth"), m=m, **args)
        )


def drive(
    chain: ChainSpec | str = "08B",
    teeth: Sequence[int] = (18, 36),
    *,
    centres: Sequence[tuple[float, float]] | None = None,
    outside: Sequence[int] = (),
    take_up_sprocket: int | None = None,
    centre_distance: float | None = None,
    n_links: int | None = None,
    speed_rpm: float = 1000.0,
    load_torque: float | AbstractLoad | Sequence[float | AbstractLoad] = 20.0,
    pretension: float = 200.0,
    fidelity: Literal["lumped", "clearance", "spans"] | AbstractFidelity = "lumped",
    profiles: Sequence[AbstractProfile] | None = None,
    tensioner: Tensioner | None = None,
    guides: Sequence[Guide] = (),
    model: ChainModel | None = None,
    **older,
) -> Scene:
    """A closed roller chain over a driver (axis at the origin, turning counter-clockwise at
    ``speed_rpm``) and a driven sprocket (axis at (C, 0)) loaded by ``load_torque``; or,
    with ``centres``, over any number of sprockets (below).

    The initial configuration is consistent: rollers seated at the pitch points of the
    wrap arcs, straight spans of whole pitches, the centre distance C adjusted (by less
    than a pitch) so the loop closes with an even link count (give ``centre_distance`` or
    ``n_links``; default 40 pitches), the chain laid out stretched by ``pretension``, and
    velocities of rigid transport at the driver speed; then (``settle``, the default) the
    static equilibrium of that layout with the driver held: rollers in their seats, joints
    closed, the driven axis moved by a take-up of 2·pretension and the full load carried.
    What remains is a small start-up transient: the polygonal mismatch of the spans' end
    velocities. From the raw layout (``settle=False``) the seat and joint clearances are
    open and the load is ramped in smoothly over ``load_ramp`` (default: one driver
    revolution) so the tight span stretches without a shock.

    Several sprockets: give ``teeth=(z1, …, zN)`` and their axes ``centres=((x1, y1), …)``
    [m]. The first (index 0) drives; the chain passes the sprockets in the order given as one
    counter-clockwise loop, wrapping counter-clockwise the ones inside it and clockwise
    the ``outside`` ones (idlers on the chain's back, turning clockwise). A driven
    sprocket with zero load torque is an idler. The layout closes exactly
    (:func:`~jaxchain.scenes.loop_layout`): the take-up sprocket moves along the outward
    bisector of its spans by what closes the loop with ``n_links`` (default: the even
    count nearest the belt length), and while the scene settles it is pushed along that
    bisector so that its two spans carry 2·pretension between them; the other axes stay
    where given. Every sprocket k starts at ±ω1·z1/zk.

    A ``tensioner`` (:class:`~jaxchain.scenes.Tensioner`, a sprung arm with a shoe)
    presses on one span from the chain's back and sets the tension: its span carries
    ``pretension`` at rest, and no sprocket moves (no take-up). The layout wraps the chain
    round the shoe, pushed in by ``Tensioner.deflection``; the loop closes by moving the
    shoe along the bisector of its spans, and the settled start turns the arm until its
    spring balances the chain. ``guides`` (:class:`~jaxchain.scenes.Guide`) are fixed
    shoes along spans. Both work with two sprockets and no ``centres`` too (the driven
    axis at (``centre_distance``, 0), default 40 pitches).

    Args:
        chain: an ISO 606 designation or a :class:`ChainSpec`.
        teeth: tooth counts, driver first: (driver, driven), or N of them with ``centres``.
        centres: (N, 2) axis positions [m] in the order the chain passes them (None: the
            two-sprocket drive on the x axis).
        outside: indices in [1, N − 1] of sprockets outside the loop (needs ``centres``).
        take_up_sprocket: the sprocket that closes the loop and takes up the pretension,
            in [1, N − 1] (default N − 1; needs ``centres``).
        centre_distance: two-sprocket drive: C [m] (adjusted by less than a pitch to close).
        n_links: even number of links.
        speed_rpm: driver speed [rpm], > 0; every scene built with the defaults runs with
            ``simulate``'s defaults from 100 to 3000 rpm, in both fidelities.
        load_torque: the torque resisting each driven sprocket's rotation: a number [N·m],
            ≥ 0, or a load (``jc.loads.Harmonic(...)``, any ``jc.loads.AbstractLoad``), for
            every driven sprocket, or one per driven sprocket. The statics hold a load at its
            value at the start; a number is ramped in over ``load_ramp``.
        pretension: chain tension at rest [N], ≥ 0.
        fidelity: the fidelity, an object (``jc.scenes.Lumped()``, ``Clearance()``,
            ``SpanLevel()``) or its name: "lumped" (rollers + elastic links),
            "clearance" (rigid links, pin/bush and bush/roller clearance joints) or
            "spans" (no rollers: the free spans as axial springs between the sprockets'
            pitch curves, for the drive's tensions and speeds over many revolutions;
            fixed axes, a tensioner's shoe as a frictionless circle the chain slides
            over, guides checked but without effect (they lie along the straight spans,
            which do not move across), no gravity; see :class:`jc.elements.Spans
            <jaxchain.elements.Spans>`).
        profiles: one tooth profile per sprocket (default ISO 606 of ``model.form``).
        tensioner: a :class:`~jaxchain.scenes.Tensioner` on one span, or None.
        guides: fixed :class:`~jaxchain.scenes.Guide` shoes, each on a span (not the
            tensioner's).
        model: how the chain and its contacts are modelled, a
            :class:`~jaxchain.scenes.ChainModel` (form, wear, restitution, friction, joint
            friction, oil, contact laws, damping, gravity, settled start, load ramp, cushion
            rings); default ``ChainModel()``.

    The drive is built through its spec, ``DriveSpec.of(...)`` of these arguments
    (:class:`~jaxchain.scenes.DriveSpec`), whose :meth:`~jaxchain.scenes.DriveSpec.build`
    gives the scene.

    Older keywords: each field of :class:`~jaxchain.scenes.ChainModel` is still taken as
    a keyword (``restitution=0.5`` for ``model=ChainModel(restitution=0.5)``), with a
    ``DeprecationWarning`` naming that spelling; and
    ``driven_inertia`` [kg·m²], of every driven sprocket or one per driven sprocket
    (default a steel disc of the pitch diameter; ``SprocketSpec.inertia`` in a
    :class:`~jaxchain.scenes.DriveSpec`).
    """
    driven_inertia = older.pop("driven_inertia", None)
    m = model_of("drive", model, older)
    spec = DriveSpec.of(
        chain, teeth, centres=centres, outside=outside, load_torque=load_torque,
        profiles=profiles, driven_inertia=driven_inertia, cushion=m.cushion,
        take_up_sprocket=take_up_sprocket, centre_distance=centre_distance, n_links=n_links,
        speed_rpm=speed_rpm, pretension=pretension, fidelity=fidelity, tensioner=tensioner,
        guides=guides, **DriveSpec._flat(m),
    )  # fmt: skip
    return spec.build()


def engagement(
    chain: ChainSpec | str = "08B",
    teeth: int = 18,
    *,
    speed_rpm: float = 1000.0,
    tension: float = 1000.0,
    slack_tension: float = 100.0,
    wrap: int | None = None,
    n_entry: int = 8,
    n_exit: int = 4,
    fidelity: Literal["lumped", "clearance"] | AbstractFidelity = "lumped",
    profile: AbstractProfile | None = None,
    span_stiffness: float | None = None,
    model: ChainModel | None = None,
    **older,
) -> Scene:
    """The meshing-impact scene used for design: a driver sprocket turning counter-clockwise
    at ``speed_rpm`` draws an open chain strand in from a tight entry span (held at
    ``tension`` far away) and lets it out into a slack exit span (``slack_tension``).

    ``wrap`` rollers start seated (default z/2), ``n_entry`` rollers on the entry span mesh
    one after the other, one per tooth period 2π/(zω): the scene's horizon
    (``Scene.horizon``) is ``n_entry`` tooth periods, and a longer solve is refused. Each
    free span end runs on a guide moving at that span's mean
    speed (the polygon's mean speed z·p·ω/2π with the pitch stretched by the span's
    tension, so the span's tension does not drift), pulled by its tension through a soft
    spring (``span_stiffness``, default 1/50 of a link's: the rest of a 50-link span).
    With ``settle`` (default) the strand starts from its static equilibrium on the held
    sprocket (:func:`~jaxchain.scenes.equilibrate`); False starts from the layout.

    ``model`` (a :class:`~jaxchain.scenes.ChainModel`, default ``ChainModel()``) sets how
    the chain and its contacts are modelled, as in :func:`~jaxchain.scenes.drive`; its
    fields are still taken as keywords, with a ``DeprecationWarning``. Its ``elongation``
    is the chain's wear: a worn chain rides higher in the gaps, the more so the further a
    roller is along the wrap.
    Its ``cushion`` is one :class:`jc.elements.CushionRing <jaxchain.elements.CushionRing>`
    on the sprocket (or None); its link plates press on it, in the settled start too (08B
    on 18 teeth: seated plate edges at ≈ 30.1 mm from the axis); a drive's ``load_ramp``
    and ``shoe_contact`` have nothing to act on here, and a model that sets them is
    refused (``ValueError``). Other arguments as in
    :func:`~jaxchain.scenes.drive`. The strand is built through its spec, a
    :class:`~jaxchain.scenes.StrandSpec` of these arguments.
    """
    m = model_of("engagement", model, older)
    unused = [name for name in ("load_ramp", "shoe_contact") if getattr(m, name) is not None]
    if unused:
        reset = ", ".join(f"{name}=None" for name in unused)
        raise ValueError(
            f"engagement: model.{' and model.'.join(unused)} set, but the meshing strand "
            "has no load ramp (its driver turns at its set speed from a settled start or "
            "the layout) and no tensioner or guides; leave them at None "
            f"(model.replace({reset})), or use jc.scenes.drive, which uses them"
        )
    # what the spec's sprocket checks, in this function's words
    checks.integer("teeth", teeth, lo=7, hi=MAX_TEETH)
    if profile is not None:
        checks.instance(
            "profile", profile, AbstractProfile,
            "a tooth profile (jc.ToothProfile, jc.FreeformProfile, any jc.AbstractProfile) "
            "or None",
        )  # fmt: skip
        if profile.teeth != teeth:
            raise ValueError(f"profile has {profile.teeth} teeth, teeth={teeth}")
    if m.cushion is not None and not isinstance(m.cushion, CushionRing):
        raise TypeError(
            f"cushion must be a jc.elements.CushionRing or None, got "
            f"{type(m.cushion).__name__} {m.cushion!r}"
        )
    spec = StrandSpec(
        chain=chain, speed_rpm=speed_rpm, fidelity=fidelity,
        sprocket=SprocketSpec(teeth, profile=profile, load=None), tension=tension,
        slack_tension=slack_tension, wrap=wrap, n_entry=n_entry, n_exit=n_exit,
        span_stiffness=span_stiffness, **StrandSpec._flat(m),
    )  # fmt: skip
    return spec.build()

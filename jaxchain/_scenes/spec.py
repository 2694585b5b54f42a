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
from .common import disc_inertia
from .drive import drive
from .engagement import engagement
from .model import MODEL_FIELDS, ChainModel, ModelFields
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
    fidelity: Literal["lumped", "clearance"] = "lumped"


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

    @property
    def model(self) -> ChainModel:
        """How the spec models the chain: its :class:`ChainModel` fields as one object."""
        fields = {name: getattr(self, name) for name in MODEL_FIELDS if hasattr(self, name)}
        return ChainModel(**fields)

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
        """The scene (:func:`~jaxchain.scenes.drive` of :meth:`arguments`), with
        ``elements`` added."""
        return self._with_elements(drive(**self.arguments()))

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
        if isinstance(teeth, (str, bytes)) or not isinstance(teeth, Sequence | np.ndarray):
            raise TypeError(
                f"teeth must be a sequence of tooth counts, driver first, got {teeth!r}"
            )
        teeth = tuple(
            checks.integer(f"teeth[{k}]", z, lo=7, hi=MAX_TEETH) for k, z in enumerate(teeth)
        )
        n = len(teeth)

        def each(name, value, count):
            if isinstance(value, Sequence | np.ndarray) and not isinstance(value, (str, bytes)):
                if len(value) != count:
                    raise ValueError(f"{name} must hold {count} values, got {len(value)}")
                return tuple(value)
            return (value,) * count

        loads = (None, *each("load_torque", load_torque, n - 1))
        inertias = (None, *each("driven_inertia", driven_inertia, n - 1))
        shapes = each("profiles", profiles, n) if profiles is not None else (None,) * n
        axes = tuple(centres) if centres is not None else (None,) * n
        if len(axes) != n:
            raise ValueError(f"centres must hold {n} axes (one per sprocket), got {len(axes)}")
        if isinstance(outside, (int, np.integer)) and not isinstance(outside, bool):
            outside = (outside,)
        if isinstance(outside, (str, bytes)) or not isinstance(outside, Sequence | np.ndarray):
            raise TypeError(
                f"outside must be a sequence of sprocket indices in [1, {n - 1}], got {outside!r}"
            )
        out = {checks.integer(f"outside[{j}]", k, lo=1, hi=n - 1) for j, k in enumerate(outside)}
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
        """The scene (:func:`~jaxchain.scenes.engagement` of :meth:`arguments`), with
        ``elements`` added."""
        return self._with_elements(engagement(**self.arguments()))

"""``ChainModel``: how a scene builder models the chain and its contacts — one object that
:func:`~jaxchain.scenes.drive`, :func:`~jaxchain.scenes.engagement` and the specs share,
instead of a dozen keywords threaded through each of them."""

from __future__ import annotations

import dataclasses
import math
import warnings
from collections.abc import Sequence
from typing import Any, Literal, NamedTuple

from .. import _checks as checks
from .._contact.base import AbstractContactLaw
from .._contact.film_base import AbstractFilmLaw
from .._contact.friction_base import AbstractFrictionLaw
from .._elements.cushion import CushionRing

__all__ = ["ChainModel", "ModelFields", "DriveArgs", "model_of", "rad_per_s"]


def rad_per_s(speed_rpm) -> float:
    """A driver speed given in rpm, checked (> 0), in rad/s: the one place the builders
    convert it."""
    rpm = checks.real("speed_rpm", speed_rpm, lo=0.0, lo_open=True, unit="rpm")
    return rpm * math.pi / 30


@dataclasses.dataclass(frozen=True)
class ModelFields:
    """The chain-model fields that :class:`ChainModel` and the specs share (a spec carries
    them flat, as the builders' keywords; see :attr:`DriveSpec.model
    <jaxchain.scenes.DriveSpec.model>`)."""

    form: Literal["min", "max", "mid"] = "mid"
    elongation: float = 0.0
    restitution: float = 0.7
    friction: AbstractFrictionLaw | str | None = "default"
    joint_friction: AbstractFrictionLaw | str | None = "default"
    lubrication: AbstractFilmLaw | None = None
    impact_speed: float = 1.0
    rollers_on_bush: Literal["joint", "lumped"] | None = None
    roller_contact: AbstractContactLaw | None = None
    link_damping: float = 0.05
    gravity: float | tuple[float, float] | None = None
    settle: bool = True


@dataclasses.dataclass(frozen=True)
class ChainModel(ModelFields):
    """How the chain and its contacts are modelled, shared by every scene builder
    (``drive(..., model=jc.scenes.ChainModel(restitution=0.5))``); ``replace`` makes a
    variant. The defaults are the builders' defaults.

    Attributes:
        form: ISO 606 tooth form ("min", "max", "mid") of every sprocket given no profile.
        elongation: the chain's wear, 0–0.03: its pitch is p·(1 + elongation) while the
            sprockets stay cut for p.
        restitution: coefficient of restitution of every contact at ``impact_speed``.
        friction: roller/tooth friction, any ``jc.contact.AbstractFrictionLaw``;
            ``"default"``: a bush chain's ``jc.scenes.BUSH_TOOTH_FRICTION``, none for a
            roller chain; None: frictionless.
        joint_friction: friction in the chain's joints; ``"default"``: lubricated steel
            (μ = 0.1, the fidelity's law); None: frictionless joints.
        lubrication: an oil film in the clearance chain's joints
            (``jc.contact.OilFilm(viscosity=0.01)``), or None (dry).
        impact_speed: reference impact speed of the history-free damping [m/s].
        rollers_on_bush: clearance fidelity: "joint" (each roller its own body on a
            clearance joint) or "lumped" (fixed to its bush); None: the chain's own.
        roller_contact: roller/tooth normal law (default
            :func:`~jaxchain.scenes.roller_law`).
        link_damping: damping ratio of the lumped links (0: undamped).
        gravity: None (none), g [m/s²] ≥ 0 along −y, or (gx, gy) [m/s²].
        settle: start from the static equilibrium (default), or from the raw layout.
        load_ramp: a drive's load ramp [s] from a raw layout (default one driver
            revolution; a settled start carries the full load at once).
        shoe_contact: roller/shoe normal law of a drive's tensioner and guides (default
            :func:`~jaxchain.scenes.shoe_law`).
        cushion: cushion rings (``jc.elements.CushionRing``): one for the strand's
            sprocket or a drive's every sprocket, or one entry (a ring or None) per
            sprocket of a drive; None: no rings.
    """

    load_ramp: float | None = None
    shoe_contact: AbstractContactLaw | None = None
    cushion: CushionRing | Sequence[CushionRing | None] | None = None

    def __post_init__(self):
        checks.choice("form", self.form, ("min", "max", "mid"))
        elongation = checks.real(
            "elongation", self.elongation, lo=0.0, hi=0.03,
            unit="(fraction of the pitch; 0.01 = 1 % wear)",
        )  # fmt: skip
        object.__setattr__(self, "elongation", elongation)
        checks.real("restitution", self.restitution, lo=0.0, hi=1.0, lo_open=True)
        what = {
            "friction": "a jc.contact.CoulombFriction, a jc.contact.DahlFriction (any "
            "jc.contact.AbstractFrictionLaw), 'default' (a bush chain's "
            "jc.scenes.BUSH_TOOTH_FRICTION, none for a roller chain) or None",
            "joint_friction": "a jc.contact.DahlFriction, a jc.contact.CoulombFriction (any "
            "jc.contact.AbstractFrictionLaw), 'default' (the fidelity's default, "
            "jc.scenes.joint_friction_default) or None",
        }
        for name, kinds in what.items():
            law = getattr(self, name)
            if law is not None and not (isinstance(law, str) and law == "default"):
                checks.instance(name, law, AbstractFrictionLaw, kinds)
        if self.lubrication is not None:
            checks.instance(
                "lubrication", self.lubrication, AbstractFilmLaw,
                "an oil film of the clearance joints (jc.contact.OilFilm(viscosity=...), "
                "any jc.contact.AbstractFilmLaw) or None (dry joints)",
            )  # fmt: skip
        checks.real("impact_speed", self.impact_speed, lo=0.0, lo_open=True, unit="m/s")
        if self.rollers_on_bush is not None:
            checks.choice("rollers_on_bush", self.rollers_on_bush, ("joint", "lumped", None))
        for name in ("roller_contact", "shoe_contact"):
            law = getattr(self, name)
            if law is not None:
                checks.instance(
                    name, law, AbstractContactLaw,
                    "a normal contact law (jc.contact.JohnsonCylinder, Flores, ...) or None",
                )  # fmt: skip
        checks.flag("settle", self.settle)
        checks.real("link_damping", self.link_damping, lo=0.0, unit="(damping ratio)")
        if self.load_ramp is not None:
            checks.real("load_ramp", self.load_ramp, lo=0.0, unit="s")

    def replace(self, **changes) -> ChainModel:
        """A copy with ``changes`` (field=value)."""
        return dataclasses.replace(self, **changes)

    def check_fidelity(self, fidelity) -> None:
        """``fidelity`` checked against the model (deprecated: the fidelity checks the
        model, ``jc.scenes.Clearance().check(model)``)."""
        from .fidelity import as_fidelity  # the fidelities read the model: imported late

        warnings.warn(
            "ChainModel.check_fidelity(fidelity) is now spelled "
            "jc.scenes.as_fidelity(fidelity).check(model)",
            DeprecationWarning,
            stacklevel=2,
        )
        as_fidelity(fidelity).check(self)


class DriveArgs(NamedTuple):
    """What a drive is, apart from its model (:func:`drive`'s arguments; the driver speed
    in rad/s)."""

    chain: Any  # a ChainSpec
    teeth: Sequence[int]
    centres: Sequence[tuple[float, float]] | None
    outside: Sequence[int]
    take_up_sprocket: int | None
    centre_distance: float | None
    n_links: int | None
    omega: float
    load_torque: Any  # a number, a load or one per driven sprocket
    pretension: float
    fidelity: str
    profiles: Sequence[Any] | None  # profiles
    driven_inertia: float | Sequence[float] | None
    tensioner: Any  # a Tensioner or None
    guides: Sequence[Any]  # Guides


#: the keywords the builders took before the model: each is a ``ChainModel`` field
MODEL_FIELDS = tuple(f.name for f in dataclasses.fields(ChainModel))


def model_of(caller: str, model: ChainModel | None, older: dict) -> ChainModel:
    """The model a builder ``caller`` runs with: ``model`` (default ``ChainModel()``) with
    the fields given the older way, as keywords of the builder (``older``); a keyword that
    is no field is refused as Python refuses it, one given both ways too."""
    if model is None:
        model = ChainModel()
    elif not isinstance(model, ChainModel):
        raise TypeError(f"{caller}: model must be a jc.scenes.ChainModel or None, got {model!r}")
    unknown = [k for k in older if k not in MODEL_FIELDS]
    if unknown:
        raise TypeError(f"{caller}() got an unexpected keyword argument {unknown[0]!r}")
    if not older:
        return model
    given = [k for k in older if not _is_default(getattr(model, k), _DEFAULTS[k])]
    if given:
        raise ValueError(
            f"{caller}: {', '.join(given)} given both as keywords and in model=; give each "
            "in the model"
        )
    spelled = ", ".join(f"{k}=..." for k in older)
    warnings.warn(
        f"{caller}({spelled}): give these in model=jc.scenes.ChainModel({spelled}); "
        "the keywords will be removed",
        DeprecationWarning,
        stacklevel=3,
    )
    return model.replace(**older)


_DEFAULTS = {f.name: f.default for f in dataclasses.fields(ChainModel)}


def _is_default(value, default) -> bool:
    """Whether a field's ``value`` is its default (laws compare by identity)."""
    if value is default:
        return True
    plain = (int, float, str, bool)
    return isinstance(value, plain) and type(value) is type(default) and value == default

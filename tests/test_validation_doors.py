"""Bad inputs to the newer public doors (loads, non-circular sprockets, profile files,
specs, the span-level chain, solve options, engagement statistics, design objects,
cushion rings, oil films, Dahl friction, elements with coordinates of their own): each
is refused with a ``ValueError``/``TypeError`` that names the argument, before anything
is traced or solved. Nothing here simulates; the builders run with ``settle=False``."""

import json

import equinox as eqx
import jax.numpy as jnp
import numpy as np
import pytest

import jaxchain as jc
from jaxchain.design import DesignSpace, ProfileObjective, SprocketDesign

from helpers import modelled

NAN, INF = float("nan"), float("inf")
CHAIN = jc.ChainSpec.iso606("08B")
P18 = jc.ToothProfile.iso606(CHAIN, 18)
RING = jc.elements.CushionRing(0.03)
SP, DS, SS = jc.scenes.SprocketSpec, jc.scenes.DriveSpec, jc.scenes.StrandSpec
REC = jc.observers.EngagementRecord(*(np.zeros((1, 2, 1)),) * 4, np.zeros((1, 2), int))
FLAT = np.zeros(3)


def strand():
    """A strand from its layout (no statics): cheap, and nothing below solves it."""
    return jc.scenes.engagement(
        "08B", 18, n_entry=3, n_exit=2, wrap=9, model=jc.scenes.ChainModel(settle=False)
    )


SCENE = strand()


def drive(**kw):
    return jc.scenes.drive(**modelled(**dict(chain="08B", teeth=(18, 36), settle=False) | kw))


def spans(**kw):
    return jc.scenes.drive(**modelled(**dict(chain="08B", teeth=(18, 36), fidelity="spans") | kw))


def objective(**kw):
    return ProfileObjective(DesignSpace.iso606("08B", 18), lambda p: SCENE, t1=1e-3, **kw)


def sim(scene=SCENE, **kw):
    return jc.simulate(scene, 1e-4, **kw)


class Slide(jc.elements.AbstractElement):
    """An element with coordinates of its own, its inertia and start as given."""

    dofs: int = eqx.field(static=True, default=1)
    inertia: object = 1.0
    start: object = 0.0

    def n_dofs(self, scene):
        return self.dofs

    def dof_inertia(self, scene):
        return jnp.atleast_1d(jnp.asarray(self.inertia, float))

    def dof_start(self, scene):
        s = jnp.atleast_1d(jnp.asarray(self.start, float))
        return s, jnp.zeros_like(s)

    def with_dof_start(self, position):
        return self

    def effect(self, t, y, scene, state):
        return jc.elements.Effect(body=jnp.zeros_like(y.q), dof_force=-state.position)


class Bare(jc.elements.AbstractElement):
    """Coordinates of its own, but no inertia for them."""

    def n_dofs(self, scene):
        return 1

    def effect(self, t, y, scene, state):
        return jc.elements.Effect(body=jnp.zeros_like(y.q), dof_force=jnp.zeros(1))


def _file(text):
    """A case that reads the profile file holding ``text`` (a dict: its JSON)."""

    def call(tmp):
        path = tmp / "profile.json"
        path.write_text(text if isinstance(text, str) else json.dumps(text))
        return jc.load_profile(path)

    call.in_dir = True
    return call


def _saved_fields():
    import tempfile
    from pathlib import Path

    with tempfile.TemporaryDirectory() as d:
        path = P18.save(Path(d) / "p.json")
        return json.loads(path.read_text())


GOOD = _saved_fields()


def _edited(**changes):
    return _file(GOOD | changes)


def _in_dir(fn):
    fn.in_dir = True
    return fn


CM = jc.scenes.ChainModel

# (id, call, error, match)
BAD = [
    # ------------------------------------------------------------------------ loads
    (
        "harmonic-mean-str",
        lambda: jc.loads.Harmonic("5"),
        TypeError,
        "Harmonic: mean must be a real",
    ),
    (
        "harmonic-mean-bool",
        lambda: jc.loads.Harmonic(True),
        TypeError,
        "mean must be a real number",
    ),
    (
        "harmonic-mean-none",
        lambda: jc.loads.Harmonic(None),
        TypeError,
        "mean must be a real number",
    ),
    (
        "harmonic-mean-vec",
        lambda: jc.loads.Harmonic([1.0, 2.0]),
        ValueError,
        r"mean must be a scalar .*\(2,\)",
    ),
    ("harmonic-mean-nan", lambda: jc.loads.Harmonic(NAN), ValueError, "mean must be finite"),
    (
        "strand-load-ramp",
        lambda: jc.scenes.engagement(model=jc.scenes.ChainModel(settle=False, load_ramp=0.01)),
        ValueError,
        r"model.load_ramp set, but the meshing strand has no load ramp",
    ),
    (
        "strand-shoe-contact",
        lambda: jc.scenes.engagement(
            model=jc.scenes.ChainModel(settle=False, shoe_contact=jc.scenes.shoe_law("08B", 0.7))
        ),
        ValueError,
        r"model.replace\(shoe_contact=None\)\), or use jc.scenes.drive",
    ),
    ("shoe-law-restitution", lambda: jc.scenes.shoe_law("08B", 0.0), ValueError, "restitution"),
    (
        "harmonic-rows-int",
        lambda: jc.loads.Harmonic(1.0, 5),
        TypeError,
        r"harmonics must be a sequence of \(order",
    ),
    (
        "harmonic-row-flat",
        lambda: jc.loads.Harmonic(1.0, (2, 1.0, 0.0)),
        TypeError,
        r"harmonics\[0\] must be \(order.*a row per harmonic",
    ),
    (
        "harmonic-row-short",
        lambda: jc.loads.Harmonic(1.0, ((2, 1.0),)),
        ValueError,
        r"harmonics\[0\] must be \(order, amplitude, phase\)",
    ),
    (
        "harmonic-order-str",
        lambda: jc.loads.Harmonic(1.0, (("2", 1.0, 0.0),)),
        TypeError,
        r"harmonics\[0\]'s order must be a real number",
    ),
    (
        "harmonic-amp-complex",
        lambda: jc.loads.Harmonic(1.0, ((2, 1j, 0.0),)),
        TypeError,
        r"harmonics\[0\]'s amplitude must be a real",
    ),
    (
        "harmonic-amp-vec",
        lambda: jc.loads.Harmonic(1.0, ((2, [1.0, 2.0], 0.0),)),
        ValueError,
        r"amplitude must be a scalar",
    ),
    (
        "harmonic-order-0",
        lambda: jc.loads.Harmonic(1.0, ((0, 1.0, 0.0),)),
        ValueError,
        "every order must be > 0",
    ),
    (
        "harmonic-phase-nan",
        lambda: jc.loads.Harmonic(1.0, ((2, 1.0, NAN),)),
        ValueError,
        "phases must be finite",
    ),
    (
        "constant-str",
        lambda: jc.loads.Constant("3"),
        TypeError,
        "Constant: value must be a real number",
    ),
    (
        "constant-vec",
        lambda: jc.loads.Constant([1.0, 2.0]),
        ValueError,
        "Constant: value must be a scalar",
    ),
    ("constant-none", lambda: jc.loads.Constant(None), TypeError, "Constant: value must be a real"),
    (
        "ramped-value-str",
        lambda: jc.loads.Ramped("1", 0.1),
        TypeError,
        "Ramped: value must be a real",
    ),
    (
        "ramped-duration-vec",
        lambda: jc.loads.Ramped(1.0, [0.1, 0.2]),
        ValueError,
        "Ramped: duration must be a scalar",
    ),
    (
        "ramped-duration-neg",
        lambda: jc.loads.Ramped(1.0, -1.0),
        ValueError,
        "duration must be >= 0 s",
    ),
    (
        "cam-phase-nan",
        lambda: jc.loads.camshaft_torque(phase_deg=NAN),
        ValueError,
        "phase_deg must be a finite",
    ),
    (
        "cam-rpm-neg",
        lambda: jc.loads.camshaft_torque(engine_rpm=-100.0),
        ValueError,
        "engine_rpm must be >= 0",
    ),
    (
        "cam-friction-neg",
        lambda: jc.loads.camshaft_torque(friction=-1.0),
        ValueError,
        r"friction must be >= 0 N·m",
    ),
    (
        "cam-cylinders-float",
        lambda: jc.loads.camshaft_torque(cylinders=4.0),
        TypeError,
        "cylinders must be an integer",
    ),
    (
        "cam-rpm-vec",
        lambda: jc.loads.camshaft_torque(engine_rpm=[1e3, 2e3]),
        TypeError,
        "engine_rpm must be a real",
    ),
    (
        "drive-load-str",
        lambda: drive(load_torque="20"),
        TypeError,
        "load_torque must be a real number",
    ),
    (
        "drive-load-module",
        lambda: drive(load_torque=jc.contact.DahlFriction()),
        TypeError,
        "load_torque must be a real number >= 0 N·m .or a jc.loads load., got DahlFriction",
    ),
    # ------------------------------------------------------------------- non-circular
    (
        "nc-base-str",
        lambda: jc.FreeformProfile.noncircular("iso"),
        TypeError,
        "noncircular: base must be a tooth profile",
    ),
    (
        "nc-base-none",
        lambda: jc.FreeformProfile.noncircular(None),
        TypeError,
        "base must be a tooth profile",
    ),
    (
        "nc-harmonics-int",
        lambda: jc.FreeformProfile.noncircular(P18, 3),
        TypeError,
        "noncircular: harmonics must be a sequence",
    ),
    (
        "nc-row-flat",
        lambda: jc.FreeformProfile.noncircular(P18, (2, 1e-4, 0.0)),
        TypeError,
        r"harmonics\[0\] must be \(order",
    ),
    (
        "nc-row-short",
        lambda: jc.FreeformProfile.noncircular(P18, ((2, 1e-4),)),
        ValueError,
        r"harmonics\[0\] must be \(order",
    ),
    (
        "nc-order-str",
        lambda: jc.FreeformProfile.noncircular(P18, (("2", 1e-4, 0.0),)),
        TypeError,
        r"order must be a real number",
    ),
    (
        "nc-order-bool",
        lambda: jc.FreeformProfile.noncircular(P18, ((True, 1e-4, 0.0),)),
        TypeError,
        r"order must be a real number",
    ),
    (
        "nc-amp-str",
        lambda: jc.FreeformProfile.noncircular(P18, ((2, "x", 0.0),)),
        TypeError,
        r"amplitude must be a real number",
    ),
    (
        "nc-amp-vec",
        lambda: jc.FreeformProfile.noncircular(P18, ((2, [1e-4, 2e-4], 0.0),)),
        ValueError,
        "amplitude must be a scalar",
    ),
    (
        "nc-order-half-z",
        lambda: jc.FreeformProfile.noncircular(P18, ((9, 1e-4, 0.0),)),
        ValueError,
        "every order must be below z/2 = 9",
    ),
    (
        "nc-order-frac",
        lambda: jc.FreeformProfile.noncircular(P18, ((1.5, 1e-4, 0.0),)),
        ValueError,
        "whole number >= 1",
    ),
    (
        "nc-amp-nan",
        lambda: jc.FreeformProfile.noncircular(P18, ((2, NAN, 0.0),)),
        ValueError,
        "amplitude must be finite",
    ),
    # ------------------------------------------------------------------- profile files
    (
        "load-missing",
        _in_dir(lambda d: jc.load_profile(d / "missing.json")),
        FileNotFoundError,
        "missing.json",
    ),
    (
        "load-folder",
        _in_dir(lambda d: jc.load_profile(d)),
        IsADirectoryError,
        "a jaxchain profile is a file",
    ),
    (
        "save-no-folder",
        _in_dir(lambda d: P18.save(d / "nope" / "p.json")),
        FileNotFoundError,
        r"nope[/\\]p\.json",
    ),
    (
        "load-not-json",
        _file("{nope"),
        ValueError,
        r"profile\.json is not a jaxchain profile: not JSON",
    ),
    ("load-empty", _file(""), ValueError, "not JSON"),
    ("load-list", _file("[1, 2]"), ValueError, 'expected a JSON object with "format"'),
    ("load-foreign", _file({"name": "x"}), ValueError, "not a jaxchain profile"),
    ("load-newer", _edited(version=99), ValueError, "newer than this jaxchain reads"),
    ("load-version-str", _edited(version="1"), ValueError, '"version" must be a positive integer'),
    ("load-kind", _edited(kind="Gear"), ValueError, "unknown profile kind 'Gear'"),
    ("load-extra-field", _edited(colour=1), ValueError, r"unknown \['colour'\]"),
    ("load-field-str", _edited(pitch="x"), ValueError, "pitch must be a number"),
    ("load-teeth-str", _edited(teeth="18"), ValueError, "teeth"),
    # ------------------------------------------------------------------------ specs
    ("sspec-teeth-str", lambda: SP("18"), TypeError, "SprocketSpec.teeth must be an integer"),
    ("sspec-teeth-float", lambda: SP(18.5), TypeError, "SprocketSpec.teeth must be an integer"),
    (
        "sspec-teeth-5",
        lambda: SP(5),
        ValueError,
        r"SprocketSpec.teeth must be an integer in \[7, 250\]",
    ),
    (
        "sspec-centre-3",
        lambda: SP(18, centre=(0.0, 0.0, 0.0)),
        ValueError,
        "SprocketSpec.centre must hold 2",
    ),
    (
        "sspec-centre-nan",
        lambda: SP(18, centre=(NAN, 0.0)),
        ValueError,
        r"SprocketSpec.centre\[0\] must be a finite",
    ),
    (
        "sspec-profile-str",
        lambda: SP(18, profile="iso"),
        TypeError,
        "SprocketSpec.profile must be a tooth profile",
    ),
    (
        "sspec-profile-teeth",
        lambda: SP(18, profile=jc.ToothProfile.iso606(CHAIN, 20)),
        ValueError,
        "profile has 20 teeth but teeth=18",
    ),
    ("sspec-load-neg", lambda: SP(18, load=-5.0), ValueError, "SprocketSpec.load must be >= 0"),
    (
        "sspec-load-str",
        lambda: SP(18, load="5"),
        TypeError,
        "SprocketSpec.load must be a real number",
    ),
    (
        "sspec-inertia-0",
        lambda: SP(18, inertia=0.0),
        ValueError,
        "SprocketSpec.inertia must be > 0",
    ),
    (
        "sspec-inertia-nan",
        lambda: SP(18, inertia=NAN),
        ValueError,
        "SprocketSpec.inertia must be a finite",
    ),
    (
        "sspec-outside-str",
        lambda: SP(18, outside="yes"),
        TypeError,
        "SprocketSpec.outside must be True or False",
    ),
    (
        "sspec-cushion-str",
        lambda: SP(18, cushion="ring"),
        TypeError,
        "SprocketSpec.cushion must be",
    ),
    ("dspec-one-sprocket", lambda: DS(sprockets=(SP(18, load=None),)), ValueError, "2 or more"),
    (
        "dspec-index-past",
        lambda: DS().with_sprocket(5, teeth=20),
        ValueError,
        r"index must be an integer in \[-2, 1\]",
    ),
    (
        "dspec-index-str",
        lambda: DS().with_sprocket("a", teeth=20),
        TypeError,
        "index must be an integer",
    ),
    (
        "dspec-of-teeth-str",
        lambda: DS.of("08B", "ab"),
        TypeError,
        "teeth must be a sequence of 2 tooth counts",
    ),
    (
        "dspec-of-teeth-float",
        lambda: DS.of("08B", (18.7, 36)),
        TypeError,
        r"teeth\[0\] must be an integer",
    ),
    (
        "dspec-of-outside-str",
        lambda: DS.of("08B", (18, 36), centres=((0, 0), (0.3, 0)), outside="a"),
        TypeError,
        "outside must be a sequence",
    ),
    (
        "dspec-of-outside-0",
        lambda: DS.of("08B", (18, 36), centres=((0, 0), (0.3, 0)), outside=(0,)),
        ValueError,
        r"outside must hold indices of driven sprockets in \[1, 1\]",
    ),
    (
        "dspec-speed-build",
        lambda: DS(speed_rpm=-1.0, settle=False).build(),
        ValueError,
        "speed_rpm must be > 0",
    ),
    (
        "dspec-fidelity-build",
        lambda: DS(fidelity="exact", settle=False).build(),
        ValueError,
        "fidelity must be one of",
    ),
    (
        "dspec-elements-build",
        lambda: DS(elements=("x",), settle=False).build(),
        TypeError,
        "elements must be",
    ),
    (
        "strand-load",
        lambda: SS(sprocket=SP(18, load=5.0)),
        ValueError,
        "does not use its sprocket's load",
    ),
    ("strand-cushion-str", lambda: SS(cushion="x"), TypeError, "StrandSpec.cushion must be"),
    # -------------------------------------------------------------- span-level chain
    (
        "spans-restitution",
        lambda: spans(restitution=0.5),
        ValueError,
        "fidelity='spans' .*does not use restitution",
    ),
    ("spans-settle", lambda: spans(settle=False), ValueError, "does not use settle"),
    (
        "spans-friction",
        lambda: spans(friction=jc.contact.DahlFriction()),
        ValueError,
        "does not use friction",
    ),
    (
        "spans-cushion",
        lambda: spans(cushion=(RING, None)),
        ValueError,
        "cushion: fidelity='spans' has no links",
    ),
    ("spans-gravity", lambda: spans(gravity=9.81), ValueError, "does not model gravity"),
    (
        "spans-lubrication",
        lambda: spans(lubrication=jc.contact.OilFilm(0.01)),
        ValueError,
        "lubrication: an oil film acts",
    ),
    ("spans-outside", lambda: spans(outside=(1,)), ValueError, "outside needs centres"),
    (
        "spans-take-up",
        lambda: spans(take_up_sprocket=1),
        ValueError,
        "take_up_sprocket needs centres",
    ),
    ("spans-teeth-int", lambda: spans(teeth=18), TypeError, "teeth must be a sequence"),
    # -------------------------------------------------------------- builders' keywords
    (
        "drive-friction-str",
        lambda: drive(friction="dahl"),
        TypeError,
        "friction must be a jc.contact",
    ),
    (
        "drive-cushion-ring",
        lambda: drive(cushion=RING),
        TypeError,
        r"cushion: a drive takes one entry per sprocket",
    ),
    (
        "drive-cushion-len",
        lambda: drive(cushion=(RING,)),
        ValueError,
        "cushion must hold 2 entries",
    ),
    (
        "drive-lubrication-lumped",
        lambda: drive(lubrication=jc.contact.OilFilm(0.01)),
        ValueError,
        "fidelity='lumped' has no clearance joints",
    ),
    (
        "drive-tensioner-str",
        lambda: drive(tensioner="t"),
        TypeError,
        "tensioner must be a jc.scenes.Tensioner",
    ),
    (
        "drive-guides-mixed",
        lambda: drive(guides=(jc.scenes.Guide(), "g")),
        TypeError,
        "guides must be a sequence of jc.scenes.Guide",
    ),
    # --------------------------------------------- CushionRing, OilFilm, DahlFriction
    (
        "ring-radius-complex",
        lambda: jc.elements.CushionRing(0.03 + 0j),
        TypeError,
        "CushionRing.radius must be a real number",
    ),
    (
        "ring-radius-str",
        lambda: jc.elements.CushionRing("0.03"),
        TypeError,
        "CushionRing.radius must be a real",
    ),
    (
        "ring-radius-vec",
        lambda: jc.elements.CushionRing([0.03, 0.04]),
        ValueError,
        "CushionRing.radius must be a scalar",
    ),
    (
        "ring-exponent",
        lambda: jc.elements.CushionRing(0.03, exponent=5.0),
        ValueError,
        r"exponent must be in \[1, 3\]",
    ),
    (
        "ring-faces",
        lambda: jc.elements.CushionRing(0.03, faces=3),
        ValueError,
        "faces must be 1 or 2",
    ),
    (
        "oil-viscosity-0",
        lambda: jc.contact.OilFilm(0.0),
        ValueError,
        "OilFilm.viscosity must be > 0",
    ),
    (
        "oil-cavitation",
        lambda: jc.contact.OilFilm(0.01, cavitation="none"),
        ValueError,
        "OilFilm.cavitation must be one of",
    ),
    (
        "oil-nodes",
        lambda: jc.contact.OilFilm(0.01, nodes=2),
        ValueError,
        "OilFilm.nodes must be an integer >= 4",
    ),
    (
        "dahl-coefficient-neg",
        lambda: jc.contact.DahlFriction(-0.1),
        ValueError,
        "DahlFriction.coefficient must be >= 0",
    ),
    (
        "dahl-presliding-0",
        lambda: jc.contact.DahlFriction(0.1, presliding=0.0),
        ValueError,
        "presliding must be > 0 m",
    ),
    (
        "dahl-coefficient-str",
        lambda: jc.contact.DahlFriction("0.1"),
        TypeError,
        "coefficient must be a real",
    ),
    # ---------------------------------------------------------------- statistics
    (
        "stats-strings",
        lambda: jc.peak_statistics(["a", "b"]),
        TypeError,
        "peak_statistics: peaks must be a 1-D array",
    ),
    (
        "stats-complex",
        lambda: jc.peak_statistics([1 + 1j, 2.0]),
        TypeError,
        "peaks must be a 1-D array of forces",
    ),
    ("stats-bools", lambda: jc.peak_statistics([True, False]), TypeError, "got bool array"),
    ("stats-none", lambda: jc.peak_statistics(None), TypeError, "peaks must be"),
    (
        "stats-scalar",
        lambda: jc.peak_statistics(5.0),
        ValueError,
        r"got one number 5.0: pass every engagement's peak, e.g. \[5.0\]",
    ),
    ("stats-empty", lambda: jc.peak_statistics([]), ValueError, "no engagements"),
    ("stats-negative", lambda: jc.peak_statistics([1.0, -2.0]), ValueError, "must be >= 0 N"),
    (
        "stats-2d",
        lambda: jc.peak_statistics(np.ones((2, 3))),
        ValueError,
        "one 1-D array of per-engagement peaks",
    ),
    (
        "stats-confidence",
        lambda: jc.peak_statistics([1.0, 2.0], confidence=95),
        ValueError,
        r"confidence must be in \(0, 1\)",
    ),
    (
        "compare-one-sample",
        lambda: jc.compare_peaks([1.0], [1.0, 2.0]),
        ValueError,
        ">= 2 engagements",
    ),
    (
        "compare-zero-baseline",
        lambda: jc.compare_peaks([0.0, 0.0], [1.0, 2.0]),
        ValueError,
        "baseline a's peaks are all 0 N",
    ),
    (
        "peaks-source-str",
        lambda: jc.engagement_peaks("sol"),
        TypeError,
        "engagement_peaks: source must be a jc.Solution",
    ),
    (
        "peaks-source-events",
        lambda: jc.engagement_peaks(jc.Engagements(*(FLAT,) * 7)),
        TypeError,
        "these are its events already",
    ),
    (
        "peaks-t-start-nan",
        lambda: jc.engagement_peaks(REC, t_start=NAN),
        ValueError,
        "t_start must be a finite",
    ),
    (
        "peaks-record-dims",
        lambda: jc.engagement_peaks(REC._replace(onset=np.zeros((2, 1)))),
        ValueError,
        r"slots are \(..., S, R, K\)",
    ),
    (
        "events-lengths",
        lambda: jc.Engagements(*(FLAT,) * 5, np.zeros(2), FLAT),
        ValueError,
        "Engagements.peak has 2, Engagements.member 3",
    ),
    (
        "events-2d",
        lambda: jc.Engagements(*(np.zeros((2, 2)),) * 7),
        ValueError,
        "Engagements.member must be a 1-D array",
    ),
    (
        "events-none",
        lambda: jc.Engagements(*(None,) * 7),
        TypeError,
        "Engagements.member must be a 1-D array",
    ),
    (
        "events-strings",
        lambda: jc.Engagements(*(np.zeros(2),) * 6, ["a", "b"]),
        TypeError,
        "Engagements.end must be",
    ),
    (
        "events-fractional",
        lambda: jc.Engagements(np.array([0.5, 1.0]), *(np.zeros(2),) * 6),
        ValueError,
        "Engagements.member must hold integer indices",
    ),
    (
        "events-select",
        lambda: jc.Engagements(*(FLAT,) * 7).select(sprocket=-1),
        ValueError,
        "select: sprocket must be an integer >= 0",
    ),
    ("observer-capacity", lambda: jc.observers.EngagementPeaks(capacity=0), ValueError, "capacity"),
    # ---------------------------------------------------------------- design
    (
        "design-profile-str",
        lambda: SprocketDesign("p"),
        TypeError,
        "SprocketDesign.profile must be a tooth profile",
    ),
    (
        "design-cushion-float",
        lambda: SprocketDesign(P18, 0.03),
        TypeError,
        "SprocketDesign.cushion must be",
    ),
    (
        "select-template-str",
        lambda: DesignSpace.select("p", {"seating_radius": (4e-3, 5e-3)}),
        TypeError,
        "template must be a jc.ToothProfile",
    ),
    (
        "select-bound-nan",
        lambda: DesignSpace.select(P18, {"seating_radius": (NAN, 4e-3)}),
        ValueError,
        r"bounds\['seating_radius'\]'s lower must be finite",
    ),
    (
        "select-bound-str",
        lambda: DesignSpace.select(P18, {"seating_radius": ("a", 4e-3)}),
        TypeError,
        r"bounds\['seating_radius'\]'s lower must be a real",
    ),
    (
        "select-bound-shapes",
        lambda: DesignSpace.select(P18, {"seating_radius": (np.zeros(2), np.ones(3))}),
        ValueError,
        r"bounds\['seating_radius'\]: the bounds' shapes",
    ),
    (
        "select-empty",
        lambda: DesignSpace.select(P18, {}),
        TypeError,
        "bounds must be a non-empty dict",
    ),
    (
        "objective-rtol-str",
        lambda: objective(rtol="1e-3"),
        TypeError,
        "ProfileObjective: rtol must be a real number",
    ),
    (
        "objective-n-steps-float",
        lambda: objective(n_steps=10.0),
        TypeError,
        "ProfileObjective: n_steps must be an integer",
    ),
    (
        "objective-n-steps-rtol",
        lambda: objective(n_steps=10, rtol=1e-3),
        ValueError,
        "with fixed steps .n_steps=.... the step count is fixed",
    ),
    # --------------------------------------------- simulate's options (refused before a solve)
    ("sim-rtol-str", lambda: sim(rtol="1e-6"), TypeError, "simulate: rtol must be a real number"),
    ("sim-atol-vec", lambda: sim(atol=[1e-9, 1e-9]), ValueError, "simulate: atol must be a scalar"),
    ("sim-dt-str", lambda: sim(dt="1e-6"), TypeError, "simulate: dt must be a real number"),
    ("sim-dt0-str", lambda: sim(dt0="1e-7"), TypeError, "simulate: dt0 must be a real number"),
    (
        "sim-max-steps-float",
        lambda: sim(max_steps=1e5),
        TypeError,
        "simulate: max_steps must be an integer",
    ),
    (
        "sim-n-steps-str",
        lambda: sim(n_steps="10"),
        TypeError,
        "simulate: n_steps must be an integer",
    ),
    ("sim-n-steps-0", lambda: sim(n_steps=0), ValueError, "n_steps must be an integer >= 1"),
    (
        "sim-n-steps-rtol",
        lambda: sim(n_steps=10, rtol=1e-4),
        ValueError,
        "rtol=0.0001 set.s. the adaptive steps",
    ),
    (
        "sim-progress-str",
        lambda: sim(progress="yes"),
        TypeError,
        "simulate: progress must be True or False",
    ),
    (
        "sim-allow-float32-int",
        lambda: sim(allow_float32=1),
        TypeError,
        "allow_float32 must be True or False",
    ),
    ("sim-throw-str", lambda: sim(throw="no"), TypeError, "simulate: throw must be True or False"),
    ("sim-t1-str", lambda: jc.simulate(SCENE, "1e-4"), TypeError, "t1 must be a time"),
    ("sim-t0-str", lambda: sim(t0="0"), TypeError, "t0 must be a time"),
    ("sim-ts-str", lambda: sim(ts="ab"), TypeError, "ts must be a 1-D array of save times"),
    (
        "sim-ts-and-n-save",
        lambda: sim(ts=[0.0, 1e-4], n_save=5),
        ValueError,
        "give ts .* or n_save .*, not both",
    ),
    # ------------------------------------------------ elements with coordinates of their own
    (
        "dofs-no-inertia",
        lambda: jc.scenes.equilibrate(SCENE.add_elements(Bare())),
        TypeError,
        "equilibrate: Bare declares coordinates .* no dof_inertia",
    ),
    (
        "dofs-inertia-0",
        lambda: jc.scenes.equilibrate(SCENE.add_elements(Slide(inertia=0.0))),
        ValueError,
        r"Slide.dof_inertia\(scene\) must be finite and > 0",
    ),
    (
        "dofs-inertia-nan",
        lambda: sim(SCENE.add_elements(Slide(inertia=NAN))),
        ValueError,
        r"simulate: Slide.dof_inertia\(scene\) must be finite",
    ),
    (
        "dofs-inertia-shape",
        lambda: sim(SCENE.add_elements(Slide(inertia=[1.0, 2.0]))),
        ValueError,
        r"dof_inertia\(scene\) must have shape \(1,\)",
    ),
    (
        "dofs-start-shape",
        lambda: sim(SCENE.add_elements(Slide(start=[0.0, 1.0]))),
        ValueError,
        r"dof_start\(scene\)'s position must have shape \(1,\)",
    ),
    (
        "dofs-start-nan",
        lambda: jc.scenes.equilibrate(SCENE.add_elements(Slide(start=NAN))),
        ValueError,
        r"dof_start\(scene\)'s position must be finite",
    ),
    (
        "dofs-count-neg",
        lambda: jc.scenes.equilibrate(SCENE.add_elements(Slide(dofs=-1))),
        ValueError,
        r"n_dofs\(scene\) must return an integer >= 0",
    ),
    (
        "dofs-count-float",
        lambda: sim(SCENE.add_elements(Slide(dofs=1.0))),
        TypeError,
        r"n_dofs\(scene\) must return an integer",
    ),
    (
        "dofs-count-neg-init",
        lambda: jc.initial_state(SCENE.add_elements(Slide(dofs=-1))),
        ValueError,
        r"initial_state: Slide.n_dofs\(scene\) must return an integer >= 0",
    ),
    (
        "dofs-start-shape-init",
        lambda: jc.initial_state(SCENE.add_elements(Slide(start=[0.0, 0.0]))),
        ValueError,
        r"initial_state: Slide.dof_start\(scene\)'s position must have shape \(1,\)",
    ),
    (
        "dofs-spec-build",
        lambda: DS(settle=False, elements=(Slide(inertia=0.0),)).build(),
        ValueError,
        r"build: Slide.dof_inertia\(scene\) must be finite and > 0",
    ),
    # ------------------------------------------------ the chain model and the re-measurement
    (
        "model-restitution",
        lambda: CM(restitution=0.0),
        ValueError,
        r"restitution must be in \(0, 1\]",
    ),
    ("model-settle-str", lambda: CM(settle="no"), TypeError, "settle must be True or False"),
    ("model-form", lambda: CM(form="wide"), ValueError, "form must be one of"),
    ("model-shoe-law", lambda: CM(shoe_contact=1.0), TypeError, "shoe_contact must be"),
    ("model-load-ramp", lambda: CM(load_ramp=-1.0), ValueError, "load_ramp must be >= 0"),
    ("model-kind", lambda: jc.scenes.drive(model=0.5), TypeError, "model must be a jc.scenes"),
    ("model-unknown-kw", lambda: jc.scenes.drive(settel=False), TypeError, "'settel'"),
    ("peak-gate-str", lambda: jc.observers.PeakRecord(gate="yes"), TypeError, "gate must be"),
    ("max-steps-0", lambda: jc.SolveOptions(max_steps=0), ValueError, "max_steps must be a"),
    ("solve-each-threads", lambda: jc.design.solve_each(len, [[1]], "2"), TypeError, "threads"),
    (
        "normals-not-a-state",
        lambda: jc.roller_normal_forces(jc.initial_state(SCENE).q, SCENE),
        TypeError,
        "roller_normal_forces: y must be a jc.DriveState",
    ),
    (
        "sharp-peak-window",
        lambda: jc.design.sharp_peak(SCENE, 1e-3, t_start=2e-3),
        ValueError,
        r"t_start must be in \[0, 0.001\] s",
    ),
    ("remeasure-one-scene", lambda: jc.design.remeasure(SCENE, 1e-3), TypeError, "sequence"),
    (
        "sample-discard",
        lambda: jc.design.engagement_sample(SCENE, discard=-1),
        ValueError,
        "discard must be an integer >= 0",
    ),
]


@pytest.mark.parametrize(("call", "error", "match"), [c[1:] for c in BAD], ids=[c[0] for c in BAD])
def test_a_bad_input_at_a_new_door_is_refused(call, error, match, tmp_path):
    with pytest.raises(error, match=match):
        call(tmp_path) if getattr(call, "in_dir", False) else call()


def test_the_table_is_large_and_its_ids_unique():
    ids = [c[0] for c in BAD]
    assert len(ids) == len(set(ids)) and len(ids) >= 100


def test_good_inputs_in_other_spellings_are_accepted():
    """What the checks must not refuse: NumPy and 0-d array numbers, one guide alone,
    lists as events, a scalar ``outside`` in ``DriveSpec.of``."""
    assert (
        float(jc.loads.Harmonic(np.float64(2.0), ((np.int64(2), jnp.asarray(1.0), 0),)).mean) == 2
    )
    assert float(jc.loads.Constant(jnp.asarray(3.0)).value) == 3.0
    assert SP(np.int64(18), centre=np.array([0.0, 0.1]), load=np.float64(5.0)).teeth == 18
    assert DS.of("08B", (18, 36), outside=()).sprockets[1].outside is False
    assert len(jc.Engagements([0], [0], [0], [0.0], [0.0], [1.0], [0.0])) == 1
    assert jc.peak_statistics(np.array([1.0, 2.0], np.float32)).n == 2
    assert drive(guides=jc.scenes.Guide(span=1, length=0.04)).shoes.count == 1

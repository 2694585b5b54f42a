"""Every scene a builder makes with its defaults runs to the end with ``simulate``'s
defaults, in every fidelity (the span-level chain: drives only), at both ends of the
speed range (100 and 3000 rpm), over two tooth periods of the driver (a revolution for the
span-level chain); and so does a drive over three sprockets."""

import pytest

import jaxchain as jc

from helpers import modelled

pytestmark = pytest.mark.slow  # each clearance solve compiles for ~1 min


def _periods(scene, rpm, n=2.0):
    """``n`` tooth periods of the driver [s]."""
    return n * 60.0 / (int(scene.sprockets[0].profile.teeth) * rpm)


@pytest.mark.parametrize("chain", ["08B", "06C"])  # the default roller chain, a bush chain
@pytest.mark.parametrize("builder", ["engagement", "drive"])
@pytest.mark.parametrize("fidelity", ["lumped", "clearance"])
@pytest.mark.parametrize("rpm", [100.0, 3000.0])
def test_builder_defaults_run(chain, builder, fidelity, rpm):
    sc = getattr(jc.scenes, builder)(chain, speed_rpm=rpm, fidelity=fidelity)
    sol = jc.simulate(sc, _periods(sc, rpm))
    assert sol.ok and float(sol.peak_contact_force) > 0, sol.message


@pytest.mark.parametrize("fidelity", ["lumped", "clearance"])
def test_three_sprocket_drive_defaults_run(fidelity):
    """The timing drive's layout (crank 21, cams 42/42) with the builder's default contact
    slots: the slots cover every roller within reach of the large cams."""
    sc = jc.scenes.drive(
        "06B",
        teeth=(21, 42, 42),
        centres=((0.0, 0.0), (0.05, 0.25), (-0.1, 0.25)),
        load_torque=(5.0, 5.0),
        fidelity=fidelity,
    )
    sol = jc.simulate(sc, _periods(sc, 1000.0))
    assert sol.ok, sol.message


@pytest.mark.parametrize("rpm", [100.0, 3000.0])
def test_span_level_drive_defaults_run(rpm):
    """``fidelity="spans"`` (a drive's fidelity only): the defaults over a driver
    revolution, two and three sprockets, and with a default tensioner."""
    three = dict(
        teeth=(21, 42, 42), centres=((0.0, 0.0), (0.05, 0.25), (-0.1, 0.25)),
        load_torque=(5.0, 5.0),
    )  # fmt: skip
    for kw in ({}, three, three | dict(tensioner=jc.scenes.Tensioner())):
        sc = jc.scenes.drive(
            "06B" if kw else "08B", **modelled(speed_rpm=rpm, fidelity="spans", **kw)
        )
        sol = jc.simulate(sc, 60.0 / rpm)
        assert sol.ok, sol.message
        assert float(sol.link_tension.min()) > 0


@pytest.mark.parametrize("builder", ["engagement", "drive"])
@pytest.mark.parametrize("rpm", [100.0, 3000.0])
def test_lubricated_defaults_run(builder, rpm):
    """The clearance chain with hot engine oil in its joints (the film law's defaults)."""
    oil = jc.contact.OilFilm(viscosity=0.01)
    model = jc.scenes.ChainModel(lubrication=oil)
    sc = getattr(jc.scenes, builder)(speed_rpm=rpm, fidelity="clearance", model=model)
    sol = jc.simulate(sc, _periods(sc, rpm))
    assert sol.ok and float(sol.peak_contact_force) > 0, sol.message


def test_a_default_drive_runs_the_revolutions_asked_for():
    """A default-built 06B 21/42 drive at 1000 rpm takes ~1.6 µs steps: a fixed budget of
    200 000 steps ended it after 0.29 s; the budget that follows the horizon (2^20 steps
    for 0.35 s) runs it to the end (about 6 driver revolutions)."""
    sc = jc.scenes.drive("06B", (21, 42))
    sol = jc.simulate(sc, 0.35)
    assert sol.ok, sol.message
    assert int(sol.stats["num_steps"]) > 200_000  # past where the old budget ended it

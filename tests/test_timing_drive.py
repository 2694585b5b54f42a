"""The timing drive (06B, crank 21 at 3000 rpm, two 42-tooth cams, a tensioner on the slack
span, a straight guide on the tight span) as notebook 05 builds it: a short solve and its
outputs, the animation drawing the tensioner and the guide, a cam's tooth profile
differentiated through the solve (against central differences on fixed steps, and as the
step shrinks), and an ensemble of crank speeds (all slow: the scene settles in about 10 s
and compiles its own solve); the shoes' contact-slot check (default). The slow smoke run
of ``benchmarks/drives.py`` is here too."""

import dataclasses
import json

import equinox as eqx
import jax.numpy as jnp
import numpy as np
import pytest

import jaxchain as jc
from jaxchain._dynamics import contact_slots_ok, initial_state, roller_kinematics
from jaxchain._elements.shoes import shoe_contacts
from jaxchain.design import DesignSpace, ProfileObjective

from helpers import modelled

CHAIN = jc.ChainSpec.iso606("06B")
RPM = 3000.0
REV = 60.0 / RPM
# notebook 05's drive and solve (the compiled solve is shared through the persistent cache)
TIMING = dict(
    teeth=(21, 42, 42),
    centres=((0.0, 0.0), (0.05, 0.18), (-0.09, 0.18)),
    load_torque=2.0,
    pretension=150.0,
    tensioner=jc.scenes.Tensioner(span=0, shoe_radius=0.12, deflection=0.015, damping=0.02),
    guides=(jc.scenes.Guide(span=2, length=0.12),),
)
N_SAVE = 601


def timing_drive(speed_rpm=RPM, **kw):
    return jc.scenes.drive(CHAIN, **modelled(speed_rpm=speed_rpm, **{**TIMING, **kw}))


_shoe_contacts = eqx.filter_jit(shoe_contacts)  # eagerly, op by op, it takes seconds


def _with_shoe_slots(scene, slots):
    return eqx.tree_at(lambda s: s.shoes, scene, dataclasses.replace(scene.shoes, slots=slots))


@pytest.fixture(scope="module")
def unsettled():
    return timing_drive(settle=False)


def test_shoe_slots_are_checked(unsettled):
    """The builder checks every roller against the shoes of a 90-link drive (cheaper than
    picking the nearest); slots that cover the rollers within reach of each shoe pass the
    coverage check, too few fail it (a run's result would be contact_slots_exceeded), and
    a slot count below 1 is refused."""
    sc = unsettled
    assert sc.shoes.slots is None
    y = initial_state(sc)
    assert bool(contact_slots_ok(y, sc))
    assert bool(contact_slots_ok(y, _with_shoe_slots(sc, 30)))
    assert not bool(contact_slots_ok(y, _with_shoe_slots(sc, 4)))
    with pytest.raises(ValueError, match="slots must be an integer >= 1 or None"):
        _with_shoe_slots(sc, 0)


@pytest.mark.slow
def test_shoe_slots_that_cover_are_exact(unsettled):
    """Shoe forces from 30 slots (every roller within reach) equal those from every
    roller."""
    sc = unsettled
    y = initial_state(sc)
    xr, vr = roller_kinematics(y, sc)
    every = _shoe_contacts(y, sc, xr, vr, sc.roller_radius)
    assert float(jnp.sum(every.normal)) > 1.0  # the tensioner's shoe presses
    picked = _shoe_contacts(y, _with_shoe_slots(sc, 30), xr, vr, sc.roller_radius)
    np.testing.assert_allclose(picked.normal, every.normal, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(picked.resultant, every.resultant, rtol=1e-12, atol=1e-12)


@pytest.fixture(scope="module")
def timing():
    return timing_drive()


@pytest.fixture(scope="module")
def short(timing):
    """A tenth of a crank revolution, as notebook 05's fast mode runs it."""
    return jc.simulate(timing, 0.1 * REV, n_save=N_SAVE)


@pytest.mark.slow
def test_timing_drive_solve(timing, short):
    """The settled drive runs: the tensioner's and the guide's outputs are there and
    finite, the shoe presses on the chain, the cams turn at z1/zk of the crank."""
    sol = short
    assert sol.ok
    assert timing.n_links == 90 and len(timing.sprockets) == 3
    for out in (sol.tensioner_angle, sol.tensioner_force, sol.tensioner_torque, sol.guide_force):
        assert out.shape == (N_SAVE, 1)
        assert np.all(np.isfinite(np.asarray(out)))
    assert float(jnp.min(sol.tensioner_force)) >= 0.0
    assert float(jnp.mean(sol.tensioner_force)) > 5.0
    w = np.asarray(sol.sprocket_speed)
    for k in (1, 2):
        np.testing.assert_allclose(w[:, k].mean() / w[:, 0].mean(), 0.5, rtol=0.02)


@pytest.mark.slow
def test_animation_turns_the_tensioner(timing, short, tmp_path):
    """animate draws the tensioner's shoe and the guide; the shoe moves with its arm."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig = plt.figure()
    path = jc.animate(timing, short, tmp_path / "timing.gif", stride=300, dpi=30, fig=fig)
    assert path.stat().st_size > 1000
    ax = fig.axes[0]
    labels = [p.get_label() for p in ax.patches]
    assert labels.count("tensioner shoe") == 1 and labels.count("guide") == 1
    plt.close(fig)
    turn = np.ptp(np.asarray(short.tensioner_angle[:, 0]))
    assert turn > 0.0  # the arm moves, so the drawn shoe does


def _cam_objective(dt: float, t1: float) -> ProfileObjective:
    """The soft peak roller/tooth force over a short window, as a function of the first
    cam's ISO 606 tooth form (4 coordinates), on fixed steps with the design contact
    model (contact onset widened to 3 µm, joint friction over 2 cm/s)."""
    law = jc.scenes.roller_law(CHAIN, 0.7, width=3e-6)
    joints = jc.contact.CoulombFriction(coefficient=0.1, slip_velocity=2e-2)
    crank = jc.ToothProfile.iso606(CHAIN, 21, "mid")
    cam = jc.ToothProfile.iso606(CHAIN, 42, "mid")

    def build(profile):
        return timing_drive(
            profiles=(crank, profile, cam), roller_contact=law, joint_friction=joints
        )

    return ProfileObjective(
        DesignSpace.iso606(CHAIN, 42),
        build,
        t1=t1,
        temperature=20.0,
        reference=300.0,
        sprocket=1,
        dt=dt,
    )


@pytest.mark.slow
def test_cam_profile_gradient_matches_central_differences():
    """The gradient of the design objective in the first cam's tooth form, through the
    resettled statics and a fixed-step solve (100 steps of 1 µs), against central
    differences of the same discrete map: measured 4.5e-6 of the largest component."""
    obj = _cam_objective(1e-6, 1e-4)
    u0 = jnp.asarray([0.3, -0.2, 0.1, 0.2])
    scenes = obj.scenes(u0)
    value, grad, out = obj.value_and_grad_on(u0, scenes)
    assert bool(jnp.all(out.result == jc.Result.successful))
    grad = np.asarray(grad)
    assert np.all(np.isfinite(grad)) and np.abs(grad).max() > 1e-3
    np.testing.assert_allclose(float(obj.value_on(u0, scenes)[0]), float(value), rtol=1e-12)
    h = 1e-4
    fd = np.array(
        [
            (
                float(obj.value_on(u0.at[i].add(h), scenes)[0])
                - float(obj.value_on(u0.at[i].add(-h), scenes)[0])
            )
            / (2 * h)
            for i in range(4)
        ]
    )
    np.testing.assert_allclose(grad, fd, rtol=0, atol=5e-5 * np.abs(grad).max())


@pytest.mark.slow
def test_cam_profile_gradient_converges_as_the_step_shrinks():
    """At a soft-peak temperature of 200 N the fixed-step gradient in the cam's seat angle
    and flank radius converges as the step halves (measured: 1.9 % and 1.1 % between 1 and
    0.25 µs, 0.4 % and 0.2 % between 0.5 and 0.25 µs). Its seating-radius component does
    not on this window (0.020, 0.0027, 0.0054 N per unit u): the seat's clearance sets
    when and how hard the cam's rollers settle into their seats after the start."""
    base = _cam_objective(1e-6, 1e-4)
    u0 = jnp.asarray([0.3, -0.2, 0.1, 0.2])
    scenes = base.scenes(u0)
    grads = {}
    for dt in (1e-6, 5e-7, 2.5e-7):
        obj = ProfileObjective(
            base.space, base.build, t1=1e-4, temperature=200.0, reference=300.0, sprocket=1,
            dt=dt,
        )  # fmt: skip
        grads[dt] = np.asarray(obj.value_and_grad_on(u0, scenes)[1])[1:3]
    coarse = np.abs(grads[1e-6] / grads[2.5e-7] - 1)
    fine = np.abs(grads[5e-7] / grads[2.5e-7] - 1)
    assert np.all(fine < 0.01) and np.all(fine < coarse), (coarse, fine)


@pytest.mark.slow
def test_ensemble_of_crank_speeds(timing):
    """Timing drives at three crank speeds as one vmapped solve: every member succeeds,
    its cams turn at z1/zk of its crank, and the 3000 rpm member is the single solve's."""
    speeds = (2000.0, RPM, 4000.0)
    scenes = [timing_drive(r) if r != RPM else timing for r in speeds]
    t1 = 0.05 * REV
    ens = jc.simulate_ensemble(scenes, t1, n_save=11, group_waste=None)
    assert ens.ok, ens.messages
    for i, rpm in enumerate(speeds):
        w = np.asarray(ens.member(i).sprocket_speed)
        np.testing.assert_allclose(w[:, 0], rpm * np.pi / 30, rtol=1e-12)
        np.testing.assert_allclose(w[:, 1:].mean(axis=0) / w[:, 0].mean(), 0.5, rtol=0.02)
    # the same solve up to the batched arithmetic's round-off, which the impacts amplify:
    # measured 5.3e-7 m on the rollers, 2.6e-4 on the speeds, 0.45 N on the shoe after 1 ms
    single = jc.simulate(timing, t1, n_save=11)
    member = ens.member(1)
    np.testing.assert_allclose(member.roller_position, single.roller_position, atol=5e-6)
    np.testing.assert_allclose(member.sprocket_speed, single.sprocket_speed, rtol=2e-3)
    np.testing.assert_allclose(member.tensioner_force, single.tensioner_force, atol=2.0)
    np.testing.assert_allclose(member.tensioner_force[0], single.tensioner_force[0], rtol=1e-9)


@pytest.mark.slow
def test_drives_benchmark_quick(tmp_path):
    from benchmarks.drives import main

    res = main(["--quick", "--out", str(tmp_path)])
    rows = res["cost"]["lumped"]["rows"]
    assert {rows[n]["links"] for n in ("timing", "two_120")} == {120}
    assert all(r["result"] == "successful" for r in rows.values())
    assert all(r["wall_per_rev_s"] > 0 and r["cpu_per_simulated_s"] > 0 for r in rows.values())
    compile_rows = res["compile"]["lumped"]["rows"]
    assert [compile_rows[f"sprockets_{n}"]["sprockets"] for n in (2, 3, 5)] == [2, 3, 5]
    assert compile_rows["timing"]["shoes"] == 2
    assert json.loads((tmp_path / "drives.json").read_text())["study"] == "drives"
    assert (tmp_path / "drives.png").stat().st_size > 10_000

"""The clearance fidelity (rigid links, pin/bush and bush/roller clearance joints): settled
drives in static equilibrium, action = reaction, a short engagement solve."""

import jax.numpy as jnp
import numpy as np
import pytest

import jaxchain as jc
from jaxchain._dynamics import forces, initial_state

from helpers import modelled, tooth_period


@pytest.mark.parametrize("rollers", ["joint", "lumped"])
def test_clearance_drive_settles(rollers):
    """The clearance drive (pin/bush free play on every joint, and with ``"joint"`` the
    rollers' free play on their bushes too) starts in static equilibrium: every body
    balanced, the driven sprocket carrying its load, the spans tensioned by the take-up
    (tight − slack = load/R2, their mean the pretension) and nothing moved by a pitch."""
    kw = dict(
        teeth=(12, 24),
        n_links=40,
        load_torque=10.0,
        pretension=200.0,
        fidelity="clearance",
        rollers_on_bush=rollers,
    )
    sc = jc.scenes.drive("08B", **modelled(**kw))
    y = initial_state(sc)
    y = y._replace(v=jnp.zeros_like(y.v), omega=jnp.zeros_like(y.omega))
    fr = forces(0.0, y, sc)
    force_scale = 10.0 / float(sc.sprockets[1].profile.pitch_radius)  # the largest applied
    assert float(jnp.max(jnp.abs(fr.body[:, :2]))) <= 1e-6 * force_scale
    np.testing.assert_allclose(float(fr.sprocket_torque[1]), 10.0, rtol=1e-6)
    # every pin/bush joint carries tension; spans: tight − slack = load / R2
    layout = jc.scenes.drive("08B", **modelled(**kw, model=jc.scenes.ChainModel(settle=False)))
    moved = np.abs(np.asarray(sc.q0[:, :2] - layout.q0[:, :2])).max()
    assert moved < 0.1 * 0.0127
    tension = np.asarray(fr.element_tension)
    assert tension.min() > 0
    x = np.asarray(sc.q0[: sc.n_links, :2])
    r1 = float(sc.sprockets[0].profile.pitch_radius)
    c2 = float(sc.sprockets[1].centre[0])
    span = (x[:, 0] > r1 + 0.01) & (x[:, 0] < c2 - 0.03)
    link_t = np.asarray(sc.link_weights) @ tension
    top, bottom = span & (x[:, 1] > 0), span & (x[:, 1] < 0)
    r2 = float(sc.sprockets[1].profile.pitch_radius)
    np.testing.assert_allclose(link_t[top].mean() - link_t[bottom].mean(), 10.0 / r2, rtol=0.02)
    np.testing.assert_allclose(0.5 * (link_t[top].mean() + link_t[bottom].mean()), 200.0, rtol=0.05)


def test_clearance_fidelity_balances_and_runs():
    """Clearance model (rigid links, pin/bush and bush/roller joints): every joint and
    contact force has its reaction, a short solve of the engagement succeeds, and the
    strand settles by default (dynamic relaxation: the joints fall into contact)."""
    sc = jc.scenes.engagement("08B", 18, speed_rpm=1000, n_entry=6, fidelity="clearance")
    assert sc.fidelity == "clearance" and sc.n_bodies == 2 * sc.n_rollers - 1
    sol = jc.simulate(sc, 0.25 * tooth_period(1000, 18), n_save=51)  # 17 000 steps
    assert sol.ok and float(sol.peak_contact_force) > 100.0
    # action = reaction at the layout (settling is test_clearance_drive_settles')
    drive = jc.scenes.drive(
        "08B",
        teeth=(12, 24),
        n_links=40,
        fidelity="clearance",
        model=jc.scenes.ChainModel(settle=False),
    )
    y = initial_state(drive)
    fr = forces(0.0, y, drive)
    total = jnp.sum(fr.body[:, :2], 0) + jnp.sum(fr.sprocket_force, 0)
    assert float(jnp.max(jnp.abs(total))) <= 1e-8 * max(1.0, float(jnp.max(jnp.abs(fr.body))))

"""Ensembles: stacking, a vmapped ensemble equal to one-at-a-time ``simulate``, grouping by
cost to cut the steps a batched while loop throws away, failures per member, no retrace,
and sharding across (forced host) devices.

The default tests share one small strand (z = 9, 3 entry, 4 wrapped, 2 exit rollers,
``settle=False``: no statics to compile) at several speeds, solved with fixed steps scaled
to the speed (300 … 2000 rpm: 300 … 2000 steps), so every member's cost is known exactly
and the results of a batch equal the one-at-a-time solves to rounding. Two compiled
shapes (an ensemble of 4, the single solve), plus one in a subprocess, all in one test
(so each shape compiles once, however pytest-xdist distributes the tests).
"""

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxchain as jc
from jaxchain._solve.ensemble import _group_cost, _padded, _plan

from helpers import count_vector_field_calls, fixed_step_joints, modelled

ROOT = Path(__file__).resolve().parents[1]
SPEEDS = np.array([300.0, 800.0, 1400.0, 2000.0])  # rpm
T1 = 1.5e-3  # s: the rollers snap into their seats (violent start), ~0.2 tooth period
DT = 5e-6 * 300.0 / SPEEDS  # fixed steps ∝ 1/speed: 300 … 2000 steps
FIXED = dict(
    solver=diffrax.Tsit5(),
    stepsize_controller=diffrax.ConstantStepSize(),
    n_save=11,
    max_steps=2048,
)


def strand(rpm, teeth=9, **kw):
    # fixed steps of up to 5 µs: the joint friction's creep band widened to follow them
    kw = {"wrap": 4, "n_entry": 3, "n_exit": 2, "settle": False, **kw}
    kw.setdefault("joint_friction", fixed_step_joints())
    return jc.scenes.engagement("08B", teeth, **modelled(speed_rpm=rpm, **kw))


@pytest.fixture(scope="module")
def scenes():
    return [strand(r) for r in SPEEDS]


def test_stack_carries_a_member_axis_and_names_what_differs(scenes):
    st = jc.scenes.stack(scenes)
    assert st.q0.shape == (4, *scenes[0].q0.shape)
    np.testing.assert_allclose(st.sprockets[0].speed, SPEEDS * 2 * np.pi / 60)
    assert st.fidelity == "lumped" and st.roller_law.width == scenes[0].roller_law.width
    with pytest.raises(ValueError, match=r"scene 1 .* mass: shape \(9,\) vs \(10,\)"):
        jc.scenes.stack([strand(1000), strand(1000, n_entry=4)])  # one more link
    with pytest.raises(ValueError, match=r"sprockets\[0\]\.profile\.teeth: 9 vs 10"):
        jc.scenes.stack([strand(1000), strand(1000, teeth=10)])
    with pytest.raises(ValueError, match="scene 2 .*(fidelity|shape)"):
        jc.scenes.stack([strand(1000), strand(900), strand(1000, fidelity="clearance")])
    with pytest.raises(ValueError, match="already stacked"):
        jc.scenes.stack([st, st])
    with pytest.raises(ValueError, match="at least one"):
        jc.scenes.stack([])
    with pytest.raises(ValueError, match="stacked scene"):
        jc.simulate_ensemble(scenes[0], T1, dt0=DT[0], **FIXED)
    with pytest.raises(ValueError, match="dt0"):
        jc.simulate_ensemble(scenes, T1, dt0=DT[:3], **FIXED)
    with pytest.raises(ValueError, match="mesh or sharding"):
        jc.simulate_ensemble(scenes, T1, dt0=DT, sharding="auto", mesh=object(), **FIXED)


def matches_simulate(ens, scenes):
    """The vmapped solve is simulate's own jitted solve: same steps, same forces (a
    fixed-step solve, so rounding differences of batched arithmetic stay at rounding)."""
    singles = [jc.simulate(s, T1, dt0=h, **FIXED) for s, h in zip(scenes, DT, strict=True)]
    assert ens.ok and ens.n_members == 4 and ens.failed == []
    assert ens.messages == [""] * 4 and ens.result_names == ["successful"] * 4
    np.testing.assert_array_equal(ens.steps, [int(s.stats["num_steps"]) for s in singles])
    np.testing.assert_array_equal(ens.steps, np.round(T1 / DT))
    peaks = np.array([float(s.peak_contact_force) for s in singles])
    np.testing.assert_allclose(ens.peak_contact_force, peaks, rtol=1e-9)
    assert peaks.min() > 1000.0  # rollers snap into their seats: real contact forces
    for i, s in enumerate(singles):
        np.testing.assert_allclose(ens.roller_sprocket_force[i], s.roller_sprocket_force, atol=1e-6)
        np.testing.assert_allclose(ens.roller_position[i], s.roller_position, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(ens.link_tension[i], s.link_tension, rtol=1e-9, atol=1e-6)
        m = ens.member(i)
        assert m.ok and float(m.peak_contact_force) == float(ens.peak_contact_force[i])
    np.testing.assert_allclose(ens.ts, singles[0].ts)
    # one batch runs 4 × 2000 steps for 4500 needed
    assert ens.groups == ((0, 1, 2, 3),) and ens.batch_sizes == (4,)
    assert int(ens.steps_executed) == 4 * 2000 and float(ens.waste) > 1.5


def grouping_cuts_the_waste():
    """Eight members, four slow and four fast (fixed steps ∝ 1/speed, so the costs are
    known): one batch would run 8 × 2000 steps for 8600 needed (waste 1.86); grouped by
    cost into two batches of four (the shape compiled already), the waste is
    (4·2000 + 4·450)/8600 = 1.14, and every member keeps its own result and place."""
    speeds = np.array([1600.0, 300.0, 2000.0, 400.0, 350.0, 1800.0, 450.0, 1700.0])
    dt = 5e-6 * 300.0 / speeds
    scs = [strand(r) for r in speeds]
    ens = jc.simulate_ensemble(scs, T1, dt0=dt, group_waste=1.5, **FIXED)
    steps = np.asarray(ens.steps)
    np.testing.assert_array_equal(steps, np.round(T1 / dt))  # members in the order given
    np.testing.assert_allclose(ens.predicted_steps, steps)
    assert 8 * steps.max() / steps.sum() > 1.5  # one batch
    assert ens.groups == ((2, 5, 7, 0), (6, 3, 4, 1)) and ens.batch_sizes == (4, 4)
    assert int(ens.steps_executed) == 4 * 2000 + 4 * 450
    assert float(ens.waste) <= 1.5
    assert ens.ok and np.all(np.asarray(ens.peak_contact_force) > 1000.0)
    # each member's result is its own: the slowest alone, against its batch of four
    alone = jc.simulate_ensemble([scs[2]] * 4, T1, dt0=np.full(4, dt[2]), **FIXED)
    np.testing.assert_allclose(alone.peak_contact_force[0], ens.peak_contact_force[2], rtol=1e-9)


def failures_are_per_member(scenes, one_batch):
    """Member 1 with a fixed step ×20 above the others' (above Tsit5's stability
    limit): it alone is reported diverged; the others are untouched."""
    dt = DT.copy()
    dt[1] = 60e-6
    ens = jc.simulate_ensemble(scenes, T1, dt0=dt, group_waste=None, throw=False, **FIXED)
    assert ens.failed == [1] and not ens.ok
    assert ens.result_names == ["successful", "diverged", "successful", "successful"]
    assert "dt0" in ens.messages[1] and ens.messages[0] == ""
    keep = np.array([0, 2, 3])
    np.testing.assert_allclose(
        ens.peak_contact_force[keep], one_batch.peak_contact_force[keep], rtol=1e-12
    )
    with pytest.raises(RuntimeError, match=r"(?s)1 of 4 members failed .*member 1: diverged"):
        jc.simulate_ensemble(scenes, T1, dt0=dt, group_waste=None, **FIXED)


def second_call_does_not_retrace(scenes, one_batch, monkeypatch):
    import jaxchain._solve.ensemble as E

    calls = count_vector_field_calls(monkeypatch)
    cache = E._solve_batch._cached._cache_size()
    # new speeds, a new profile leaf, new t1 and steps: same structure and batch size
    new = [strand(r) for r in SPEEDS * 1.1]
    new[2] = eqx.tree_at(
        lambda s: s.sprockets[0].profile.seating_radius,
        new[2],
        new[2].sprockets[0].profile.seating_radius * 1.01,
    )
    ens = jc.simulate_ensemble(new, 0.9 * T1, dt0=0.9 * DT, group_waste=None, **FIXED)
    assert ens.ok and len(calls) == 0
    mesh = E._resolve_mesh(None, None)  # the default one-device mesh, given explicitly
    ens = jc.simulate_ensemble(scenes, T1, dt0=DT, group_waste=None, mesh=mesh, **FIXED)
    assert len(calls) == 0 and E._solve_batch._cached._cache_size() == cache
    np.testing.assert_allclose(ens.peak_contact_force, one_batch.peak_contact_force, rtol=1e-12)
    monkeypatch.undo()


SHARDED = """
import json, sys
import jax
jax.config.update("jax_enable_x64", True)
import numpy as np
sys.path.insert(0, {tests!r})
from test_ensembles import DT, FIXED, SPEEDS, T1, strand
import jaxchain as jc

assert jax.device_count() == 4, jax.devices()
ens = jc.simulate_ensemble([strand(r) for r in SPEEDS], T1, dt0=DT, group_waste=None,
                           sharding="auto", **FIXED)
shards = ens.roller_sprocket_force.addressable_shards
print(json.dumps({{
    "peak": np.asarray(ens.peak_contact_force).tolist(),
    "force": np.asarray(ens.roller_sprocket_force).tolist(),
    "steps": np.asarray(ens.steps).tolist(),
    "steps_executed": int(ens.steps_executed),
    "n_devices": ens.n_devices,
    "devices": len(ens.peak_contact_force.sharding.device_set),
    "shard_rows": sorted(s.data.shape[0] for s in shards),
    "shard_devices": len({{s.device for s in shards}}),
}}))
"""


def start_sharded():
    """XLA_FLAGS must be set before jax is imported: a subprocess with 4 host devices,
    started first so that it compiles while this process works."""
    env = dict(os.environ)
    flags = env.get("XLA_FLAGS", "") + " --xla_force_host_platform_device_count=4"
    env["XLA_FLAGS"] = flags.strip()
    env["JAX_PLATFORMS"] = "cpu"
    code = SHARDED.format(tests=str(ROOT / "tests"))
    return subprocess.Popen(
        [sys.executable, "-c", textwrap.dedent(code)],
        env=env,
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def sharded_equals_unsharded(proc, one_batch):
    """One member per device, each device's while loop stops with its own member: no
    step is wasted (one device: 4 × 2000 executed for 4500 needed); same results, the
    output spread over the 4 devices."""
    out, err = proc.communicate(timeout=600)
    assert proc.returncode == 0, err[-3000:]
    res = json.loads(out.strip().splitlines()[-1])
    assert res["n_devices"] == 4 and res["devices"] == 4 and res["shard_devices"] == 4
    assert res["shard_rows"] == [1, 1, 1, 1]
    np.testing.assert_allclose(res["peak"], one_batch.peak_contact_force, rtol=1e-9)
    np.testing.assert_allclose(res["force"], one_batch.roller_sprocket_force, atol=1e-6)
    np.testing.assert_array_equal(res["steps"], one_batch.steps)
    assert res["steps_executed"] == int(np.sum(one_batch.steps))  # waste 1.0


def test_ensembles_batched_grouped_per_member_failures_no_retrace(scenes, monkeypatch):
    """One test for everything that shares the compiled batch of four (it compiles once
    however pytest-xdist distributes the tests): equal to one-at-a-time ``simulate``,
    grouping by cost, failures per member, no retrace."""
    one_batch = jc.simulate_ensemble(scenes, T1, dt0=DT, group_waste=None, **FIXED)
    matches_simulate(one_batch, scenes)
    grouping_cuts_the_waste()
    failures_are_per_member(scenes, one_batch)
    second_call_does_not_retrace(scenes, one_batch, monkeypatch)


@pytest.mark.slow  # a subprocess on the worker's core: ~15 s of its own compile
def test_ensembles_sharded_over_4_host_devices(scenes):
    """The batch of four sharded over 4 host devices (a subprocess, run alongside) equals
    the batch on one device."""
    proc = start_sharded()
    try:
        one_batch = jc.simulate_ensemble(scenes, T1, dt0=DT, group_waste=None, **FIXED)
        sharded_equals_unsharded(proc, one_batch)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()


def test_plan_groups_are_contiguous_padded_and_within_the_waste():
    rng = np.random.default_rng(0)
    for n_dev in (1, 4):
        for m in (1, 3, 17, 64):
            pred = rng.lognormal(7.0, 0.8, m)
            groups = _plan(pred, 1.5, n_dev)
            flat = np.concatenate(groups)
            assert sorted(flat) == list(range(m))
            assert np.all(np.diff(pred[flat]) <= 0)  # sorted, cut into contiguous runs
            for g in groups:
                size = _padded(len(g), n_dev)
                assert size % n_dev == 0 and (size // n_dev) & (size // n_dev - 1) == 0
                waste = _group_cost(pred[g], size, n_dev) / pred[g].sum()
                # within the target, or the least wasteful choice there was (a lone
                # member still fills every device's slot)
                assert waste <= 1.5 or len(g) <= n_dev, (n_dev, m, waste)
    # equal costs: one batch
    assert len(_plan(np.full(8, 100.0), 1.5, 1)) == 1


@pytest.mark.slow
def test_adaptive_pilot_grouping_on_speeds_and_loads():
    """Adaptive solves: members differ in steps (speed, tension); the loose-tolerance
    pilot predicts them, grouping brings the waste of one batch (> 1.5) to ≤ 1.5, and
    every member agrees with its one-at-a-time solve to the solver's tolerance (the
    accept/reject decisions of a batched solve can flip on last-bit differences of
    vectorized arithmetic, so agreement is at the tolerance, not at rounding)."""
    points = [(300, 200), (300, 1000), (1000, 200), (1000, 1000), (1000, 4000), (3000, 1000)]
    period = 60.0 / 1000.0 / 18
    scs = [strand(r, teeth=18, wrap=9, n_entry=8, tension=t) for r, t in points]
    kw = dict(n_save=11, max_steps=8192)
    one = jc.simulate_ensemble(scs, period, group_waste=None, **kw)
    grouped = jc.simulate_ensemble(scs, period, **kw)
    assert one.ok and grouped.ok
    assert float(one.waste) > 1.5, (one.steps, float(one.waste))
    assert float(grouped.waste) <= 1.5, (grouped.steps, grouped.groups, float(grouped.waste))
    assert len(grouped.groups) > 1 and grouped.predicted_steps is not None
    singles = [jc.simulate(s, period, **kw) for s in scs]
    peaks = np.array([float(s.peak_contact_force) for s in singles])
    # each adaptive peak is within ~0.5 % of the converged one at rtol 1e-6
    # (tests/test_engagement.py::test_peak_force_self_converges): two solves within 1 %
    np.testing.assert_allclose(grouped.peak_contact_force, peaks, rtol=1e-2)
    np.testing.assert_allclose(one.peak_contact_force, peaks, rtol=1e-2)


@pytest.mark.slow
def test_gradient_through_the_ensemble_equals_the_members_gradients(scenes):
    """Inside the caller's grad the ensemble is one vmapped batch (no pilot, no
    shard_map): d(mean peak)/d(seating radius) equals the mean of the one-at-a-time
    gradients of ``simulate``."""
    stacked = jc.scenes.stack(scenes)
    radius = lambda s: s.sprockets[0].profile.seating_radius
    r0 = float(radius(scenes[0]))

    dt = float(DT.min())  # one step for all: one compiled single-member gradient

    def ensemble(r):
        sc = eqx.tree_at(radius, stacked, jnp.full(len(scenes), r))
        ens = jc.simulate_ensemble(sc, T1, dt0=dt, throw=False, **FIXED)
        return jnp.mean(ens.peak_contact_force)

    def single(r, scene):
        sc = eqx.tree_at(radius, scene, r)
        return jc.simulate(sc, T1, dt0=dt, throw=False, **FIXED).peak_contact_force

    g = float(jax.jit(jax.grad(ensemble))(r0))
    g1 = eqx.filter_jit(jax.grad(single))
    ref = np.mean([float(g1(r0, s)) for s in scenes])
    assert np.isfinite(g) and abs(g) > 0
    np.testing.assert_allclose(g, ref, rtol=1e-8)


@pytest.mark.slow
def test_ensembles_benchmark_quick(tmp_path):
    from benchmarks.ensembles import main

    res = main(["--quick", "--out", str(tmp_path)])
    saved = json.loads((tmp_path / "ensembles.json").read_text())
    assert saved["quick"] and set(res) <= set(saved)
    assert all(r["members_per_s"] > 0 for r in saved["throughput"]["rows"])
    assert all(r["waste_one_batch"] >= 1.0 for r in saved["waste"]["rows"])
    # adaptive solves: sharded and one-device batches agree to the solver's tolerance
    assert saved["sharding"]["devices"] == 4 and saved["sharding"]["max_rel_diff_peak"] < 1e-2
    assert saved["sharding"]["output_devices"] == 4
    g = saved["gradient"]
    assert g["grad_over_forward_every_step_checkpointed"] > 0 and g["grad_vs_fd_rel"] < 1e-3
    assert all(r["retraced"] is False for r in saved["compile"]["rows"])
    assert (tmp_path / "ensembles.png").stat().st_size > 10_000

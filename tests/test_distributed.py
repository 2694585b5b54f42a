"""Ensembles across processes (JAX's multi-process runtime, gloo CPU collectives), tested
with local processes started by ``python -m jaxchain.launch``.

The default tests are cheap: the split of members among processes and the launcher's
handling of a process that exits early (processes that do not import JAX). The slow
test runs one worker program as 2 processes × 1 CPU device and as 1 process and compares:
an uneven ensemble (5 members: 3 + 2 and one padding row) of the small fixed-step strand
of ``test_ensembles``, each process building only its own members; a member that
diverges; and the design objective's value and gradient (soft maximum over 3 members).
Each process compiles its own solves, so it is slow on two shared cores (a few minutes).

    python -m pytest -n 0 -m slow tests/test_distributed.py    # or .ci/distributed
"""

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from jaxchain._solve.distributed import Split
from jaxchain.launch import launch

ROOT = Path(__file__).resolve().parents[1]
TESTS = ROOT / "tests"


# ------------------------------------------------------------------ cheap (default)
@pytest.mark.parametrize(
    ("members", "processes", "rows", "slots"),
    [
        (5, 2, 3, [(0, 1, 2), (3, 4, 4)]),  # uneven: the last share padded
        (4, 2, 2, [(0, 1), (2, 3)]),
        (1, 2, 1, [(0,), (0,)]),  # a process without members pads with the last member
        (3, 4, 1, [(0,), (1,), (2,), (2,)]),
        (16, 2, 8, [tuple(range(8)), tuple(range(8, 16))]),
    ],
)
def test_split_shares_contiguous_padded_rows(members, processes, rows, slots):
    shares = [Split(members, processes, p, rows) for p in range(processes)]
    assert [s.slots for s in shares] == slots
    assert all(len(s.slots) == rows for s in shares)
    # member i sits at row i of the global axis; the rows past the last are padding
    rows_of = [i for s in shares for i in s.slots]
    assert rows_of[:members] == list(range(members))
    assert sorted(i for s in shares for i in s.local) == list(range(members))
    assert shares[0].padded == rows * processes


def test_one_process_split_and_initialize_without_a_launcher(monkeypatch):
    import jaxchain as jc

    for name in ("JAXCHAIN_COORDINATOR", "SLURM_NTASKS", "OMPI_COMM_WORLD_SIZE"):
        monkeypatch.delenv(name, raising=False)
    assert jc.distributed.initialize() is False  # nothing to join: one process
    assert jc.distributed.split(3) == Split(3, 1, 0, 3)
    with pytest.raises(ValueError, match="at least one member"):
        jc.distributed.split(0)
    with pytest.raises(ValueError, match="together"):
        jc.distributed.initialize("127.0.0.1:1234", 2)
    with pytest.raises(ValueError, match="process_id must be in"):
        jc.distributed.initialize("127.0.0.1:1234", 2, 2)
    with pytest.raises(ValueError, match="heartbeat_timeout"):
        jc.distributed.initialize(heartbeat_timeout=0)


def test_launcher_validates_and_names_a_process_that_exits_early(tmp_path, capfd):
    with pytest.raises(ValueError, match="integer >= 1"):
        launch([sys.executable, "-c", "pass"], 0)
    with pytest.raises(ValueError, match="give the program"):
        launch([], 2)
    with pytest.raises(ValueError, match="port"):
        launch([sys.executable, "-c", "pass"], 2, port=70000)
    # rank 1 fails at once; rank 0 would run for a minute: it is stopped, not waited for
    code = textwrap.dedent(
        """
        import os, sys, time
        rank = int(os.environ["JAXCHAIN_PROCESS_ID"])
        assert os.environ["JAXCHAIN_NUM_PROCESSES"] == "2"
        assert os.environ["JAXCHAIN_COORDINATOR"].startswith("127.0.0.1:")
        if rank == 1:
            sys.exit(3)
        time.sleep(60)
        """
    )
    script = tmp_path / "early.py"
    script.write_text(code)
    rc = launch([sys.executable, str(script)], 2, grace=2.0, settle=0.3)
    err = capfd.readouterr().err
    assert rc == 3
    assert "process 1 of 2" in err and "exited with code 3" in err
    assert "stopped processes [0]" in err
    assert launch([sys.executable, "-c", "pass"], 2) == 0


def test_launcher_command_line(monkeypatch):
    import jaxchain.launch as launcher

    seen = []
    monkeypatch.setattr(launcher, "launch", lambda cmd, n, **kw: seen.append((n, cmd[1:])) or 0)
    # everything after -m MODULE (or after the script) belongs to the program
    assert launcher.main(["-n", "2", "-m", "optimize", "--fast", "-n", "3"]) == 0
    assert launcher.main(["-n", "3", "run.py", "--out", "x", "-m", "y"]) == 0
    assert seen == [
        (2, ["-m", "optimize", "--fast", "-n", "3"]),
        (3, ["run.py", "--out", "x", "-m", "y"]),
    ]
    for argv in (["-n", "2"], ["-n", "2", "-m"]):
        with pytest.raises(SystemExit):
            launcher.main(argv)


# ------------------------------------------------------------------ slow: 2 processes vs 1
WORKER = """
import json, sys
import jax
import jaxchain as jc

jc.distributed.initialize()
jax.config.update("jax_enable_x64", True)
import numpy as np
sys.path.insert(0, {tests!r})
from test_design import CHAIN, DESIGN_LAW, DESIGN_JOINTS, SPACE
from test_ensembles import FIXED, T1, strand

out = {{"processes": jax.process_count(), "devices": jax.device_count()}}
# an uneven ensemble (5 members), each process building only its own
speeds = np.array([300.0, 800.0, 1400.0, 2000.0, 600.0])
dt = 5e-6 * 300.0 / speeds
built = []
local = jc.distributed.local_members(5, lambda i: built.append(i) or strand(speeds[i]))
ens = jc.simulate_ensemble(local, T1, dt0=dt, sharding="auto", **FIXED)
out["built"] = built
out["peak"] = np.asarray(ens.peak_contact_force).tolist()
out["force"] = np.asarray(ens.roller_sprocket_force).tolist()
out["steps"] = np.asarray(ens.steps).tolist()
out["steps_executed"] = int(ens.steps_executed)
out["n_devices"] = ens.n_devices

# member 3 (held by process 1 of 2) diverges: a fixed step far above the stability limit
bad = dt.copy()
bad[3] = 2e-4
ens = jc.simulate_ensemble(
    [strand(r) for r in speeds], T1, dt0=bad, sharding="auto", throw=False, **FIXED
)
out["diverged_names"] = ens.result_names
out["diverged_failed"] = ens.failed

# the design objective: soft maximum over 3 operating points (uneven: 2 + 1)
PERIOD = 60.0 / (18 * 1000.0)

def build(profile):
    return jc.distributed.local_members(3, lambda i: jc.scenes.engagement(
        CHAIN, 18, speed_rpm=1000.0 * (0.9, 1.0, 1.1)[i], profile=profile, n_entry=3,
        roller_contact=DESIGN_LAW, joint_friction=DESIGN_JOINTS))

obj = jc.design.ProfileObjective(
    SPACE, build, t1=1.5 * PERIOD, t_start=0.5 * PERIOD, temperature=50.0,
    reference=2000.0, dt=4e-6, combine="max", sharding="auto")
u = np.array([0.3, -0.5, 0.2, 0.1])
value, grad, members = obj.value_and_grad(u)
out["value"] = float(value)
out["grad"] = np.asarray(grad).tolist()
out["member_values"] = np.asarray(members.value).tolist()
out["member_codes"] = jc.result_names(members.result)
out["evaluations"] = obj.evaluations
if jax.process_count() == 1:  # the default formulation: a reverse pass through the max
    obj.sharding = None
    scenes = jc.scenes.stack([jc.scenes.engagement(
        CHAIN, 18, speed_rpm=1000.0 * f, profile=SPACE.profile(u), n_entry=3,
        roller_contact=DESIGN_LAW, joint_friction=DESIGN_JOINTS) for f in (0.9, 1.0, 1.1)])
    value, grad, _ = obj.value_and_grad_on(u, scenes)
    out["default_value"], out["default_grad"] = float(value), np.asarray(grad).tolist()
with open(sys.argv[1] + f".{{jax.process_index()}}.json", "w") as f:
    json.dump(out, f)
"""


def _start(script: Path, result: Path, processes: int | None) -> subprocess.Popen:
    env = dict(os.environ, JAX_PLATFORMS="cpu", EQX_ON_ERROR="nan")
    env.pop("XLA_FLAGS", None)  # one CPU device per process
    if processes is None:  # one plain process, no launcher
        cmd = [sys.executable, str(script), str(result)]
    else:
        cmd = [sys.executable, "-m", "jaxchain.launch", "-n", str(processes)]
        cmd += [str(script), str(result)]
    return subprocess.Popen(cmd, env=env, cwd=ROOT, stderr=subprocess.PIPE, text=True)


@pytest.mark.slow
def test_two_processes_match_one(tmp_path):
    script = tmp_path / "worker.py"
    script.write_text(textwrap.dedent(WORKER.format(tests=str(TESTS))))
    two = _start(script, tmp_path / "two", 2)
    one = _start(script, tmp_path / "one", None)
    for p in (two, one):
        _, err = p.communicate(timeout=1500)
        assert p.returncode == 0, err[-4000:]
    ref = json.loads((tmp_path / "one.0.json").read_text())
    runs = [json.loads((tmp_path / f"two.{r}.json").read_text()) for r in (0, 1)]
    assert ref["processes"] == 1 and ref["built"] == [0, 1, 2, 3, 4]
    # each process built its own members only (the last share padded with its last)
    assert runs[0]["built"] == [0, 1, 2] and runs[1]["built"] == [3, 4]
    for r in runs:
        assert r["processes"] == 2 and r["devices"] == 2 and r["n_devices"] == 2
        # complete on every process: all 5 members, in order, padding dropped. A vmapped
        # batch's width (3 rows here, groups of 1-2 in one process) changes the
        # floating-point schedule of its members, which the impacts amplify (measured:
        # 3.2e-11 of member 0's peak; 1.2e-11 of the largest saved force, one member)
        np.testing.assert_allclose(r["peak"], ref["peak"], rtol=1e-9, atol=0)
        f, f_ref = np.asarray(r["force"]), np.asarray(ref["force"])
        assert np.max(np.abs(f - f_ref)) <= 1e-9 * np.max(np.abs(f_ref))
        assert r["steps"] == ref["steps"] == [300, 800, 1400, 2000, 600]
        # each device's loop runs to its slowest row: 3·1400 + 3·2000
        assert r["steps_executed"] == 3 * 1400 + 3 * 2000
        # the diverging member's code, on every process
        assert r["diverged_failed"] == [3] == ref["diverged_failed"]
        assert r["diverged_names"] == ref["diverged_names"]
        assert r["diverged_names"][3] == "diverged"
        # the design objective: same members, value and gradient to round-off
        assert r["member_codes"] == ["successful"] * 3
        np.testing.assert_allclose(r["member_values"], ref["member_values"], rtol=1e-12)
        np.testing.assert_allclose(r["value"], ref["value"], rtol=1e-12)
        g, g_ref = np.asarray(r["grad"]), np.asarray(ref["grad"])
        assert np.max(np.abs(g - g_ref)) <= 1e-12 * np.max(np.abs(g_ref))
        assert r["evaluations"] == ref["evaluations"] == 3
    assert np.all(np.isfinite(ref["grad"])) and np.max(np.abs(ref["grad"])) > 0
    # the default objective (reverse pass through the soft maximum) agrees to round-off
    # of the backward pass (measured 1.5e-11 of the largest entry)
    np.testing.assert_allclose(ref["default_value"], ref["value"], rtol=1e-12)
    g_def = np.asarray(ref["default_grad"])
    assert np.max(np.abs(g_def - g_ref)) <= 1e-9 * np.max(np.abs(g_ref))


@pytest.mark.slow
@pytest.mark.parametrize(
    ("death", "code"), [("os._exit(7)", 7), ("raise ValueError('no scene for member 3')", 1)]
)
def test_launcher_stops_the_run_when_a_process_dies_in_a_collective(tmp_path, death, code):
    """Process 1 dies after joining (killed, or an uncaught exception); process 0 waits
    for it in an all-gather: gloo sees the closed connection, process 0 fails, and the
    launcher names process 1."""
    script = tmp_path / "dies.py"
    script.write_text(
        textwrap.dedent(
            f"""
            import os
            import jax
            import jaxchain as jc
            assert jc.distributed.initialize()
            import numpy as np
            jc.distributed.gather(np.zeros(1))  # both joined
            if jax.process_index() == 1:
                {death}
            jc.distributed.gather(np.zeros(1))
            raise SystemExit("process 0 went on without process 1")
            """
        )
    )
    env = dict(os.environ, JAX_PLATFORMS="cpu")
    env.pop("XLA_FLAGS", None)
    p = subprocess.run(
        [sys.executable, "-m", "jaxchain.launch", "-n", "2", "--heartbeat-timeout", "10"]
        + [str(script)],
        env=env,
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert p.returncode == code, p.stderr[-3000:]
    assert "process 1 of 2 (pid" in p.stderr and f"exited with code {code}" in p.stderr
    assert "went on without" not in p.stderr
    if code == 1:  # what ended it, from the process itself
        assert "(raised ValueError: no scene for member 3)" in p.stderr


@pytest.mark.slow
def test_benchmark_smoke(tmp_path):
    """benchmarks/multiprocess.py --quick: 1 process against 2, 4 members."""
    env = dict(os.environ, EQX_ON_ERROR="nan")
    p = subprocess.run(
        [sys.executable, "-m", "benchmarks.multiprocess", "--quick", "--members", "4"]
        + ["--out", str(tmp_path)],
        env=env,
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=1200,
    )
    assert p.returncode == 0, p.stderr[-3000:]
    res = json.loads((tmp_path / "multiprocess.json").read_text())
    one, two = res["configs"]
    assert one["processes"] == 1 and two["processes"] == 2 and two["same_on_every_process"]
    # adaptive steps: a batch's width changes its rounding, and with it where the
    # controller puts the steps that sample the peak (measured 6.5e-5 at rtol 1e-6)
    assert one["throughput"]["peak_N"] == pytest.approx(two["throughput"]["peak_N"], rel=1e-3)
    assert two["throughput"]["all_successful"] and two["design"]["gather_ms_median"] > 0
    assert "load average" in two["uptime_before"]
    assert (tmp_path / "multiprocess.png").exists()

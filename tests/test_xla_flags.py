"""The XLA flag of the main job and the test suite (optimize/xla_flags.py), and the test
workers' cores (tests/xla_flags.py)."""

from xla_flags import worker_core

from optimize.xla_flags import FLAG, MEASURED, fast_compile


def test_compile_flag_only_where_measured():
    """The XLA flag: added for a measured jaxlib release, kept as the user
    set it, never duplicated, left out for other releases (an unknown flag aborts XLA)."""
    env = {"XLA_FLAGS": "--xla_dump_to=/tmp/x"}
    assert fast_compile(env, MEASURED[0]) and env["XLA_FLAGS"] == f"--xla_dump_to=/tmp/x {FLAG}"
    assert fast_compile(env, MEASURED[0]) and env["XLA_FLAGS"].count(FLAG) == 1
    mine = {"XLA_FLAGS": "--xla_cpu_use_fusion_emitters=true"}
    assert not fast_compile(mine, MEASURED[0])
    assert mine["XLA_FLAGS"] == "--xla_cpu_use_fusion_emitters=true"
    other = {}
    assert not fast_compile(other, (99, 0)) and "XLA_FLAGS" not in other


def test_each_worker_its_own_core_when_there_are_enough():
    env = lambda w, n: {"PYTEST_XDIST_WORKER": w, "PYTEST_XDIST_WORKER_COUNT": str(n)}  # noqa: E731
    assert [worker_core(env(f"gw{i}", 2), [3, 1]) for i in range(2)] == [1, 3]
    assert worker_core(env("gw0", 3), [0, 1]) is None  # more workers than cores: unpinned
    assert worker_core({}, [0, 1]) is None  # not under xdist

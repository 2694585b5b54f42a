"""The test suite's XLA flag (tests/xla_flags.py)."""

from xla_flags import FLAG, MEASURED, fast_compile


def test_compile_flag_only_where_measured():
    """The test suite's XLA flag: added for a measured jaxlib release, kept as the user
    set it, never duplicated, left out for other releases (an unknown flag aborts XLA)."""
    env = {"XLA_FLAGS": "--xla_dump_to=/tmp/x"}
    assert fast_compile(env, MEASURED[0]) and env["XLA_FLAGS"] == f"--xla_dump_to=/tmp/x {FLAG}"
    assert fast_compile(env, MEASURED[0]) and env["XLA_FLAGS"].count(FLAG) == 1
    mine = {"XLA_FLAGS": "--xla_cpu_use_fusion_emitters=true"}
    assert not fast_compile(mine, MEASURED[0])
    assert mine["XLA_FLAGS"] == "--xla_cpu_use_fusion_emitters=true"
    other = {}
    assert not fast_compile(other, (99, 0)) and "XLA_FLAGS" not in other

"""The test suite's XLA flags (tests/xla_flags.py)."""

from xla_flags import FLAGS, MEASURED, fast_compile

OURS = [f"--{name}={value}" for name, value in FLAGS.items()]


def test_compile_flags_only_where_measured():
    """The test suite's XLA flags: added for a measured jaxlib release, kept as the user
    set them, never duplicated, left out for other releases (an unknown flag aborts XLA)."""
    env = {"XLA_FLAGS": "--xla_dump_to=/tmp/x"}
    assert fast_compile(env, MEASURED[0])
    assert env["XLA_FLAGS"] == " ".join(["--xla_dump_to=/tmp/x", *OURS])
    assert fast_compile(env, MEASURED[0]) and env["XLA_FLAGS"].split().count(OURS[0]) == 1
    mine = {"XLA_FLAGS": "--xla_cpu_use_fusion_emitters=true"}
    assert not fast_compile(mine, MEASURED[0])
    assert mine["XLA_FLAGS"].split() == ["--xla_cpu_use_fusion_emitters=true", *OURS[1:]]
    other = {}
    assert not fast_compile(other, (99, 0)) and "XLA_FLAGS" not in other

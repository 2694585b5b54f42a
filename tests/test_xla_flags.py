"""The XLA flag and the caches' folder of the main job and the test suite
(optimize/xla_flags.py), and the test workers' cores (tests/xla_flags.py)."""

from pathlib import Path

import pytest
from xla_flags import worker_core

from optimize.xla_flags import (
    CACHE_SIZE,
    FLAG,
    MEASURED,
    fast_compile,
    prune_cache,
    use_user_cache,
    user_cache,
)


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


def test_the_caches_are_the_users_unless_set(tmp_path):
    """The compilation cache (and the program store inside it) is per user, not per
    checkout: $JAXCHAIN_CACHE, else $XDG_CACHE_HOME/jaxchain, else ~/.cache/jaxchain; a
    folder set in JAX_COMPILATION_CACHE_DIR stands."""
    env = {"XDG_CACHE_HOME": str(tmp_path / "x")}
    assert use_user_cache(env) == str(tmp_path / "x" / "jaxchain")
    assert env["JAX_COMPILATION_CACHE_DIR"] == str(tmp_path / "x" / "jaxchain")
    assert use_user_cache({"JAXCHAIN_CACHE": str(tmp_path / "mine")}) == str(tmp_path / "mine")
    assert user_cache({}) == Path.home() / ".cache" / "jaxchain"
    chosen = {"JAX_COMPILATION_CACHE_DIR": str(tmp_path / "here")}
    assert use_user_cache(chosen) == str(tmp_path / "here")


def test_the_cache_is_pruned_longest_written_first(tmp_path):
    """Over its bound, the compiled programs written longest ago go first, down to three
    quarters of the bound; under it, nothing goes; the program store is not XLA's."""
    import os

    for k in range(10):  # 10 entries of 100 bytes, entry 0 written first
        entry = tmp_path / f"jit_f-{k}-cache"
        entry.write_bytes(b"x" * 100)
        os.utime(entry, (1000.0 + k, 1000.0 + k))
    (tmp_path / "jaxchain-programs").mkdir()
    assert prune_cache(tmp_path, max_bytes=1000) == 0  # at the bound: kept
    assert prune_cache(tmp_path, max_bytes=800) == 400  # down to 600 bytes
    left = sorted(int(p.name.split("-")[1]) for p in tmp_path.glob("*-cache"))
    assert left == [4, 5, 6, 7, 8, 9] and (tmp_path / "jaxchain-programs").is_dir()
    assert CACHE_SIZE == 4 << 30


def test_each_worker_its_own_core_when_there_are_enough():
    env = lambda w, n: {"PYTEST_XDIST_WORKER": w, "PYTEST_XDIST_WORKER_COUNT": str(n)}  # noqa: E731
    assert [worker_core(env(f"gw{i}", 2), [3, 1]) for i in range(2)] == [1, 3]
    assert worker_core(env("gw0", 3), [0, 1]) is None  # more workers than cores: unpinned
    assert worker_core({}, [0, 1]) is None  # not under xdist


SOLVE = """
import jax
jax.config.update("jax_enable_x64", True)
import numpy as np
import jaxchain as jc
sc = jc.scenes.engagement("08B", 18, speed_rpm=1000.0, n_entry=3, joint_friction=None)
sol = jc.simulate(sc, 2 * 60.0 / (18 * 1000.0), n_save=201, dt=2e-6)
np.savez({out!r}, peak=sol.peak_contact_force, steps=sol.stats["num_steps"],
         force=sol.roller_sprocket_force, q=sol.y1.q, v=sol.y1.v)
"""


@pytest.mark.slow
def test_the_flag_gives_the_same_results_to_rounding(tmp_path):
    """optimize/xla_flags.py: XLA's CPU backend with the newer fusion emitters off gives
    results equal to rounding. The engagement strand over two tooth periods (a meshing
    impact in each) in two fresh processes, with and without the flag, no caches: the
    same steps, and the peak, the saved forces and the final state each within 1e-9 of
    its own scale (measured: 8.6e-11 the forces, 7.9e-12 the
    peak, 7.8e-15 the positions). Fixed steps: an adaptive controller turns rounding into
    other steps (2341 against 2338 here), and the results then differ at its tolerance."""
    import os
    import subprocess
    import sys

    import numpy as np

    runs = {}
    for name, flags in (("on", FLAG), ("off", "--xla_cpu_use_fusion_emitters=true")):
        env = {k: v for k, v in os.environ.items() if k != "JAX_COMPILATION_CACHE_DIR"}
        env.update(XLA_FLAGS=flags, JAXCHAIN_PROGRAM_STORE="0", JAX_PLATFORMS="cpu")
        out = tmp_path / f"{name}.npz"
        subprocess.run([sys.executable, "-c", SOLVE.format(out=str(out))], env=env, check=True)
        runs[name] = dict(np.load(out))
    on, off = runs["on"], runs["off"]
    assert on["steps"] == off["steps"]
    errors = {
        k: float(np.abs(on[k] - off[k]).max() / np.abs(on[k]).max())
        for k in ("peak", "force", "q", "v")
    }
    print(errors)
    assert max(errors.values()) < 1e-9, errors

"""Traced programs kept across processes (jaxchain._programs): a program read back from
the store runs without tracing and gives what the ordinary call gives, bit for bit; what
a key cannot identify runs the ordinary way."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxchain as jc
import jaxchain._programs as programs

from helpers import count_vector_field_calls


@pytest.fixture
def store(tmp_path, monkeypatch):
    """A store of its own in ``tmp_path`` and an empty memory (a fresh process's); the
    folder this version of jaxchain saves its programs in."""
    monkeypatch.setenv("JAXCHAIN_PROGRAM_STORE", str(tmp_path / "programs"))
    monkeypatch.setattr(programs, "_MEMORY", {})
    return tmp_path / "programs" / programs._generation()


class Held(eqx.Module):
    t1: object = eqx.field(static=True)


Held.__module__ = "jaxchain.test"  # as if jaxchain's own


def _poly(x, powers):
    return {"sum": sum(x**p for p in powers), "n": len(powers), "one": jnp.asarray(1) + 0 * x}


def test_read_back_without_tracing_equal_bit_for_bit(store, monkeypatch):
    traced = []

    def counting(x, powers):
        traced.append(1)
        return _poly(x, powers)

    run = programs.stored("test.poly")(eqx.filter_jit(counting))
    x = jnp.linspace(0.0, 1.0, 7)
    first = run(x, (1, 2, 3))
    assert len(traced) == 1 and len(list(store.iterdir())) == 1
    monkeypatch.setattr(programs, "_MEMORY", {})  # another process: its own function
    # object too, which JAX's in-process trace cache has never seen (the same object
    # would be answered from that cache, hiding a store that reads nothing back)
    run = programs.stored("test.poly")(eqx.filter_jit(lambda x, powers: counting(x, powers)))
    again = run(x + 1.0, (1, 2, 3))
    assert len(traced) == 1  # read back, not traced
    ordinary = eqx.filter_jit(_poly)(x + 1.0, (1, 2, 3))
    np.testing.assert_array_equal(again["sum"], ordinary["sum"])
    assert again["n"] == 3 and first["n"] == 3  # static outputs kept
    # the same types whether traced here or read back (a read-back program returns no
    # weak types, so neither does the first call)
    assert (first["one"].dtype, first["one"].weak_type) == (again["one"].dtype, False)
    # arrays committed to the device (jax.device_put) run the same compiled program
    compiles = []
    listen = lambda event, *_, **__: compiles.append(event)  # noqa: E731
    jax.monitoring.register_event_duration_secs_listener(listen)
    try:
        committed = run(jax.device_put(x + 1.0, jax.devices()[0]), (1, 2, 3))
    finally:
        jax.monitoring.unregister_event_duration_listener(listen)
    assert "/jax/core/compile/backend_compile_duration" not in compiles
    np.testing.assert_array_equal(committed["sum"], again["sum"])
    # committed where the ordinary call's would be: only where an argument was
    assert committed["sum"].committed and not again["sum"].committed
    run(x, (1, 2))  # another constant: another program
    run(jnp.zeros(3), (1, 2, 3))  # another shape: another program
    assert len(traced) == 3 and len(list(store.iterdir())) == 3


@pytest.mark.filterwarnings("ignore:A JAX array is being set as static")
def test_what_a_key_cannot_identify_runs_the_ordinary_way(store):
    class Mine(eqx.Module):  # a user's class: its code is not in the key
        a: jax.Array

    x = jnp.ones(3)
    assert programs._key("f", (x, Mine(x))) is None
    assert programs._key("f", (x, lambda v: v)) is None
    assert programs._key("f", (x, jc.scenes.roller_law("08B", 0.7))) is not None
    # a static field's array is a constant of the program: its value is in the key
    keys = {programs._key("f", (Held(np.float64(v)),)) for v in (1.0, 2.0, 1.0)}
    assert len(keys) == 2 and None not in keys
    seen = []

    def traced_inside(v):
        seen.append(programs._key("f", (v,)))
        return v

    jax.jit(traced_inside)(x)
    assert seen == [None]  # a traced argument
    run = programs.stored("test.mine")(eqx.filter_jit(lambda m: m.a * 2))
    np.testing.assert_array_equal(run(Mine(x)), 2 * x)
    assert not store.parent.exists()


def test_off_without_a_compilation_cache_or_when_switched_off(store, monkeypatch):
    run = programs.stored("test.poly")(eqx.filter_jit(_poly))
    monkeypatch.setenv("JAXCHAIN_PROGRAM_STORE", "0")
    run(jnp.ones(2), (1,))
    assert programs.store_folder() is None
    monkeypatch.delenv("JAXCHAIN_PROGRAM_STORE")
    monkeypatch.setattr(programs, "_cache_dir", lambda: None)
    assert programs.store_folder() is None
    run(jnp.ones(2), (1,))
    monkeypatch.setattr(programs, "_cache_dir", lambda: "/somewhere")
    assert programs.store_folder() == programs.Path("/somewhere/jaxchain-programs")
    assert not store.parent.exists()


def test_other_versions_folders_are_pruned_when_old(store, monkeypatch):
    """Each version of jaxchain and its libraries saves into its own folder; the first
    save of a process removes other versions' folders that are both beyond the KEEP most
    recently written and older than KEEP_DAYS, and entries of the former flat layout."""
    import os
    import time

    assert (programs.KEEP, programs.KEEP_DAYS) == (4, 7.0)
    root = store.parent

    def versions(ages):  # days since each other version last saved
        now = time.time()
        for i, days in enumerate(ages):
            (root / f"{i:016x}").mkdir(parents=True)
            (root / f"{i:016x}" / "entry").write_bytes(b"x")
            os.utime(root / f"{i:016x}", (now - days * 86400, now - days * 86400))

    def kept():
        return [int(p.name, 16) for p in sorted(root.iterdir()) if p != store]

    # all old: the KEEP - 1 = 3 newest others stay
    versions([10.0, 20.0, 30.0, 40.0, 9.0])
    flat = root / ("0" * 64)
    flat.write_bytes(b"old layout")
    programs.stored("test.poly")(eqx.filter_jit(_poly))(jnp.ones(2), (1,))  # prunes
    assert kept() == [0, 1, 4] and not flat.exists()
    assert len(list(store.iterdir())) == 1  # this version's program saved
    # all young: every one stays, beyond the 3 newest too
    for p in root.iterdir():
        if p != store:
            for f in p.iterdir():
                f.unlink()
            p.rmdir()
    versions([1.0, 2.0, 3.0, 5.0, 6.0, 8.0])
    programs._prune(root, store.name)
    assert kept() == [0, 1, 2, 3, 4]


def test_a_damaged_entry_is_traced_anew(store, monkeypatch):
    run = programs.stored("test.poly")(eqx.filter_jit(_poly))
    run(jnp.ones(2), (1,))
    (entry,) = store.iterdir()
    entry.write_bytes(b"damaged")
    monkeypatch.setattr(programs, "_MEMORY", {})
    np.testing.assert_array_equal(run(jnp.ones(2), (1,))["sum"], jnp.ones(2))  # x¹ = x
    assert entry.read_bytes() != b"damaged"


def test_simulate_read_back_equals_the_ordinary_solve(store, monkeypatch):
    """simulate's solve from the store: no trace, every output equal to the ordinary
    call's bit for bit (the engagement strand of test_engagement, default options)."""
    scene = jc.scenes.engagement("08B", 18, n_entry=3)
    t1 = 60.0 / (18 * 1000.0)
    jc.simulate(scene, t1)  # stores the program
    monkeypatch.setattr(programs, "_MEMORY", {})  # another process
    calls = count_vector_field_calls(monkeypatch)
    read = jc.simulate(scene, t1)
    assert len(calls) == 0
    monkeypatch.setenv("JAXCHAIN_PROGRAM_STORE", "0")
    ordinary = jc.simulate(scene, t1)
    for a, b in zip(
        jax.tree_util.tree_leaves(read), jax.tree_util.tree_leaves(ordinary), strict=True
    ):
        np.testing.assert_array_equal(a, b)


def test_threads_calling_at_once_trace_and_compile_once(store):
    """Threads calling a stored function for the first time at once (speed groups
    settling their scenes side by side) wait for one trace and one compile."""
    import threading

    traced, compiles = [], []

    def slow(x, powers):
        traced.append(1)
        return _poly(x, powers)

    def listen(event, *_, **__):
        if event == "/jax/core/compile/backend_compile_duration":
            compiles.append(event)

    x = jnp.linspace(0.0, 1.0, 5)
    go = threading.Barrier(4)
    results = [None] * 4

    def call(i):
        go.wait()
        results[i] = run(x, (1, 2))

    jax.monitoring.register_event_duration_secs_listener(listen)
    try:
        programs.stored("test.poly.alone")(eqx.filter_jit(_poly))(x, (1, 2))  # one-offs
        before = len(compiles)
        run = programs.stored("test.poly.threads")(eqx.filter_jit(slow))
        threads = [threading.Thread(target=call, args=(i,)) for i in range(4)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
    finally:
        jax.monitoring.unregister_event_duration_listener(listen)
    assert len(traced) == 1 and len(compiles) - before == 1
    for r in results:
        np.testing.assert_array_equal(r["sum"], results[0]["sum"])


def test_threads_trace_one_at_a_time_and_compile_side_by_side(store):
    """Different stored functions called at once from threads are traced one after the
    other (a trace holds Python's lock anyway; the one finished first compiles, outside
    it, beside the next trace), each giving the function's own value."""
    import threading
    import time

    spans = []  # (start, end) of each trace

    def slow():  # a function of its own each: three programs
        def f(x, powers):
            start = time.perf_counter()
            time.sleep(0.2)  # a long trace (sleeping lets another thread's trace in)
            out = _poly(x, powers)
            spans.append((start, time.perf_counter()))
            return out

        return f

    x = jnp.linspace(0.0, 1.0, 5)
    runs = [programs.stored(f"test.poly.traces.{i}")(eqx.filter_jit(slow())) for i in range(3)]
    go = threading.Barrier(3)
    results = [None] * 3

    def call(i):
        go.wait()
        results[i] = runs[i](x, (1, 2))

    threads = [threading.Thread(target=call, args=(i,)) for i in range(3)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    spans.sort()
    assert len(spans) == 3
    assert all(a[1] <= b[0] for a, b in zip(spans, spans[1:], strict=False)), spans
    for r in results:
        np.testing.assert_array_equal(r["sum"], _poly(x, (1, 2))["sum"])

"""Where the test run's time goes: with ``JAXCHAIN_TIME_LOG=<folder>`` set, every pytest
worker appends one JSON line per test to ``<folder>/<worker>.jsonl``: its wall time and
the seconds JAX spent tracing, lowering and compiling inside it (JAX's own monitoring
events; a compile answered by the persistent cache counts as a short compile), and how
many programs it compiled or loaded.

    JAXCHAIN_TIME_LOG=/tmp/tl python -m pytest
    python tests/time_log.py /tmp/tl          # per file, heaviest first; the programs
                                              # that compile longest, by name

Unset (the default run), nothing is registered.
"""

from __future__ import annotations

import json
import os
import sys
import time
from collections import defaultdict
from pathlib import Path

EVENTS = {
    "/jax/core/compile/jaxpr_trace_duration": "trace",
    "/jax/core/compile/jaxpr_to_mlir_module_duration": "lower",
    "/jax/core/compile/backend_compile_duration": "compile",
}


BIG = 0.5  # programs compiling longer than this [s] are listed by name


class TimeLog:
    """A pytest plugin: per-test wall time and JAX's compile-phase durations."""

    def __init__(self, folder: Path):
        import jax  # the caller has set JAX's configuration already

        folder.mkdir(parents=True, exist_ok=True)
        worker = os.environ.get("PYTEST_XDIST_WORKER", "main")
        self.file = open(folder / f"{worker}.jsonl", "a", buffering=1)  # noqa: SIM115
        self.current = defaultdict(float)
        self.programs = []
        jax.monitoring.register_event_duration_secs_listener(self._listen)

    def _listen(self, event, duration, **kwargs):
        name = EVENTS.get(event)
        if name:
            self.current[name] += duration
            if name == "compile":
                self.current["programs"] += 1
                if duration > BIG:
                    self.programs.append([kwargs.get("fun_name", "?"), round(duration, 2)])

    def pytest_runtest_logstart(self, nodeid, location):
        self.current.clear()
        self.programs = []
        self.start = time.perf_counter()

    def pytest_runtest_logfinish(self, nodeid, location):
        record = {"test": nodeid, "wall": time.perf_counter() - self.start, **self.current}
        record["big"] = self.programs
        self.file.write(json.dumps(record) + "\n")


def _records(folder: Path):
    """Every test's record in the folder's logs."""
    for path in folder.glob("*.jsonl"):
        for line in path.read_text().splitlines():
            yield json.loads(line)


def _row(name: str, v) -> str:
    return (
        f"{name[-44:]:44s} {int(v['tests']):5d} {v['wall']:7.1f} {v['trace']:6.1f} "
        f"{v['lower']:6.1f} {v['compile']:7.1f} {int(v['programs']):5d}"
    )


def summary(folder: Path) -> str:
    """Per file: wall seconds and the trace/lower/compile seconds within, heaviest first."""
    files = defaultdict(lambda: defaultdict(float))
    total = defaultdict(float)
    for r in _records(folder):
        key = r["test"].split("::")[0]
        if "test_notebooks" in key:
            key = r["test"].split("[")[-1].rstrip("]")
        for part in (files[key], total):
            for k in ("wall", "trace", "lower", "compile", "programs"):
                part[k] += r.get(k, 0.0)
            part["tests"] += 1
    rows = sorted(files.items(), key=lambda kv: -kv[1]["wall"])
    head = (
        f"{'file':44s} {'tests':>5s} {'wall':>7s} {'trace':>6s} {'lower':>6s} "
        f"{'compile':>7s} {'progs':>5s}"
    )
    return "\n".join([head, *(_row(name, v) for name, v in rows), _row("total", total)])


def programs(folder: Path, top: int = 30) -> str:
    """The programs that took longest to compile, by name: count and seconds."""
    by = defaultdict(lambda: [0, 0.0])
    for r in _records(folder):
        for name, sec in r.get("big", []):
            by[name][0] += 1
            by[name][1] += sec
    rows = sorted(by.items(), key=lambda kv: -kv[1][1])[:top]
    return "\n".join(f"{n:6d} {s:7.1f}  {name}" for name, (n, s) in rows)


if __name__ == "__main__":
    print(summary(Path(sys.argv[1])))
    print(programs(Path(sys.argv[1])))

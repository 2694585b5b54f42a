"""Start N local processes of one program on JAX's multi-process runtime.

    python -m jaxchain.launch -n 2 script.py [args ...]
    python -m jaxchain.launch -n 2 -m optimize --fast

Each process runs the program with the coordinator on localhost and its rank in the
environment (``JAXCHAIN_COORDINATOR``, ``JAXCHAIN_NUM_PROCESSES``, ``JAXCHAIN_PROCESS_ID``),
which :func:`jaxchain.distributed.initialize` reads; the program calls it first. Processes
run on the CPU (``JAX_PLATFORMS=cpu`` unless set) with gloo collectives, so this works on
one laptop. Output of every process goes to this terminal.

When a process exits with an error while others still run, the others are stopped (they
would wait for it in their next collective) and the launcher exits with that process's
code and a message naming it and what ended it. Where several fail together, the one
named is the cause: a process whose collective failed because another was gone is named
after it. Exit code 0 when every process succeeded.
"""

from __future__ import annotations

import argparse
import os
import signal
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path

from ._solve.distributed import (
    ENV_COORDINATOR,
    ENV_HEARTBEAT,
    ENV_PROCESS_ID,
    ENV_PROCESSES,
    ENV_STATUS,
)

PROG = "python -m jaxchain.launch"


def free_port() -> int:
    """A TCP port on localhost that was free a moment ago."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _describe(code: int) -> str:
    if code < 0:
        try:
            return f"was killed by {signal.Signals(-code).name}"
        except ValueError:
            return f"was killed by signal {-code}"
    return f"exited with code {code}"


def _stop(procs: dict[int, subprocess.Popen], grace: float) -> None:
    """SIGTERM the processes still running, SIGKILL what remains after ``grace`` s."""
    for p in procs.values():
        if p.poll() is None:
            p.terminate()
    end = time.monotonic() + grace
    for p in procs.values():
        try:
            p.wait(timeout=max(0.0, end - time.monotonic()))
        except subprocess.TimeoutExpired:
            p.kill()
            p.wait()


def launch(
    command: Sequence[str],
    n: int,
    *,
    port: int | None = None,
    devices: int | None = None,
    heartbeat_timeout: int | None = None,
    grace: float = 5.0,
    env: dict | None = None,
    poll: float = 0.05,
    settle: float = 1.0,
) -> int:
    """Run ``command`` (an argv list) as ``n`` processes of one multi-process program;
    return the exit code (0: all succeeded), after a message on stderr naming the
    process that caused a failure (processes failing within ``settle`` s of the first
    are weighed together)."""
    if isinstance(n, bool) or not isinstance(n, int) or n < 1:
        raise ValueError(f"the number of processes must be an integer >= 1, got {n!r}")
    if devices is not None and (isinstance(devices, bool) or devices < 1):
        raise ValueError(f"devices per process must be >= 1, got {devices!r}")
    if not command:
        raise ValueError("give the program to run: a script and its arguments, or -m module")
    port = free_port() if port is None else port
    if not 1 <= port <= 65535:
        raise ValueError(f"port must be in [1, 65535], got {port}")
    base = dict(os.environ if env is None else env)
    base.setdefault("JAX_PLATFORMS", "cpu")
    base[ENV_COORDINATOR] = f"127.0.0.1:{port}"
    base[ENV_PROCESSES] = str(n)
    if heartbeat_timeout is not None:
        base[ENV_HEARTBEAT] = str(int(heartbeat_timeout))
    if devices is not None:
        flags = base.get("XLA_FLAGS", "") + f" --xla_force_host_platform_device_count={devices}"
        base["XLA_FLAGS"] = flags.strip()
    with tempfile.TemporaryDirectory(prefix="jaxchain-launch-") as status:
        base[ENV_STATUS] = status
        procs: dict[int, subprocess.Popen] = {}
        for rank in range(n):
            procs[rank] = subprocess.Popen(list(command), env=base | {ENV_PROCESS_ID: str(rank)})
        return _watch(procs, Path(status), grace, poll, settle)


def _watch(procs, status: Path, grace: float, poll: float, settle: float) -> int:
    """Wait for the processes; on the first failure, stop the rest and name the cause."""
    n = len(procs)
    exits: dict[int, int] = {}  # rank -> code, in the order the processes ended
    first_failure = None
    try:
        while len(exits) < n:
            for rank, p in procs.items():
                code = p.poll()
                if code is not None and rank not in exits:
                    exits[rank] = code
                    if code != 0 and first_failure is None:
                        first_failure = time.monotonic()
            if first_failure is not None and time.monotonic() - first_failure >= settle:
                break
            time.sleep(poll)
    except KeyboardInterrupt:
        _stop(procs, grace)
        print(f"{PROG}: interrupted; stopped all {n} processes", file=sys.stderr)
        return 130
    failed = [r for r, c in exits.items() if c != 0]
    if not failed:
        return 0
    running = [r for r, p in procs.items() if p.poll() is None]
    _stop(procs, grace)
    notes = {}
    for r in failed:
        f = status / f"{r}.txt"
        notes[r] = f.read_text().strip() if f.exists() else ""
    # the cause: a process that did not merely lose a peer, first come first
    cause = next((r for r in failed if not notes[r].startswith("lost a peer")), failed[0])
    code = exits[cause]
    msg = f"{PROG}: process {cause} of {n} (pid {procs[cause].pid}) {_describe(code)}"
    if notes[cause]:
        msg += f" ({notes[cause]})"
    finished = [r for r, c in exits.items() if c == 0]
    if finished:
        msg += f"; processes {finished} had finished"
    others = [r for r in failed if r != cause]
    if others:
        msg += f"; processes {others} failed with it"
    if running:
        msg += f"; stopped processes {running}, which were still running"
    msg += f". See process {cause}'s output above."
    print(msg, file=sys.stderr, flush=True)
    return code if 0 < code < 256 else 128 + (-code if code < 0 else 1)


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog=PROG,
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    ap.add_argument("-n", "--processes", type=int, required=True, help="processes to start")
    ap.add_argument(
        "-m",
        dest="module",
        nargs=argparse.REMAINDER,
        metavar="MODULE ...",
        help="run a module with its arguments (as python -m does); last",
    )
    ap.add_argument("--port", type=int, help="coordinator port on localhost (default: a free one)")
    ap.add_argument(
        "--devices", type=int, help="CPU devices per process (XLA's forced host device count)"
    )
    ap.add_argument(
        "--heartbeat-timeout",
        type=int,
        help="seconds without a heartbeat before a process counts as dead (default 60)",
    )
    ap.add_argument("program", nargs=argparse.REMAINDER, help="script.py [args ...]")
    args = ap.parse_args(argv)
    if args.module is not None:
        if not args.module:
            ap.error("-m needs a module name")
        command = [sys.executable, "-m", *args.module]
    elif args.program:
        command = [sys.executable, *args.program]
    else:
        ap.error("give a script (script.py [args ...]) or -m module [args ...]")
    try:
        return launch(
            command,
            args.processes,
            port=args.port,
            devices=args.devices,
            heartbeat_timeout=args.heartbeat_timeout,
        )
    except ValueError as e:
        ap.error(str(e))


if __name__ == "__main__":
    sys.exit(main())

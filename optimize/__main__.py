"""``python -m optimize``: lower the peak roller/tooth contact force by reshaping the
sprocket's tooth profile, with gradients through the dynamics.

Default problem (``--problem gentle``): a free-form asymmetric tooth (each side of the
gap its own seat angle and a two-arc flank, plus the seating radius) for an 08B chain
meshing an 18-tooth driver under 1000 N (the engagement scene, lumped fidelity), robust
over speeds of 0.5, 1.0 and 1.5 × 1000 rpm and chain wear of 0 and 2 % (the worst member
counts). ``--problem iso`` designs inside the ISO 606 box instead (four parameters),
``--problem ring`` the tooth with a cushion ring, ``--problem quiet`` both re-measured in
the clearance-joint chain dry and in oil (optimize/quiet.py).
The design objective solves each operating point over two of its own tooth periods
(``--horizon own``) with fixed 4 µs steps and the soft peak sampled 8 times per step
(``--samples``): its gradient then converges as the step shrinks; over longer solves a
fast member's sensitivity to its state grows until the gradient stops describing the
objective (``benchmarks/step_convergence.py``). Adam runs first, then Nelder–Mead on
the same objective; both designs are re-measured (tight tolerance, nominal and second
contact law) and the better one is delivered.
Writes results.json (with a top-level "summary"), profile.png, forces.png,
spectra.png (the driver torque's spectrum before/after), objective.png, the designed
sprocket as sprocket.dxf and the delivered design as profile.json (jc.load_profile
reads it) to --out; checkpoints every iteration (--resume continues after
an interrupt). Adam's gradient is clipped to a norm of 100 N (--clip; 0 turns it off):
a rebound that appears or vanishes spikes it. ``JAXCHAIN_FAST=1`` (or --fast) runs a
small version for smoke tests. Compiled solves are kept in a persistent compilation
cache, ``~/.cache/jaxchain`` (``JAXCHAIN_CACHE`` or ``JAX_COMPILATION_CACHE_DIR`` moves
it; ``optimize/xla_flags.py``): a second run, from any checkout, skips most of the
compile time.
"""

from __future__ import annotations

import argparse
import os
import sys
from dataclasses import fields
from pathlib import Path

# Failures here are values (result codes, checked by the run), so equinox's in-graph
# runtime checks may return NaN rather than call back to Python: computations without a
# host callback are what XLA's persistent compilation cache keeps (see main()).
os.environ.setdefault("EQX_ON_ERROR", "nan")
# XLA's older CPU fusion emitters: a third less compile time, results equal to rounding
# (a flag of its own in XLA_FLAGS stands; optimize/xla_flags.py)
from .xla_flags import fast_compile, use_user_cache  # noqa: E402  (imports no JAX)

fast_compile()
CACHE = use_user_cache()  # before JAX reads its configuration from the environment

try:
    import optax  # noqa: F401
except ImportError:
    sys.exit(
        "python -m optimize needs optax, the optimize extra: "
        'pip install -e ".[optimize]" (from the repository root)'
    )

from .problem import Settings  # noqa: E402


def _floats(text: str) -> tuple[float, ...]:
    try:
        return tuple(float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected comma-separated numbers, got {text!r}"
        ) from None


# what --fast changes: a small run with the same code paths (CI, notebooks in fast mode);
# each from its Settings field's option
FAST = {f.name: f.metadata["fast"] for f in fields(Settings) if "fast" in f.metadata}
# each Settings field's command-line flag
FLAGS = {f.name: f.metadata.get("flag", "--" + f.name.replace("_", "-")) for f in fields(Settings)}
FAST_RTOL = 1e-6  # the re-measurement's tolerance (no option of its own)


def fast_settings(s: Settings, given: frozenset[str] = frozenset()) -> Settings:
    """``s`` made small (:data:`FAST`), keeping the options in ``given`` (set explicitly)."""
    for name, value in FAST.items():
        if name not in given:
            setattr(s, name, value)
    s.remeasure_rtol = FAST_RTOL
    return s


def _writable(out: Path) -> None:
    """``--out`` must be a folder this process can create and write in."""
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out {out} is a file; give a folder (it is created if missing)")
    try:
        out.mkdir(parents=True, exist_ok=True)
        probe = out / ".write-test"
        probe.write_text("")
        probe.unlink()
    except OSError as e:
        raise ValueError(f"--out {out} is not a writable folder ({e.strerror or e})") from None


def _option(ap: argparse.ArgumentParser, f, default) -> None:
    """The command-line option of Settings field ``f`` (its metadata: help, flag, choices;
    a ``fast`` or scene-dependent default is None here, filled in by :func:`parse`)."""
    meta = f.metadata
    kind = {"int": int, "float": float, "str": str}.get(f.type, _floats)
    shown = ",".join(f"{v:g}" for v in default) if isinstance(default, tuple) else default
    given = "fast" in meta or "by_scene" in meta
    text = meta["help"] if "by_scene" in meta else f"{meta['help']} (default {shown})"
    ap.add_argument(
        meta.get("flag", "--" + f.name.replace("_", "-")),
        dest=f.name,
        type=kind,
        choices=meta.get("choices"),
        default=None if given else default,
        help=text,
    )


def parse(argv=None) -> tuple[Settings, argparse.Namespace]:
    d = Settings()
    ap = argparse.ArgumentParser(
        prog="python -m optimize",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    for f in fields(Settings):
        if f.metadata.get("flag", "") is not None:  # flag None: no option of its own
            _option(ap, f, getattr(d, f.name))
    ap.add_argument(
        "--speeds",
        type=_floats,
        default=None,
        help="quiet: speed factors (of 1000 rpm) of the clearance-chain measurement "
        "(default 0.5,1,1.5,2,2.5: the design band and two speeds above it; --fast: 1)",
    )
    ap.add_argument(
        "--viscosity",
        type=float,
        default=None,
        help="quiet: the lubricated measurement's oil viscosity [Pa·s] (default 0.01)",
    )
    ap.add_argument("--out", type=Path, default=Path("results/optimize"), help="output folder")
    ap.add_argument("--resume", action="store_true", help="continue from --out's checkpoint")
    ap.add_argument(
        "--fast",
        action="store_true",
        help="small smoke-test run: "
        + ", ".join(f"{k.replace('_', '-')} {v}" for k, v in FAST.items())
        + " unless given",
    )
    ap.add_argument("--quiet", action="store_true", help="no progress output")
    args = ap.parse_args(argv)
    given = frozenset(k for k in FAST if getattr(args, k) is not None)
    args.given = given
    for k in FAST:
        if getattr(args, k) is None:
            setattr(args, k, getattr(d, k))
    if args.scene == "drive" and "wear" not in given:
        args.wear = (0.0,)  # the drive scene models an unworn chain
    for f in fields(Settings):
        if "by_scene" in f.metadata and getattr(args, f.name) is None:
            setattr(args, f.name, f.metadata["by_scene"][args.scene])
    s = Settings(
        **{f.name: getattr(args, f.name) for f in fields(Settings) if hasattr(args, f.name)}
    )
    if args.fast or os.environ.get("JAXCHAIN_FAST") == "1":  # as the notebooks read it
        s = fast_settings(s, given)
    return s, args


def main(argv=None) -> dict:
    import jax

    jax.config.update("jax_enable_x64", True)  # the application (not the library) picks x64
    # compiled solves persist across runs (a second run skips most of the compile time)
    jax.config.update("jax_compilation_cache_dir", CACHE)
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.5)
    import jaxchain as jc

    from .run import RunFailed, run

    settings, args = parse(argv)
    if settings.problem == "timing":
        return _timing(args)
    if settings.problem == "quiet":
        return _quiet(args)
    for name in ("speeds", "viscosity"):
        if getattr(args, name) is not None:
            raise SystemExit(
                f"python -m optimize: error: --{name} is an option of --problem quiet; "
                f"--problem {settings.problem} does not use it"
            )
    if settings.scene == "engagement":  # what only the closed drive uses
        for name, flag in (("pretension", "--pretension"), ("driven_teeth", "--driven-teeth")):
            if getattr(args, name) != getattr(parse([])[1], name):
                raise SystemExit(
                    f"python -m optimize: error: {flag} sets the closed drive of --scene "
                    "drive; the engagement scene (the default) does not use it"
                )
    # several processes (python -m jaxchain.launch -n N -m optimize, or srun): the operating
    # points are shared among them; process 0 reports and writes, all read a checkpoint
    jc.distributed.initialize()
    lead = jax.process_index() == 0
    try:
        settings.validate()
        if lead:
            _writable(args.out)
    except ValueError as e:
        raise SystemExit(f"python -m optimize: error: {e}") from None
    try:
        return run(settings, args.out, resume=args.resume, quiet=args.quiet or not lead)
    except KeyboardInterrupt:
        sys.exit(130)
    except ValueError as e:  # bad input found while setting up (e.g. a mismatched resume)
        hint = ""
        if settings.scene == "drive" and "pretension" in str(e):  # the builder's words
            hint = " (here: --pretension [N], --load [N·m])"
        raise SystemExit(f"python -m optimize: error: {e}{hint}") from None
    except (jc.SolveError, RunFailed) as e:  # a simulation failed: its message says why
        raise SystemExit(f"python -m optimize: the run stopped: {e}") from None


# the options every problem reads, and those of the named problems
COMMON_OPTIONS = {"problem", "out", "resume", "fast", "quiet", "given", "iterations"}
NAMED_OPTIONS = {
    "quiet": {"speeds", "viscosity", "clearance_engagements"},
    "timing": set(),
}


def _refuse_unused(args, problem: str, what: str) -> None:
    """Exit with a message naming the options given that ``problem`` does not use."""
    used = COMMON_OPTIONS | NAMED_OPTIONS[problem]
    defaults = vars(parse([])[1])
    unused = sorted(
        k for k, v in vars(args).items()
        if k not in used and k not in FAST and v != defaults.get(k)
    )  # fmt: skip
    unused += sorted(k for k in FAST if k in args.given and k not in used)
    if unused:
        flag = lambda k: FLAGS.get(k) or "--" + k.replace("_", "-")
        reads = ", ".join(flag(k) for k in sorted(used - {"given", "problem"}))
        raise SystemExit(
            f"python -m optimize: error: --problem {problem} {what} and does not use "
            + ", ".join(flag(k) for k in unused)
            + f" (it reads {reads})"
        )


def _quiet(args) -> dict:
    """``--problem quiet`` (:mod:`optimize.quiet`)."""
    from . import quiet

    _refuse_unused(args, "quiet", "designs the main job's default problems")
    q = quiet.QuietSettings()
    if args.speeds is not None:
        q.speeds = tuple(args.speeds)
    if args.viscosity is not None:
        q.viscosity = args.viscosity
    if "clearance_engagements" in args.given:
        q.engagements = args.clearance_engagements
    if "iterations" in args.given:
        q.iterations = args.iterations
    fast = args.fast or os.environ.get("JAXCHAIN_FAST") == "1"
    if fast:
        q.fast = True
        if "clearance_engagements" not in args.given:
            q.engagements = 4
        if args.speeds is None:
            q.speeds = (1.0,)
    return _run_named(quiet.run, q, args, "results/optimize_quiet")


def _run_named(run, settings, args, default_out: str) -> dict:
    """Validate ``settings`` and the output folder (``--out``, else ``default_out``),
    then ``run(settings, out, resume=, quiet=)``: bad input, an interrupt and a stopped
    simulation end the process with a message, not a traceback."""
    import jaxchain as jc

    from .run import RunFailed

    out = args.out if args.out != Path("results/optimize") else Path(default_out)
    try:
        settings.validate()
        _writable(out)
        return run(settings, out, resume=args.resume, quiet=args.quiet)
    except KeyboardInterrupt:
        sys.exit(130)
    except ValueError as e:
        raise SystemExit(f"python -m optimize: error: {e}") from None
    except (jc.SolveError, RunFailed) as e:
        raise SystemExit(f"python -m optimize: the run stopped: {e}") from None


def _timing(args) -> dict:
    """``--problem timing`` (:mod:`optimize.timing`)."""
    import dataclasses

    from . import timing

    _refuse_unused(args, "timing", "designs a timing drive of its own")
    s = timing.TimingSettings()
    if "iterations" in args.given:
        s.iterations = args.iterations
    if args.fast or os.environ.get("JAXCHAIN_FAST") == "1":
        s = dataclasses.replace(s, **timing.FAST)
    return _run_named(timing.run, s, args, "results/optimize_timing")


if __name__ == "__main__":
    main()

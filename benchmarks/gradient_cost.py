"""Cost of a design gradient against the dimension of the design space.

    python -m benchmarks.gradient_cost            # full study (~5 min on 2 cores)
    python -m benchmarks.gradient_cost --quick    # smoke run (CI-sized)

Writes ``benchmarks/results/gradient_cost.json`` and ``gradient_cost.png``. Reverse mode
costs a small multiple of one forward solve whatever the number of parameters; a
gradient-free method or finite differences pay per parameter. Measured here, in one run
(machines are shared and noisy: compare ratios, not seconds):

* the design objective of ``python -m optimize``'s scene (08B engagement, z = 18, 1000 rpm,
  1000 N, design contact law, fixed steps of 4 µs over two tooth periods, soft peak over
  the second) built for a free-form tooth and differentiated in design spaces of
  4 (the ISO 606 box), 36 (per-gap seating radius and clockwise seat angle) and 72
  coordinates (per-gap seating radius, both seat angles and seat offset);
* for each: the wall time of the value alone and of value + gradient (the least of
  ``repeats`` warm calls, interleaved; compile excluded), their ratio, and the compile
  times; the gradient by the default fixed-step adjoint (every step's residuals kept,
  :class:`jaxchain.StepResidualsAdjoint`), by diffrax's checkpointing of every step
  (each step run forward again on the way back) and by forward mode (one tangent per
  coordinate, all carried by one vmapped solve: ``ProfileObjective(gradient="forward")``),
  with each one's difference from the first.

A value+gradient then counts as ``ratio`` simulations when methods are compared on one
simulation budget (issue "design that pays": the ratio should stay ≤ 4 and flat in the
dimension).
"""

from __future__ import annotations

import datetime
import time

import jax

jax.config.update("jax_enable_x64", True)


from benchmarks.common import (  # noqa: E402
    finish,
    machine_info,  # noqa: E402
    parse,
    parser,
)
from benchmarks.designs import checkpointed, cost_of, objective, spaces  # noqa: E402


def chart(results: dict, path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = results["rows"]
    dims = [r["dimension"] for r in rows]
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.plot(
        dims,
        [r["ratio"] for r in rows],
        "o-",
        color="tab:red",
        label="reverse mode, every step's residuals kept",
    )
    if "ratio_checkpointed" in rows[0]:
        ax.plot(dims, [r["ratio_checkpointed"] for r in rows], "s--", color="tab:orange",
                label="reverse mode, every step checkpointed")  # fmt: skip
    if "ratio_forward" in rows[0]:
        ax.plot(dims, [r["ratio_forward"] for r in rows], "^-", color="tab:blue",
                label="forward mode, one tangent per coordinate")  # fmt: skip
    ax.plot(dims, [d + 1 for d in dims], "--", color="0.5", label="forward differences (n + 1)")
    ax.axhline(4, color="k", lw=0.8, ls=":")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xticks(dims, [str(d) for d in dims], minor=False)
    ax.set_xticks([], minor=True)
    ax.set_yticks([2, 4, 8, 16, 32, 64], ["2", "4", "8", "16", "32", "64"])
    ax.set_yticks([], minor=True)
    ax.set_xlabel("design coordinates")
    ax.set_ylabel("cost of value + gradient / value")
    ax.set_title("Gradient cost against dimension (08B engagement, fixed 4 µs steps)")
    ax.legend()
    fig.savefig(path, dpi=120, bbox_inches="tight")
    plt.close(fig)


def main(argv=None) -> dict:
    args = parse(parser(__doc__), argv)
    start = time.perf_counter()
    repeats = 3 if args.quick else 9
    picks = ("4", "72") if args.quick else ("4", "36", "72")
    machine = machine_info()  # the load average at the start
    rows = []
    for name, space in spaces().items():
        if name not in picks:
            continue
        others = {
            "checkpointed": checkpointed(space),
            "forward": objective(space, gradient="forward"),
        }
        obj = objective(space, gradient="reverse")
        row = cost_of(space, repeats, obj=obj, others=others)
        rows.append(row)
        print(
            f"dimension {row['dimension']:3d}: value {row['value_s']:.3f} s, value+grad "
            f"{row['value_and_grad_s']:.3f} s, ratio {row['ratio']:.2f} (every step "
            f"checkpointed: {row['ratio_checkpointed']:.2f}; forward mode: "
            f"{row['ratio_forward']:.2f}; gradients differ by "
            f"{row['grad_difference_checkpointed']:.1e} and {row['grad_difference_forward']:.1e}); "
            f"compile: value {row['first_value_s']:.1f} s, reverse "
            f"{row['first_value_and_grad_s']:.1f} s, forward "
            f"{row['first_value_and_grad_forward_s']:.1f} s",
            flush=True,
        )
    results = {
        "study": "gradient_cost",
        "command": "python -m benchmarks.gradient_cost" + (" --quick" if args.quick else ""),
        "date": datetime.date.today().isoformat(),
        "machine": machine,
        "repeats": repeats,
        "rows": rows,
    }
    return finish(results, args.out, "gradient_cost", chart, start)


if __name__ == "__main__":
    main()

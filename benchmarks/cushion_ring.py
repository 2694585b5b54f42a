"""What cushion rings do to the clearance-joint chain's meshing peaks: the per-engagement
peak of both roller populations without a ring and with rings of several interferences
and stiffnesses, dry and lubricated, beside the lumped chain.

    python -m benchmarks.cushion_ring            # full study (~30 min on 2 busy cores)
    python -m benchmarks.cushion_ring --quick    # smoke run (4 engagements per variant)

Writes ``benchmarks/results/cushion_ring.json`` and ``cushion_ring.png``.

The scene: the 08B strand meshing an 18-tooth driver under 1000 N at 1000 rpm
(``jc.scenes.engagement(..., fidelity="clearance", cushion=ring)``, settled start with the
ring, Dahl joint friction), engagements after the first two tooth periods
(``benchmarks/engagement_stats.py``: statistics per roller population, Welch intervals
against the same chain without a ring).

**Rings.** ``jc.elements.CushionRing`` on both faces of the driver, its radius the seated
links' plate edge (R·cos(π/z) − h2/2 = 30.11 mm for 08B, z = 18) plus an interference
(``--interference``, default 0.1, 0.2 and 0.3 mm) at the ring's default elastomer
stiffness; at 0.2 mm also 4 times stiffer; the 0.2 mm ring with
hot engine oil in the joints (``jc.contact.OilFilm(viscosity=0.01)``; the oil alone is
``lubrication``'s); and the lumped chain with and without the 0.2 mm ring.
"""

from __future__ import annotations

import math
import time

import jax

jax.config.update("jax_enable_x64", True)

import jaxchain as jc  # noqa: E402
from benchmarks.common import finish, header, parse, parser, save_chart  # noqa: E402
from benchmarks.engagement_stats import (  # noqa: E402
    CHAIN,
    DISCARD,
    TEETH,
    TENSION,
    boxes,
    compare,
    measure,
)

RPM = 1000.0
OIL = jc.contact.OilFilm(viscosity=0.01)


def seated_edge() -> float:
    """Distance of a seated link's plate edge from the driver's axis [m]."""
    chain = jc.ChainSpec.iso606(CHAIN)
    pitch_radius = chain.pitch / (2 * math.sin(math.pi / TEETH))
    return pitch_radius * math.cos(math.pi / TEETH) - chain.plate_height / 2


def ring(interference: float, stiffness: float = 1.0, damping: float = 1.0):
    base = jc.elements.CushionRing(radius=seated_edge() + interference)
    return jc.elements.CushionRing(
        radius=base.radius,
        stiffness=stiffness * float(base.stiffness),
        damping=damping * float(base.damping),
    )


def chart(results: dict, path) -> None:
    import matplotlib.pyplot as plt

    runs = results["runs"]
    clear = [r for r in runs if r["fidelity"] == "clearance"]
    lumped = [r for r in runs if r["fidelity"] == "lumped"]
    fig, axes = plt.subplots(
        1, 2, figsize=(14, 4.6), gridspec_kw={"width_ratios": [max(len(clear), 1), 1 + len(lumped)]}
    )
    boxes(axes[0], clear, f"clearance chain, {RPM:.0f} rpm")
    if lumped:
        boxes(axes[1], lumped, "lumped chain")
    save_chart(fig, results, path)


def main(argv=None) -> dict:
    ap = parser(__doc__)
    ap.add_argument("--interference", type=float, nargs="+", default=[0.1e-3, 0.2e-3, 0.3e-3])
    ap.add_argument("--n-entry", type=int, default=35)
    args = parse(ap, argv)
    n_entry = 6 if args.quick else args.n_entry
    interferences = args.interference[:1] if args.quick else args.interference
    mid = interferences[len(interferences) // 2]
    start = time.perf_counter()
    results = header("cushion_ring", argv)
    results.update(
        scene=f"{CHAIN} z={TEETH} engagement strand, {TENSION:.0f} N, {RPM:.0f} rpm, "
        f"n_entry={n_entry}, first {DISCARD} tooth periods discarded",
        seated_edge_m=seated_edge(),
        runs=[],
        comparisons=[],
    )

    def run(name, fidelity="clearance", **model):
        r = measure(RPM, n_entry, name, fidelity=fidelity, **model)
        r["fidelity"] = fidelity
        results["runs"].append(r)
        return r

    def versus(base, other):
        results["comparisons"].append(
            {"base": base["label"], "variant": other["label"], "fidelity": other["fidelity"],
             "change": compare(base, other)}
        )  # fmt: skip

    none = run("no ring")
    for i in interferences:
        versus(none, run(f"ring +{i * 1e3:.2g} mm", cushion=ring(i)))
    if not args.quick:
        versus(none, run(f"ring +{mid * 1e3:.2g} mm, 4x stiff", cushion=ring(mid, stiffness=4)))
        both = run(f"oil + ring +{mid * 1e3:.2g} mm", lubrication=OIL, cushion=ring(mid))
        versus(none, both)
        lumped = run("lumped, no ring", fidelity="lumped")
        versus(
            lumped, run(f"lumped, ring +{mid * 1e3:.2g} mm", fidelity="lumped", cushion=ring(mid))
        )
    return finish(results, args.out, "cushion_ring", chart, start)


if __name__ == "__main__":
    main()

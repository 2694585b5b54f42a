"""What each freedom of the tooth buys, on the main job's six operating points.

    python -m optimize --problem iso --out benchmarks/results/optimize_iso   # ~8 min
    python -m optimize --out benchmarks/results/optimize_default              # 503 s
    python -m benchmarks.archive.design_freedoms                                      # seconds

Reads the two main-job runs (``--iso``, ``--freeform``: their ``results.json``) and puts
their re-measured designs side by side: the ISO 606 forms (no freedom), the ISO 606 box
(4 coordinates: seating radius and angle, flank radius, tip diameter) and the free-form
asymmetric tooth (7 coordinates: each side's seat angle and two flank arcs, the seating
radius), each box searched by Adam (reverse-mode gradients) and by Nelder–Mead on the
same objective. Every design was re-measured the same way by its run: Dopri8 at rtol
1e-9, the sharp peak, the nominal Johnson law and a second law (Hertz, one stiffness),
worst over 500 / 1000 / 1500 rpm × 0 / 2 % wear. Both runs must have been made on the
same operating points (checked). Writes ``design_freedoms.json`` and
``design_freedoms.png``; no simulation runs here.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

from benchmarks.common import ARCHIVE, finish, header, parse, parser, shown

RESULTS = Path(__file__).parents[1] / "results"
ISO = RESULTS / "optimize_iso" / "results.json"
FREEFORM = RESULTS / "optimize_default" / "results.json"
LAWS = ("johnson", "hertz")
#: settings both runs must share for their designs to be compared
SHARED = ("scene", "chain", "teeth", "speed_rpm", "load", "ensemble", "wear", "remeasure_rtol")


def _designs(run: dict) -> dict:
    """The run's two optimized designs, re-measured: {method: {law: worst peak [N]}}."""
    rm = run["remeasured"]
    adam = rm.get("gradient", rm["optimized"])  # runs before both were kept: "optimized"
    out = {"adam": {law: adam[law]["peak_N"] for law in LAWS}}
    nm = run["gradient_free"]
    if not nm.get("skipped"):
        out["nelder_mead"] = {law: nm["remeasured"][law] for law in LAWS}
    return out


def _members(entry: dict) -> list[float] | None:
    rows = entry["johnson"].get("members")
    return None if rows is None else [r["peak_N"] for r in rows]


def compare(iso: dict, freeform: dict) -> dict:
    """The table: every design's worst peak under both laws and against the ISO minimum
    form, and the per-member peaks (Johnson) where the run kept them."""
    differ = [k for k in SHARED if iso["settings"][k] != freeform["settings"][k]]
    if differ:
        raise ValueError(
            f"the two runs were made on different operating points or models ({differ}): "
            "re-run one with the other's settings"
        )
    rm = freeform["remeasured"]
    forms = {f: {law: rm[f"iso_{f}"][law]["peak_N"] for law in LAWS} for f in ("min", "mid", "max")}
    rows = [
        {"freedom": "ISO 606 form", "coordinates": 0, "design": f"{f} form", **forms[f]}
        for f in ("min", "mid", "max")
    ]
    for freedom, run, n in (("ISO 606 box", iso, 4), ("free-form asymmetric", freeform, 7)):
        for method, peaks in _designs(run).items():
            rows.append({"freedom": freedom, "coordinates": n, "design": method, **peaks})
    ref = forms["min"]
    for r in rows:
        r["vs_iso_min"] = {law: r[law] / ref[law] - 1 for law in LAWS}
    members = {"iso_min": _members(rm["iso_min"])}
    for name in ("gradient", "nelder_mead"):
        if name in rm:
            members[f"free-form {name}"] = _members(rm[name])
    points = [(m["speed_factor"], m["wear"]) for m in freeform["summary"]["members"]]
    return {
        "rows": rows,
        "members": members,
        "points": points,
        "delivered": freeform["optimized"].get("method", "gradient"),
    }


def chart(results: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    rows = results["table"]["rows"]
    fig, ax = plt.subplots(1, 2, figsize=(13, 4.8), gridspec_kw={"width_ratios": [3, 2]})
    short = {"ISO 606 form": "ISO 606", "ISO 606 box": "ISO box (4)"}
    short["free-form asymmetric"] = "free-form (7)"
    labels = [f"{short[r['freedom']]}\n{r['design'].replace('_', '-')}" for r in rows]
    x = np.arange(len(rows))
    for k, (law, color) in enumerate((("johnson", "tab:red"), ("hertz", "tab:gray"))):
        v = [100 * r["vs_iso_min"][law] for r in rows]
        bars = ax[0].bar(x + (k - 0.5) * 0.38, v, 0.38, color=color, label=f"{law.title()} law")
        for b, val in zip(bars, v, strict=True):
            ax[0].annotate(
                f"{val:+.1f}",
                (b.get_x() + b.get_width() / 2, val),
                ha="center",
                va="bottom" if val >= 0 else "top",
                fontsize=7,
            )
    ax[0].axhline(0, color="k", lw=0.8)
    ax[0].set_xticks(x, labels, fontsize=7)
    ax[0].set(
        ylabel="worst-member peak against the ISO minimum form [%]",
        title="Re-measured designs, six operating points (Dopri8, sharp peak)",
    )
    ax[0].legend(fontsize=8)
    ax[0].grid(alpha=0.3, axis="y")

    pts = results["table"]["points"]
    styles = {"iso_min": ("tab:blue", "ISO 606 minimum form")}
    styles["free-form gradient"] = ("tab:orange", "free-form, Adam")
    styles["free-form nelder_mead"] = ("tab:green", "free-form, Nelder–Mead")
    for name, peaks in results["table"]["members"].items():
        if peaks is None:
            continue
        color, label = styles[name]
        ax[1].plot(np.arange(len(pts)), peaks, "o-", color=color, label=label)
    ax[1].set_xticks(
        np.arange(len(pts)), [f"{1000 * f:g} rpm\n{100 * w:g} %" for f, w in pts], fontsize=8
    )
    ax[1].set(
        xlabel="operating point (speed, chain wear)",
        ylabel="re-measured peak, Johnson law [N]",
        title="Per operating point",
    )
    ax[1].legend(fontsize=8)
    ax[1].grid(alpha=0.3)
    fig.suptitle(
        f"{results['command']} — {results['date']}; the runs: {results['sources']['iso']}, "
        f"{results['sources']['freeform']}",
        fontsize=8,
    )
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None) -> dict:
    ap = parser(__doc__, out=ARCHIVE, quick_help="(no effect: nothing is simulated)")
    ap.add_argument("--iso", type=Path, default=ISO, help="the ISO-box run's results.json")
    ap.add_argument("--freeform", type=Path, default=FREEFORM,
                    help="the free-form run's results.json")  # fmt: skip
    args = parse(ap, argv)
    start = time.perf_counter()
    runs = {}
    for name, p in (("iso", args.iso), ("freeform", args.freeform)):
        if not p.exists():
            raise SystemExit(f"{p} not found: make it with the command in this module's help")
        runs[name] = json.loads(p.read_text())

    results = {
        **header("design_freedoms", argv),
        "sources": {"iso": shown(args.iso), "freeform": shown(args.freeform)},
        "runs": {k: {"settings": r["settings"], "versions": r.get("versions")}
                 for k, r in runs.items()},
        "table": compare(runs["iso"], runs["freeform"]),
    }  # fmt: skip
    for r in results["table"]["rows"]:
        print(
            f"{r['freedom']:22s} {r['design']:12s} Johnson {r['johnson']:6.0f} N "
            f"({100 * r['vs_iso_min']['johnson']:+5.1f} %)  Hertz {r['hertz']:6.0f} N "
            f"({100 * r['vs_iso_min']['hertz']:+5.1f} %)"
        )
    return finish(results, args.out, "design_freedoms", chart, start)


if __name__ == "__main__":
    main()

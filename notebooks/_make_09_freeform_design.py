"""Generate ``notebooks/09_freeform_design.ipynb`` (run from anywhere):

    .venv/bin/python notebooks/_make_09_freeform_design.py

The notebook walks through the free-form tooth that ``python -m optimize`` (the main job,
its default problem) delivers, reading the committed run in
``benchmarks/results/optimize_default/``: the design space and operating points, the
objective's history (Adam and Nelder–Mead), the tight re-measurement under both contact
laws, and the clearance-joint chain's comparison with its 95 % interval. One live check
re-measures the worst operating point (ISO minimum form and delivered tooth; Dopri8 at the
run's rtol 1e-9; skipped with ``JAXCHAIN_FAST=1``, as the test suite sets it). No
optimization is re-run. This script writes it without outputs;

    .venv/bin/python notebooks/_make_all.py --execute 09

executes it in full mode, storing the outputs (the form it is committed in).
"""

from nbformat.v4 import new_code_cell, new_markdown_cell

from _write import BENCHMARKS, CACHE, STAMP, X64, write

CELLS = [
    new_markdown_cell(
        """# The free-form tooth of the main job

`python -m optimize` (the main job, on its defaults: `--problem gentle`) designs a
free-form asymmetric tooth gap for an 08B chain on an 18-tooth driver against the worst
peak roller/tooth force over six operating points, then re-measures it independently.
This notebook walks through the run committed in `benchmarks/results/optimize_default/`
(made by README command 1, `python -m optimize`; its settings are in `results.json`):

1. the design space: the tooth's seven coordinates and their bounds, the operating
   points, and the delivered tooth drawn against the ISO 606 forms;
2. the objective's history: Adam's iterations and Nelder–Mead's best-so-far;
3. the re-measurement: tight solves of the ISO forms and of both designs under the
   nominal (Johnson) contact law and a second (Hertz) law;
4. the clearance-joint chain: the delivered tooth against the ISO minimum form over 31
   engagements each, with the 95 % interval of the difference;
5. one live check: the worst operating point re-measured here, both teeth.

**No optimization is re-run**: every number except section 5's is read from the run's
`results.json` and printed from it. Section 5 solves two engagements (Dopri8 at the run's
rtol 1e-9; skipped with `JAXCHAIN_FAST=1`, as the test suite sets it)."""
    ),
    new_code_cell(
        """import json
import os
import sys
from pathlib import Path

import jax

"""
        + X64
        + """import matplotlib.pyplot as plt
import numpy as np

import jaxchain as jc
"""
        + CACHE
        + STAMP
        + BENCHMARKS
        + """from optimize.problem import Settings, make_problem

FAST = os.environ.get("JAXCHAIN_FAST") == "1"
RUN = root / "benchmarks" / "results" / "optimize_default"
run = json.loads((RUN / "results.json").read_text())
tooth = jc.load_profile(RUN / "profile.json")  # the delivered tooth, leaf for leaf
s = run["settings"]
print(
    f"committed run: problem {run['problem']!r}, jaxchain {run['versions']['jaxchain']}, "
    f"jax {run['versions']['jax']}, {run['versions']['xla_flags']}"
)
print(
    f"total {run['timing']['total_s']:.0f} s: "
    + ", ".join(
        f"{k.removesuffix('_s')} {run['timing'][k]:.0f} s"
        for k in ("baselines_s", "optimization_s", "remeasure_s", "clearance_s")
    )
)"""
    ),
    new_markdown_cell(
        """## 1. The design space

The tooth is a `jc.FreeformProfile`: each side of the gap (clockwise, the side the
driver's load presses the roller against, and counter-clockwise) has its own seat angle
and a flank of two tangent arcs (their curvatures), plus the seating radius shared by
both; the tip circle is ISO's smallest. Seven coordinates, each mapped into its box by a
sigmoid (`DesignSpace.select`), started from the ISO 606 minimum form (2 % inside the
box where that form lies on its edge)."""
    ),
    new_code_cell(
        """settings = Settings(**{k: tuple(v) if isinstance(v, list) else v for k, v in s.items()})
problem = make_problem(settings)  # the run's problem: its space, scenes and window
space = run["design_space"]
assert np.allclose(np.asarray(problem.space.lower), space["lower"])
assert np.allclose(np.asarray(problem.space.upper), space["upper"])
UNITS = {  # name → (unit, scale from SI)
    "seating_radius": ("mm", 1e3), "seat_angle": ("deg", 180 / np.pi), "curvature": ("1/m", 1.0)
}  # fmt: skip


def flat(params):
    \"\"\"A params dict of the run (floats or lists) as one row per coordinate.\"\"\"
    return [v for name in space["parameters"] for v in np.atleast_1d(params[name])]


rows = [
    f"{name}[{i}]" if len(shape) else name
    for name, shape in zip(space["parameters"], space["shapes"])
    for i in range(shape[0] if shape else 1)
]
start, delivered = flat(run["history"][0]["params"]), flat(run["optimized"]["params"])
print(
    f"{'coordinate':18s} {'unit':4s} {'lower':>8s} {'upper':>8s} {'start':>8s} "
    f"{'delivered':>9s}  fraction of box"
)
for k, row in enumerate(rows):
    unit, scale = UNITS[row.split(".")[-1].split("[")[0]]
    lo, hi = space["lower"][k] * scale, space["upper"][k] * scale
    print(
        f"{row:18s} {unit:4s} {lo:8.3f} {hi:8.3f} {start[k] * scale:8.3f} "
        f"{delivered[k] * scale:9.3f}  {run['history'][0]['fraction'][k]:.3f} → "
        f"{run['optimized']['fraction_of_box'][k]:.3f}"
    )
points = problem.operating_points
print(
    f"\\noperating points: speed {s['speed_rpm']:.0f} rpm × {s['ensemble']} and chain wear "
    f"{[f'{100 * w:g} %' for w in s['wear']]}: {len(points)} members, "
    f"{s['load']:.0f} N entry tension, {s['fidelity']} chain"
)
print(
    "window [ms]:",
    [round(1e3 * t, 3) for t in run["window_s"]],
    "(the slowest member's second tooth period)",
)"""
    ),
    new_markdown_cell(
        """The delivered tooth (dash-dotted) against the ISO 606 minimum and maximum forms and the
band between them, a roller seated in each; the clockwise side is on the right:"""
    ),
    new_code_cell(
        """fig, ax = plt.subplots(1, 2, figsize=(13, 5), gridspec_kw={"width_ratios": (3, 2)})
for a in ax:
    jc.plot_profiles(problem.chain, settings.teeth, extra={"delivered free-form tooth": tooth},
                     ax=a, gaps=0)  # fmt: skip
ax[0].get_legend().remove()
ax[1].set(xlim=(3.8, 7.2), ylim=(34.5, 40.2), title="the clockwise flank, enlarged")
fig.tight_layout()
plt.show()"""
    ),
    new_markdown_cell(
        """**What the table and drawing show.** Adam moved four of the seven coordinates
markedly: the clockwise seat angle out of the ISO range to 74.2° (the minimum form, ISO's
largest: 67.5°), its lower flank arc flatter (13.8 against 29.1 1/m), the
counter-clockwise lower arc flatter too (22.7 1/m), and the counter-clockwise seat angle
to 99 % of its box, pressed against its upper bound (68°): the box limits it there, and
the run cannot say what lies beyond. The seating radius stays near ISO's smallest (2 → 4 %
of its range). Both outer arcs end where they started (29.1 1/m): the
roller never reaches them in these scenes, so their gradient is zero. In the drawing the
delivered seat lies on the minimum form's; on the clockwise side (right) its seat arc runs
further up and its flank rises steeper than even the minimum form's, outside the ISO
band (the gap up to 0.4 mm narrower there), while on the counter-clockwise side (left)
its flank stays on the minimum form's (within 0.04 mm). Its teeth are cut at ISO's
smallest tip circle, lower than the minimum form's tips."""
    ),
    new_markdown_cell(
        """## 2. The objective's history

The design objective is the soft maximum over the six members of each member's soft peak
force (the design model: fixed 4 µs Tsit5 steps, contact onset widened to 3 µm, joint
friction's creep band to 20 mm/s). Adam (optax) takes 10 value-and-gradient steps from
the ISO minimum form; Nelder–Mead searches the same objective from the same start with
forward solves only (120 simulations). The run stores the ISO forms' *re-measured*
peaks, not their design-objective values: of the three ISO forms only the minimum form's
objective is known, as Adam's iteration 0 (its start)."""
    ),
    new_code_cell(
        """hist = run["history"]
it = np.array([h["iteration"] for h in hist])
obj = np.array([h["objective_N"] for h in hist])
gnorm = np.array([h["grad_norm_N"] for h in hist])
sims = np.array([h["simulations"] for h in hist])
gf = run["gradient_free"]
nm = np.asarray(gf["best_so_far_N"])
nm_sims = gf["simulations_per_evaluation"] * np.arange(1, len(nm) + 1)
best = run["optimized"]
print(f"{'iteration':>9s} {'objective [N]':>14s} {'|grad| [N]':>11s} {'simulations':>12s}")
for h in hist:
    print(
        f"{h['iteration']:9d} {h['objective_N']:14.1f} {h['grad_norm_N']:11.1f} "
        f"{h['simulations']:12d}"
    )
print(
    f"Adam's best: iteration {best['iteration']}, {best['objective_N']:.1f} N "
    f"({100 * (best['objective_N'] / obj[0] - 1):+.1f} % from the start)"
)
print(
    f"Nelder–Mead: {gf['simulations']} simulations, best {gf['best_N']:.1f} N "
    f"({gf['best_N'] - best['objective_N']:+.1f} N against Adam's best; reached it: "
    f"{'never' if gf['simulations_to_target'] is None else gf['simulations_to_target']})"
)
t = run["timing"]
at_best = sims[it == best["iteration"]][0]
print(
    f"cost: value and gradient {t['grad_over_forward']:.2f}× a value (median calls): Adam's "
    f"best {at_best} simulations = {at_best * t['grad_over_forward']:.0f} forward-simulation "
    f"equivalents, Nelder–Mead {gf['simulations']}"
)
print(
    f"the objective at the delivered design lies {100 * run['soft_peak_bias']:+.1f} % from "
    f"its re-measured peak (design model, soft maximum)"
)
assert best["iteration"] == int(np.argmin(obj))

fig, ax = plt.subplots(1, 3, figsize=(15, 3.8))
ax[0].plot(it, obj, "o-", color="C3", label="Adam")
ax[0].axhline(obj[0], color="k", ls="--", lw=0.8, label=f"ISO min form (start): {obj[0]:.0f} N")
ax[0].plot(best["iteration"], best["objective_N"], "*", ms=14, color="C3",
           label=f"best: iteration {best['iteration']}")  # fmt: skip
ax[0].set(xlabel="iteration", ylabel="design objective [N]", title="Adam")
ax[0].legend(fontsize=8)
ax[1].semilogy(it, gnorm, "o-", color="C3")
ax[1].axhline(s["clip"], color="0.5", ls=":", label=f"clipped at {s['clip']:.0f} N")
ax[1].set(xlabel="iteration", ylabel="gradient norm [N]", title="Adam's gradient")
ax[1].legend(fontsize=8)
ax[2].plot(sims, obj, "o-", color="C3", label="Adam (value + gradient)")
ax[2].step(nm_sims, nm, where="post", color="0.3", label="Nelder–Mead, best so far")
ax[2].axhline(obj[0], color="k", ls="--", lw=0.8)
ax[2].set(xlabel="simulations", ylabel="design objective [N]", title="against simulations")
ax[2].legend(fontsize=8)
fig.tight_layout()
plt.show()"""
    ),
    new_markdown_cell(
        """**What the history shows.** Adam's objective falls steadily, by 53–61 N an iteration,
for six iterations, then flattens: 1364, 1343, 1337 N at iterations 6–8 and
back up to 1340 N at iteration 9. The best iterate is iteration 8, with the gradient
down to 9 N from about 200 N; the job keeps it, not the last one. Whether that is
converged the run cannot say: it stops at its budget of 10 iterations, the last step
rose, and at iteration 6 the gradient jumped to 421 N before falling — the objective is
rough where a rebound appears or vanishes. Every gradient but those of iterations 7, 8
and 9 were above the clipping norm, so Adam saw them clipped to 100 N. Nelder–Mead, on
forward solves only, finds a plateau at 1494 N after 18 simulations, stays there for 60,
and ends 1.9 N above Adam's best after 120 simulations: it never reaches it. But Adam's
54 simulations to its best are value-and-gradient calls, each costing 2.9 forward calls
in this run: about 156 forward-simulation equivalents against Nelder–Mead's 120. On
these seven coordinates the gradient bought 1.9 N (0.1 %) for about 30 % more compute.
Neither value is a peak force: at the delivered design the objective lies 25 % below the
re-measured peak (section 3)."""
    ),
    new_markdown_cell(
        """## 3. The re-measurement

Every design is re-measured with the nominal model (10 nm contact onset, nominal joint
friction), Dopri8 at rtol 1e-9 and the sharp peak from saves 0.5 µs apart, at every
operating point over the slowest member's window, under the nominal Johnson law and a
second, Hertz (Lankarani–Nikravesh) law. The worst member's peak counts."""
    ),
    new_code_cell(
        """rem = run["remeasured"]
better = run["better_baseline"]
NAMES = {"iso_min": "ISO 606 min form", "iso_max": "ISO 606 max form",
         "iso_mid": "ISO 606 mid form", "gradient": "Adam's design (delivered)",
         "nelder_mead": "Nelder–Mead's design"}  # fmt: skip
best_iso = {
    law: min(rem[f][law]["peak_N"] for f in ("iso_min", "iso_max", "iso_mid"))
    for law in ("johnson", "hertz")
}
print(
    f"{'design':28s} {'Johnson [N]':>12s} {'vs best ISO':>11s} {'Hertz [N]':>10s} "
    f"{'vs best ISO':>11s}"
)
for key, name in NAMES.items():
    j, h = rem[key]["johnson"]["peak_N"], rem[key]["hertz"]["peak_N"]
    print(
        f"{name:28s} {j:12.1f} {100 * (j / best_iso['johnson'] - 1):+10.1f} % {h:10.1f} "
        f"{100 * (h / best_iso['hertz'] - 1):+10.1f} %"
    )
print(f"delivered: {best['method']} (the better re-measured of the two); best ISO form: {better}")
for law, r in run["reduction_vs_better_baseline"].items():
    print(f"reduction against the best ISO form, {law}: {100 * r:.1f} %")
assert np.isclose(run["reduction_vs_better_baseline"]["johnson"],
                  1 - rem["gradient"]["johnson"]["peak_N"] / best_iso["johnson"])  # fmt: skip

print("\\nper operating point (delivered / ISO min form):")
print(
    f"{'rpm':>5s} {'wear':>5s} {'Johnson [N]':>19s} {'change':>8s} {'Hertz [N]':>19s} {'change':>8s}"
)
table = []
for i, (f, e) in enumerate(points):
    row = [rem[d][law]["members"][i]["peak_N"] for law in ("johnson", "hertz")
           for d in ("optimized", "iso_min")]  # fmt: skip
    table.append(row)
    print(
        f"{s['speed_rpm'] * f:5.0f} {100 * e:4.0f}% {row[0]:9.0f} / {row[1]:7.0f} "
        f"{100 * (row[0] / row[1] - 1):+7.1f}% {row[2]:9.0f} / {row[3]:7.0f} "
        f"{100 * (row[2] / row[3] - 1):+7.1f}%"
    )
table = np.array(table)
sp = run["spectra"]
print(
    f"\\ndriver torque spectrum at the worst member ({s['speed_rpm'] * sp['speed_factor']:.0f} "
    f"rpm, {100 * sp['wear']:g} % wear), band RMS [N·m], delivered / ISO min: "
    + ", ".join(
        f"{band} {sp['optimized']['band_rms'][band]:.2f} / {sp['iso_min']['band_rms'][band]:.2f}"
        for band in sp["optimized"]["band_rms"]
    )
)

labels = [f"{s['speed_rpm'] * f:.0f} rpm\\n{100 * e:g} % wear" for f, e in points]
x = np.arange(len(points))
fig, ax = plt.subplots(1, 2, figsize=(13, 4), sharey=True)
for a, law, cols in ((ax[0], "Johnson (nominal)", (0, 1)), (ax[1], "Hertz (second law)", (2, 3))):
    a.bar(x - 0.2, table[:, cols[1]], 0.4, color="0.6", label="ISO 606 min form")
    a.bar(x + 0.2, table[:, cols[0]], 0.4, color="C3", label="delivered tooth")
    a.set_xticks(x, labels, fontsize=8)
    a.set_title(f"re-measured peak, {law} law")
    a.legend(fontsize=8)
ax[0].set_ylabel("peak roller/tooth force [N]")
fig.tight_layout()
plt.show()"""
    ),
    new_markdown_cell(
        """**What the re-measurement shows.** Under the law it was designed with, the delivered
tooth lowers the worst peak from the minimum form's 2255 N to 1793 N, 20.5 %; the ISO
minimum form is the best of the three ISO forms, the maximum form the worst (2892 N).
The gain is all at 1000 and 1500 rpm (−17 to −20 %); at 500 rpm the delivered tooth is
*worse* than the minimum form by 10–11 % (888 against 798–808 N), below the worst
member's peak, so the worst-case objective does not see it. Under the Hertz law the same
tooth gains only 3.1 % in the worst member (1062 against 1096 N), and only at 1500 rpm
(−1 to −6 %): at 500 and 1000 rpm it is 6–25 % *worse* than the minimum form. How much,
and where, the tooth helps depends on the contact law, which the lumped chain's design
does not settle. Nelder–Mead's design, near Adam's in the design objective, re-measures 2 % higher
under Johnson (1832 N) and the same under Hertz. A gentler peak is not a quieter impact
spectrum either: the delivered tooth lowers the driver torque's 0–1 kHz band and raises
the 1–5 and 5–20 kHz bands."""
    ),
    new_markdown_cell(
        """## 4. The clearance-joint chain

The source paper's model: rigid links on pin/bush clearance joints, each roller on its own
bush/roller joint, Dahl joint friction. Its meshing peaks scatter from engagement to
engagement (the rollers rattle in their clearances), so each design is compared over 31
engagements at the ISO minimum form's worst operating point, with Welch's 95 % interval
on the difference of the means (delivered − ISO min)."""
    ),
    new_code_cell(
        """c = run["clearance"]
print(c["model"])
for m in c["members"]:
    opt, base = m["optimized"], m[c["baseline"]]
    d = opt["difference"]
    print(f"\\n{s['speed_rpm'] * m['speed_factor']:.0f} rpm, {100 * m['wear']:g} % wear:")
    for name, r in (("ISO 606 min form", base), ("delivered tooth", opt)):
        lo, hi = r["ci95_N"]
        print(
            f"  {name:17s} mean {r['mean_N']:6.0f} N [95 % CI {lo:.0f}, {hi:.0f}], sd "
            f"{r['std_N']:.0f} N, p95 {r['p95_N']:.0f} N, min {min(r['peaks_N']):.0f} N, "
            f"max {r['max_N']:.0f} N, n = {r['n']}"
        )
    lo, hi = d["ci95_N"]
    print(
        f"  difference {d['mean_N']:+.0f} N ({100 * d['relative']:+.1f} %), 95 % CI "
        f"[{lo:+.0f}, {hi:+.0f}] N ({100 * lo / base['mean_N']:+.1f} to "
        f"{100 * hi / base['mean_N']:+.1f} % of the ISO mean); excludes zero: "
        f"{d['excludes_zero']}"
    )
    check = jc.compare_peaks(base["peaks_N"], opt["peaks_N"])  # recomputed from the peaks
    assert np.allclose([check.ci_low, check.ci_high], d["ci95_N"])
    i = points.index((m["speed_factor"], m["wear"]))
    print(
        f"  the lumped chain at the same point: {table[i, 0]:.0f} against {table[i, 1]:.0f} N "
        f"({100 * (table[i, 0] / table[i, 1] - 1):+.1f} %)"
    )

fig, ax = plt.subplots(1, 2, figsize=(13, 4), gridspec_kw={"width_ratios": (3, 1)})
for name, r, col in (("ISO 606 min form", base, "0.5"), ("delivered tooth", opt, "C3")):
    p = np.asarray(r["peaks_N"])
    ax[0].plot(np.arange(len(p)), p, "o-", ms=4, lw=0.6, color=col, label=name)
    ax[0].axhline(r["mean_N"], color=col, ls="--", lw=1)
    ax[0].axhspan(*r["ci95_N"], color=col, alpha=0.15)
ax[0].set(xlabel="engagement", ylabel="peak roller/tooth force [N]",
          title="per-engagement peaks: means (dashed) and their 95 % intervals (shaded)")  # fmt: skip
ax[0].legend(fontsize=8)
ax[1].errorbar([0], [d["mean_N"]], yerr=[[d["mean_N"] - lo], [hi - d["mean_N"]]], fmt="o",
               color="C3", capsize=8)  # fmt: skip
ax[1].axhline(0, color="k", lw=0.8)
ax[1].set(xticks=[], xlim=(-1, 1), ylabel="delivered − ISO min [N]",
          title="difference of the means, 95 % CI")  # fmt: skip
fig.tight_layout()
plt.show()"""
    ),
    new_markdown_cell(
        """**What the clearance chain shows.** At 1500 rpm with 2 % wear the delivered tooth's
mean peak is 58 N (3.3 %) below the minimum form's, but the 95 % interval of the
difference runs from −152 to +35 N and **crosses zero**: over 31 engagements the two
teeth cannot be told apart in this model. The per-engagement peaks of both overlap over
most of their range (1116–2023 N delivered, 1310–2064 N ISO), the delivered tooth's
highest is 41 N below the ISO form's, and the engagement-to-engagement scatter (standard
deviation 176–191 N) is three times the difference of the means. The lumped chain's −20.5 % at this
point does not carry over to the model with clearance joints; a run elsewhere (another
CPU model or compiler setting) moves these means by tens of newtons
(`benchmarks/README.md`, optimize_default), within the intervals."""
    ),
    new_markdown_cell(
        """## 5. A live check: the worst operating point

The ISO minimum form and the delivered tooth (`profile.json`), each in a fresh settled
scene at 1500 rpm and 2 % wear, solved by `jc.design.sharp_peak` as the run's
re-measurement does: Dopri8, the largest roller/tooth force over the window. In full mode
at the run's rtol 1e-9, to compare with `results.json` (skipped with `JAXCHAIN_FAST=1`,
as the test suite sets it). The minimum form is solved as a free-form tooth with
its outline (`jc.FreeformProfile.from_iso`), so that both teeth share one compiled
solve."""
    ),
    new_code_cell(
        """if FAST:  # two Dopri8 solves of a free-form tooth: ~20 s of compile and run
    print("JAXCHAIN_FAST=1: the live check is skipped; without it the notebook runs it")
else:
    RTOL = s["remeasure_rtol"]
    worst = int(np.argmax(table[:, 1]))  # the ISO minimum form's worst member
    f, e = points[worst]
    # the ISO minimum form written as a free-form tooth (the same outline): both teeth then
    # share one compiled solve
    iso_min = jc.FreeformProfile.from_iso(
        jc.ToothProfile.iso606(problem.chain, settings.teeth, "min"), 2
    )
    plt.rcParams["path.simplify"] = False  # draw every save: the impacts are µs-wide spikes
    fig, ax = plt.subplots(figsize=(10, 3.8))
    for key, name, profile, col in (("iso_min", "ISO 606 min form", iso_min, "0.5"),
                                    ("optimized", "delivered tooth", tooth, "C3")):  # fmt: skip
        tic = perf_counter()
        scene = problem.build(profile, f, wear=e)
        m = jc.design.sharp_peak(scene, problem.t1, t_start=problem.t_start, rtol=RTOL)
        stored = rem[key]["johnson"]["members"][worst]["peak_N"]
        print(
            f"{name:17s} peak {m['peak_N']:7.1f} N (results.json {stored:7.1f} N, relative "
            f"difference {m['peak_N'] / stored - 1:+.1e}), {m['steps']} steps, rtol {RTOL:g}, "
            f"{perf_counter() - tic:.0f} s"
        )
        # each tooth period of this member holds one meshing: its peak, and the median force
        period = problem.tooth_period / f
        k = ((m["ts"] - problem.t_start) // period).clip(0, None).astype(int)
        k = np.minimum(k, round((problem.t1 - problem.t_start) / period) - 1)
        for j in np.unique(k):
            fj, tj = m["force"][k == j], m["ts"][k == j]
            print(f"  tooth period {j + 1}: peak {fj.max():.0f} N at {1e3 * tj[fj.argmax()]:.3f} ms, "
                  f"median {np.median(fj):.0f} N")  # fmt: skip
        ax.plot(1e3 * m["ts"], m["force"], color=col, lw=0.9, zorder=3 if key == "iso_min" else 2,
                label=f"{name}: peak {m['peak_N']:.0f} N")  # fmt: skip
    ax.set(xlabel="time [ms]", ylabel="largest roller/tooth force [N]",
           title=f"{s['speed_rpm'] * f:.0f} rpm, {100 * e:g} % wear, Johnson law, rtol {RTOL:g}")  # fmt: skip
    ax.legend(fontsize=8)
    plt.show()"""
    ),
    new_markdown_cell(
        """**What the live check shows.** Solved here, the two teeth give the run's worst-member
peaks again (to a few parts in 10⁶ at rtol 1e-9: other steps on another machine and
compiler flags). Three rollers mesh in the window, one per
tooth period; at each the delivered tooth's impact peak is 430–460 N lower (full mode),
and the minimum form's isolated spikes between the meshings are absent. Not all its force
is lower: its median force in each period is about 90–140 N higher (568–614 against
476–481 N), it carries more before each impact, and it rings higher for about half a
millisecond after each. The gain is in the impact peaks, the quantity the job minimizes."""
    ),
    new_markdown_cell(
        """## Conclusions

* **Design space (section 1).** The delivered tooth leaves the ISO band on its clockwise
  side (seat angle 74.2° against the minimum form's 67.5°, a flatter lower flank); the
  counter-clockwise seat angle ends against its upper bound (99 % of the box), so a
  larger box might move it further; both outer arcs are untouched (zero gradient).
* **History (section 2).** Adam lowers the design objective 22 % (1713 → 1337 N) in 9
  evaluations; the best is iteration 8, the last iteration rises 4 N, and a gradient
  spike at iteration 6 shows the objective's roughness. Ten iterations are the run's
  budget, not a convergence test: the flattening and the small gradient at iteration 8
  suggest a local minimum, they do not prove one. Nelder–Mead gets within 1.9 N in 120
  forward simulations, fewer than the 156 forward-simulation equivalents Adam's best
  cost: here the gradient is no cheaper than the gradient-free search.
* **Re-measurement (section 3).** On the lumped chain under the Johnson law the worst
  peak falls 20.5 % (2255 → 1793 N) against the best ISO form; at 500 rpm the tooth is
  10–11 % *worse* than the minimum form. Under the Hertz law the gain is 3.1 %, at
  1500 rpm only: at 500 and 1000 rpm it is 6–25 % worse. The design objective is 25 % below the re-measured peak: it ranks designs, it does not
  predict forces.
* **Clearance chain (section 4).** −3.3 % in the mean peak, with a 95 % interval of
  −152 to +35 N that crosses zero: in the paper's model with clearance joints the tooth is
  not shown to be better than the ISO minimum form.
* **Live check (section 5).** The worst operating point re-solved here reproduces the
  stored peaks of both teeth; its force traces show lower impacts but a higher force
  between them.

The favourable result is real but narrow: a robust 20 % cut of the worst meshing peak in
the model and law it was designed in. It shrinks to 3 % under another contact law, is
not resolved in the clearance-joint chain, and costs 10 % at the lowest speed (6–25 %
at 500 and 1000 rpm under the Hertz law)."""
    ),
]


def main():
    return write(
        CELLS,
        "09_freeform_design.ipynb",
        checkout="reads the committed run in `benchmarks/results/optimize_default/` and "
        "imports `optimize`",
    )


if __name__ == "__main__":
    main()

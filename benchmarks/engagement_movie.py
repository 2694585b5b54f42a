"""The README's opening figures: an 08B chain meshing with an 18-tooth driver, as a movie
coloured by the roller/tooth force, and the same solve's force histories.

The meshing strand of ``jc.scenes.engagement`` (1000 N tight span, 100 N slack) at 1500 rpm
in the lumped chain, from its settled start over 2.5 tooth periods at ``simulate``'s
defaults, 120 frames. Writes ``engagement.gif`` (the rollers coloured by their tooth
force, the colour scale of the whole run), ``engagement_movie.png`` (each meshing
roller's force against time, the exact peak of the solve marked) and
``engagement_movie.json`` (the command, date, machine and the figures' numbers).

    python -m benchmarks.engagement_movie            # ~1 min on 2 cores
"""

from __future__ import annotations

import time

import jax

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402

import jaxchain as jc  # noqa: E402
from benchmarks.common import finish, header, parse, parser, tooth_period  # noqa: E402

RPM, TEETH, TENSION = 1500.0, 18, 1000.0
FRAMES, PERIODS, TRACE = 120, 2.5, 2201


def chart(res: dict, path) -> None:
    """The force histories over the run and about the largest impact (the movie is
    written beside it by ``main``)."""
    import matplotlib.pyplot as plt

    d = res["trace"]
    t, force = np.asarray(d["t_ms"]), np.asarray(d["force_N"])
    fig, ax = plt.subplots(1, 2, figsize=(11, 3.8), gridspec_kw={"width_ratios": [2, 1]})
    k_top = int(np.argmax(force.max(0)))
    t_top = t[int(np.argmax(force[:, k_top]))]
    for a in ax:
        for k, r in enumerate(d["rollers"]):
            a.plot(t, force[:, k], lw=1.3, label=f"roller {r}")
        a.axhline(res["peak_N"], color="k", ls="--", lw=0.8)
        a.grid(alpha=0.3)
        a.set(xlabel="time [ms]")
    ax[0].set(ylabel="roller/tooth force [N]", title=f"{PERIODS:g} tooth periods")
    ax[0].text(t[0], res["peak_N"], f" exact peak {res['peak_N']:.0f} N", va="bottom", fontsize=9)
    ax[1].set_xlim(t_top - 0.12, t_top + 0.25)
    ax[1].set_title("the largest impact", fontsize=10)
    ax[1].legend(fontsize=8, loc="upper right")
    fig.suptitle(
        f"08B chain meshing with an 18-tooth driver at {RPM:.0f} rpm, {TENSION:.0f} N "
        f"tight span\n{res['command']} — {res['date']}",
        fontsize=9,
    )
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)


def main(argv=None) -> dict:
    ap = parser(__doc__)
    ap.add_argument("--frames", type=int, default=FRAMES, help="frames of the movie")
    args = parse(ap, argv)
    start = time.perf_counter()
    res = header("engagement_movie", argv)
    frames = 30 if args.quick else args.frames
    sc = jc.scenes.engagement("08B", TEETH, speed_rpm=RPM, tension=TENSION)
    t1 = PERIODS * tooth_period(TEETH, RPM)
    sol = jc.simulate(sc, t1, n_save=frames)
    dense = jc.simulate(sc, t1, n_save=TRACE)  # the histories: 2.5 µs apart
    force = np.asarray(dense.roller_sprocket_force, dtype=float)
    meshing = [int(r) for r in np.argsort(force.max(0))[::-1][:4]]
    meshing.sort()
    res.update(
        scene=f"jc.scenes.engagement('08B', {TEETH}, speed_rpm={RPM}, tension={TENSION})",
        t1_s=t1,
        frames=frames,
        steps=int(sol.stats["num_steps"]),
        peak_N=float(sol.peak_contact_force),
        saved_peak_N=float(force.max()),  # over the trace's 2.5 µs samples
        trace={
            "t_ms": (np.asarray(dense.ts) * 1e3).tolist(),
            "rollers": meshing,
            "force_N": force[:, meshing].tolist(),
        },
    )
    gif = args.out / "engagement.gif"
    jc.animate(sc, sol, gif, fps=20, dpi=60, color_by="force")
    res["gif_bytes"] = gif.stat().st_size
    print(
        f"{res['steps']} steps; exact peak {res['peak_N']:.0f} N (2.5 µs samples' largest "
        f"{res['saved_peak_N']:.0f} N); {gif} {res['gif_bytes'] / 1e6:.2f} MB"
    )
    return finish(res, args.out, "engagement_movie", chart, start)


if __name__ == "__main__":
    main()

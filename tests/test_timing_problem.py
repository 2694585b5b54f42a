"""``python -m optimize --problem timing`` in fast mode: interrupted and resumed (no
evaluation repeated), its results' summary in the default problem's schema, the
designed sprocket's files, and its objective traced once however many iterations (slow:
about six minutes, most of it the lumped chain's re-measurement)."""

import json

import numpy as np
import pytest

import jaxchain as jc
from optimize import timing
from optimize.__main__ import main


@pytest.mark.slow
def test_timing_problem_interrupted_resumed_and_remeasured(tmp_path, monkeypatch):
    out = tmp_path / "timing"
    real = timing.TimingObjective.value
    calls = []

    def interrupted(self, u):
        calls.append(1)
        if len(calls) == 6:  # Ctrl-C inside CMA-ES (after the baseline and warm-up values)
            raise KeyboardInterrupt
        return real(self, u)

    monkeypatch.setattr(timing.TimingObjective, "value", interrupted)
    with pytest.raises(SystemExit) as e:
        main(["--problem", "timing", "--fast", "--quiet", "--out", str(out)])
    assert e.value.code == 130
    monkeypatch.setattr(timing.TimingObjective, "value", real)
    import pickle

    done = pickle.loads((out / "timing_checkpoint.pkl").read_bytes())["evaluations"]
    kinds = [k for k, _, _ in done]
    assert kinds == ["grad"] * 3 + ["value"] * 2  # Adam's three, then CMA-ES's first two

    res = main(["--problem", "timing", "--fast", "--quiet", "--out", str(out), "--resume"])
    s = res["summary"]
    assert s["unit"] == "N" and s["remeasured"] is True
    assert s["improvement"] == pytest.approx(1 - s["optimized_value"] / s["baseline_value"])
    assert s["baseline_value"] == max(r["p2p"] for r in res["lumped"]["baseline"])
    assert all(r["ok"] for rows in res["lumped"].values() for r in rows)
    assert res["cost"]["traces"] == 2  # the value and the value-and-gradient: no retrace
    assert {r["method"] for r in res["runs"]} == {"Adam", "CMA-ES"}
    assert s["method"] == min(res["runs"], key=lambda r: r["best_J"])["method"]
    saved = json.loads((out / "results.json").read_text())
    assert saved["summary"] == json.loads(json.dumps(s))
    designed = jc.load_profile(out / "profile.json")
    chords = np.linalg.norm(
        np.diff(np.asarray(designed.pitch_points()), axis=0, append=designed.pitch_points()[:1]),
        axis=1,
    )
    np.testing.assert_allclose(chords, float(designed.pitch), atol=1e-12)
    for name in ("sprocket.dxf", "timing.png", "pitch_curve.png"):
        assert (out / name).stat().st_size > 0


def test_timing_settings_are_checked():
    with pytest.raises(ValueError, match="window must be in"):
        timing.TimingSettings(revolutions=3, window=3).validate()
    with pytest.raises(ValueError, match="speeds must be positive"):
        timing.TimingSettings(speeds=(0.0,)).validate()

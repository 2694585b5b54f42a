"""The main job runs end to end on its default and its numbers are physical."""

import json

import jaxchain as jc
from optimize.__main__ import main


def test_main_job_default_runs(tmp_path):
    main(["--out", str(tmp_path)])
    res = json.loads((tmp_path / "demo.json").read_text())
    assert (tmp_path / "tooth_forms.png").stat().st_size > 10_000
    assert (tmp_path / "seat_impact.png").stat().st_size > 10_000
    # the rebound of the free roller is the closed-form restitution of the law it used
    # (Flores / Johnson-with-Flores damping, e = 0.8)
    e_star = jc.contact.hysteresis_restitution(1.6 * (1 - 0.8) / 0.8)
    for case in res["seat_impact"].values():
        assert abs(case["rebound_ratio"] - e_star) < 2e-3
        assert 100 < case["peak_force_N"] < 5000

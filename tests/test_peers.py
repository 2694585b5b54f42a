"""The peer comparison (benchmarks/peers.py) runs end to end with EXUDYN (the ``peers``
extra); slow: ``python -m pytest -m slow tests/test_peers.py``."""

import json

import pytest


@pytest.mark.slow
def test_peers_quick(tmp_path):
    from benchmarks.peers import main  # before exudyn's import: it asks for the fast module

    pytest.importorskip("exudyn")

    main(["--quick", "--out", str(tmp_path)])
    res = json.loads((tmp_path / "peers.json").read_text())
    assert {
        "command",
        "date",
        "machine",
        "parameters",
        "closed_form",
        "refinement",
        "runs",
        "ratio",
        "exudyn_vs_jaxchain_matched",
        "johnson_vs_matched_law",
    } <= set(res)
    assert res["machine"]["loadavg_at_end"] is not None
    assert set(res["runs"]) == {"jaxchain_johnson", "jaxchain_matched", "exudyn"}
    for run in res["runs"].values():
        m = run["metrics"]
        assert run["wall_s"] > 0 and run["cpu_s"] > 0 and run["steps"] > 0
        assert run["loadavg"] is not None
        # both codes against the closed forms: speed ratio z1/z2, torques, tight − slack
        assert abs(m["speed_ratio_error"]) < 0.01
        assert abs(m["driven_torque_error"]) < 0.05
        assert abs(m["driver_torque_error"]) < 0.05
        assert abs(m["tension_error"]) < 0.05
    # and each other, on the mesh-order line of the driven speed
    assert abs(res["exudyn_vs_jaxchain_matched"]["mesh_speed_line_rad_s"]) < 0.2
    assert res["ratio"]["wall_exudyn_over_jaxchain_matched"] > 0
    assert res["ratio"]["cpu_exudyn_over_jaxchain_matched"] > 0
    assert (tmp_path / "peers.png").stat().st_size > 10_000

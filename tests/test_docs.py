"""The documentation site builds with every warning an error (mkdocs.yml): every page,
notebook, chart and relative link between them found, every public docstring parsed."""

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_the_site_builds_strictly(tmp_path):
    env = dict(os.environ, NO_MKDOCS_2_WARNING="1")
    out = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(tmp_path)],
        cwd=ROOT, env=env, capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert out.returncode == 0, out.stderr[-4000:]
    api = (tmp_path / "docs" / "api.html").read_text()
    for name in ("jaxchain.simulate", "jaxchain.scenes.drive", "jaxchain.contact.OilFilm"):
        assert f'id="{name}"' in api, name  # the reference documents the public API
    assert ":class:<code>" not in api and ":meth:<code>" not in api  # roles shown as code
    assert (tmp_path / "notebooks" / "01_drive_walkthrough.html").exists()
    assert (tmp_path / "benchmarks" / "results" / "engagement.gif").exists()

"""Test configuration: float64 everywhere (the library itself never flips JAX config), and
a persistent compilation cache in the repository (``.jax_cache/``), shared by the test
workers, the notebooks they execute and the main job's runs."""

import os
from pathlib import Path

CACHE = Path(__file__).resolve().parents[1] / ".jax_cache"
os.environ.setdefault("JAX_COMPILATION_CACHE_DIR", str(CACHE))  # notebook kernels inherit it
# As in the main job and the notebooks: equinox's in-graph checks return NaN instead of
# calling back to Python (jaxchain reports failures as result codes, checked outside the
# graph); XLA's persistent cache keeps only computations without host callbacks.
os.environ.setdefault("EQX_ON_ERROR", "nan")
os.environ.setdefault("JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS", "0.2")

import jax  # noqa: E402  (after the environment it reads)

jax.config.update("jax_enable_x64", True)
jax.config.update("jax_platforms", "cpu")

import hypothesis  # noqa: E402

hypothesis.settings.register_profile("default", deadline=None, max_examples=60, print_blob=True)
hypothesis.settings.register_profile("ci", deadline=None, max_examples=60, derandomize=True)
hypothesis.settings.load_profile("ci" if os.environ.get("CI") else "default")


def pytest_collection_modifyitems(items):
    """Workers take whole files (module-scoped fixtures then compile once), except the
    notebooks, each of which is a unit of its own (``--dist loadgroup``)."""
    import pytest

    for item in items:
        if item.get_closest_marker("xdist_group") is None:
            name = item.module.__name__
            if name.endswith("test_notebooks"):
                name = item.name
            item.add_marker(pytest.mark.xdist_group(name))

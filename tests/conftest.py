"""Test configuration: float64 everywhere (the library itself never flips JAX config), and
the persistent compilation cache in the user's cache folder (``~/.cache/jaxchain``,
``optimize/xla_flags.py``), shared by the test workers, the notebooks they execute, the
main job's runs and every checkout of the repository on the machine."""

import os
from pathlib import Path

from optimize.xla_flags import fast_compile, use_user_cache  # noqa: E402  (imports no JAX)

use_user_cache()  # in the environment: notebook kernels and subprocesses inherit it
# As in the main job and the notebooks: equinox's in-graph checks return NaN instead of
# calling back to Python (jaxchain reports failures as result codes, checked outside the
# graph); XLA's persistent cache keeps only computations without host callbacks.
os.environ.setdefault("EQX_ON_ERROR", "nan")
os.environ.setdefault("JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS", "0")
# XLA's older CPU fusion emitters, as the main job: a third less compile time
# (optimize/xla_flags.py); each xdist worker on a core of its own (tests/xla_flags.py)
from xla_flags import pin_worker  # noqa: E402  (imports no JAX)

fast_compile()
pin_worker()

import jax  # noqa: E402  (after the environment it reads)

jax.config.update("jax_enable_x64", True)
jax.config.update("jax_platforms", "cpu")

import hypothesis  # noqa: E402
import pytest  # noqa: E402

hypothesis.settings.register_profile("default", deadline=None, max_examples=60, print_blob=True)
# CI: fewer examples, the same seeds every run (each property compiles once; its examples
# run the compiled function)
hypothesis.settings.register_profile("ci", deadline=None, max_examples=40, derandomize=True)
hypothesis.settings.load_profile("ci" if os.environ.get("CI") else "default")


def pytest_configure(config):
    """``JAXCHAIN_TIME_LOG=<folder>``: log each test's wall and compile time there
    (tests/time_log.py)."""
    folder = os.environ.get("JAXCHAIN_TIME_LOG")
    controller = config.getoption("numprocesses", None) and not hasattr(config, "workerinput")
    if folder and not controller:  # the workers run the tests, not xdist's controller
        from time_log import TimeLog

        config.pluginmanager.register(TimeLog(Path(folder)), "jaxchain_time_log")


# Heaviest units first (cold-cache durations on the 2-core machine): each worker takes the
# next unit when it runs dry, so the long ones must not be left for the end. The notebooks
# come last: their kernels load what the tests compiled for the same scenes (the design
# objective, the settled strands, the re-measurement) from the persistent cache.
FIRST = (
    "test_design.py",
    "test_dynamics.py",
    "test_engagement.py",
    "test_ensembles.py",
    "test_clearance.py",
    "test_orders.py",
    "test_multi_drive.py",
    "test_tensioner.py",
    "test_failures.py",
    "test_gap.py",
)
LAST = ("test_notebooks.py",)
# the notebooks, heaviest first (fast mode, cold cache, 2-core machine: 19, 16, 14, 14, 12,
# 10, 4 and 3 s)
NOTEBOOKS = ("03_", "08_", "01_", "04_", "05_", "02_", "09_", "07_", "06_")


def unit(nodeid: str) -> str:
    """The unit of work a test belongs to: its file (a file's module-scoped fixtures and
    compiled functions are built once, on one worker), except that each notebook is a unit
    of its own and the main job's test joins the design tests (the same compiled
    objective)."""
    path = nodeid.split("::", 1)[0]
    if path.endswith("test_notebooks.py"):
        return nodeid
    if path.endswith("test_main_job.py"):
        return path.replace("test_main_job.py", "test_design.py")
    return path


def pytest_collection_modifyitems(items):
    """Order the tests: ``FIRST``, the rest, ``LAST`` (stable within each)."""
    rank = {name: i for i, name in enumerate(FIRST)}
    rank.update({name: len(FIRST) + 1 + i for i, name in enumerate(LAST)})

    def key(item):
        path, _, test = item.nodeid.partition("::")
        file = rank.get(path.rsplit("/", 1)[-1], len(FIRST))
        if not path.endswith("test_notebooks.py"):
            return file, 0
        notebook = test.rsplit("[", 1)[-1]
        return file, next((i for i, p in enumerate(NOTEBOOKS) if notebook.startswith(p)), 0)

    items.sort(key=key)


@pytest.hookimpl(optionalhook=True)  # a hook of pytest-xdist: absent without it (-p no:xdist)
def pytest_xdist_make_scheduler(config, log):
    """``--dist loadfile`` (the default run's) with the units above: xdist's own groups
    (``--dist loadgroup``) rely on rewriting node ids, which pytest ≥ 9.2 ignores
    (pytest-dev/pytest-xdist#1386)."""
    if config.getvalue("dist") != "loadfile":
        return None
    from xdist.scheduler import LoadScopeScheduling

    class UnitScheduling(LoadScopeScheduling):
        def _split_scope(self, nodeid: str) -> str:
            return unit(nodeid)

        def _reschedule(self, node) -> None:
            """xdist's, but a node takes its next unit only when one test is left it (the
            one it holds back to learn its successor): xdist's threshold of two let one
            worker queue up the last notebooks while the other ran dry."""
            if node.shutting_down:
                return
            if not self.workqueue:
                node.shutdown()
                return
            if self._pending_of(self.assigned_work[node]) <= 1:
                self._assign_work_unit(node)

    config.option.loadscopereorder = False  # keep the order above
    return UnitScheduling(config, log)

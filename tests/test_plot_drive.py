"""Plotting helpers for simulated drives: histories, snapshots, animations."""

import math

import matplotlib

matplotlib.use("Agg")

import matplotlib.animation as manimation  # noqa: E402
import matplotlib.collections as mcoll  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from PIL import Image  # noqa: E402

import jaxchain as jc  # noqa: E402
from jaxchain._plots.drive import (  # noqa: E402
    animate,
    plot_forces,
    plot_snapshot,
    plot_speed,
    plot_tensions,
)

RPM = 1000.0
TEETH = 18


@pytest.fixture(scope="module")
def engaged():
    """The meshing scene simulated over three tooth periods, with default options: the
    program tests/test_engagement.py compiles for the same scene (the persistent
    compilation cache shares it between the test workers)."""
    scene = jc.scenes.engagement("08B", TEETH, speed_rpm=RPM, n_entry=8)
    period = 60 / RPM / TEETH
    sol = jc.simulate(scene, 3 * period)
    assert sol.ok, sol.message
    return scene, sol


@pytest.fixture(scope="module")
def closed_drive():
    """A closed two-sprocket drive and a two-frame "solution" of its rigid transport.

    Built from the unsettled layout and not simulated (a drive solve would cost this file's
    time budget on its own): only geometry matters to the snapshot.
    """
    scene = jc.scenes.drive(
        "08B", teeth=(18, 36), speed_rpm=RPM, n_links=100, model=jc.scenes.ChainModel(settle=False)
    )
    q0 = np.asarray(scene.q0)
    body, off = np.asarray(scene.roller_body), np.asarray(scene.roller_offset)
    c, s = np.cos(q0[body, 2]), np.sin(q0[body, 2])
    pos0 = q0[body, :2] + np.stack(
        [c * off[:, 0] - s * off[:, 1], s * off[:, 0] + c * off[:, 1]], -1
    )
    omega = np.array([float(spr.speed) for spr in scene.sprockets])
    theta0 = np.array([float(spr.angle0) for spr in scene.sprockets])
    ts = np.array([0.0, 1e-3])
    n_r, n_l = scene.n_rollers, scene.n_links
    force = np.zeros((2, n_r))
    force[1, :3] = [100.0, 400.0, 50.0]
    sol = jc.Solution(
        ts=ts,
        roller_position=np.stack([pos0, pos0 + [1e-3, 0.0]]),
        roller_velocity=np.zeros((2, n_r, 2)),
        roller_sprocket_force=force,
        link_tension=np.full((2, n_l), 200.0),
        span_tension=np.array([[300.0, 100.0], [320.0, 90.0]]),  # tight, slack
        sprocket_speed=np.tile(omega, (2, 1)),
        sprocket_angle=theta0 + ts[:, None] * omega,
        sprocket_torque=np.zeros((2, 2)),
        peak_contact_force=np.asarray(400.0),
        result=jc.Result.successful,
        stats={},
        y1=None,
    )
    return scene, sol


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    plt.close("all")


def _data_lines(ax):
    """Labelled history lines (not peak markers or reference lines)."""
    return [ln for ln in ax.get_lines() if ln.get_linestyle() == "-" and ln.get_marker() == "None"]


def _roller_collection(ax):
    (coll,) = [c for c in ax.collections if isinstance(c, mcoll.EllipseCollection)]
    return coll


def _savefig(ax, path):
    ax.figure.savefig(path)
    assert path.stat().st_size > 1000


def test_plot_forces_top_rollers(engaged, tmp_path):
    _, sol = engaged
    ax = plot_forces(sol, top=3)
    force = np.asarray(sol.roller_sprocket_force)
    expected = sorted(np.argsort(-force.max(0))[:3].tolist())
    lines = _data_lines(ax)
    assert [ln.get_label() for ln in lines] == [f"roller {i}" for i in expected]
    np.testing.assert_allclose(lines[0].get_xdata(), np.asarray(sol.ts) * 1e3)
    np.testing.assert_allclose(lines[0].get_ydata(), force[:, expected[0]])
    markers = [ln for ln in ax.get_lines() if ln.get_marker() == "o"]
    assert len(markers) == 3
    assert {float(m.get_ydata()[0]) for m in markers} == {force[:, i].max() for i in expected}
    texts = [t.get_text() for t in ax.texts]
    assert len(texts) == 3 and all(t.endswith(" N") for t in texts)
    (dashed,) = [ln for ln in ax.get_lines() if ln.get_linestyle() == "--"]
    assert dashed.get_ydata()[0] == pytest.approx(float(sol.peak_contact_force))
    assert "[ms]" in ax.get_xlabel() and "[N]" in ax.get_ylabel() and ax.get_title()
    assert ax.get_legend() is not None
    _savefig(ax, tmp_path / "forces.png")


def test_plot_forces_chosen_rollers_into_given_axes(engaged):
    _, sol = engaged
    fig, axes = plt.subplots(1, 2)
    assert plot_forces(sol, rollers=[7, -1], ax=axes[1]) is axes[1]
    n = sol.roller_sprocket_force.shape[1]
    assert [ln.get_label() for ln in _data_lines(axes[1])] == ["roller 7", f"roller {n - 1}"]
    assert not axes[0].get_lines()
    with pytest.raises(ValueError, match="out of range"):
        plot_forces(sol, rollers=[n])
    with pytest.raises(ValueError, match="top"):
        plot_forces(sol, top=0)


def test_plot_tensions(engaged, tmp_path):
    _, sol = engaged
    ax = plot_tensions(sol)
    tension = np.asarray(sol.link_tension)
    expected = sorted(np.argsort(-tension.max(0))[:5].tolist())
    assert [ln.get_label() for ln in _data_lines(ax)] == [f"link {i}" for i in expected]
    assert len(ax.texts) == 5
    assert "[ms]" in ax.get_xlabel() and "[N]" in ax.get_ylabel() and ax.get_title()
    _savefig(ax, tmp_path / "tensions.png")
    ax = plot_tensions(sol, links=3)
    assert [ln.get_label() for ln in _data_lines(ax)] == ["link 3"]
    with pytest.raises(ValueError, match="closed drive"):  # a strand has no spans
        plot_tensions(sol, spans=True)


def test_plot_tensions_of_a_drive_are_its_spans(closed_drive):
    """A closed drive's default: each free span's mean tension, named by its sprockets."""
    _, dsol = closed_drive
    ax = plot_tensions(dsol)
    lines = _data_lines(ax)
    assert [ln.get_label() for ln in lines] == ["span 0: sprocket 0 → 1", "span 1: sprocket 1 → 0"]
    np.testing.assert_allclose(lines[1].get_ydata(), np.asarray(dsol.span_tension)[:, 1])
    assert "span tension" in ax.get_ylabel()
    links = plot_tensions(dsol, spans=False)
    assert all(ln.get_label().startswith("link ") for ln in _data_lines(links))


def test_plot_speed(engaged, closed_drive, tmp_path):
    _, sol = engaged
    ax = plot_speed(sol, relative=False)
    (line,) = _data_lines(ax)
    np.testing.assert_allclose(line.get_ydata(), RPM, rtol=1e-9)  # the driver's prescribed
    assert "[rpm]" in ax.get_ylabel() and "[ms]" in ax.get_xlabel()
    _savefig(ax, tmp_path / "speed.png")
    scene, dsol = closed_drive
    ax = plot_speed(dsol, scene=scene, relative=False)
    labels = [ln.get_label() for ln in _data_lines(ax)]
    assert labels == ["sprocket 0 (driver, z = 18)", "sprocket 1 (driven, z = 36)"]
    np.testing.assert_allclose(_data_lines(ax)[1].get_ydata(), RPM * 18 / 36)
    # by default each sprocket's fluctuation about its own mean [%], the mean in the legend
    ax = plot_speed(dsol, scene=scene)
    rpm = np.asarray(dsol.sprocket_speed) * 60 / (2 * np.pi)
    for k, line in enumerate(_data_lines(ax)):
        np.testing.assert_allclose(line.get_ydata(), 100 * (rpm[:, k] / rpm[:, k].mean() - 1))
        assert line.get_label().endswith(f": {rpm[:, k].mean():.1f} rpm")
    np.testing.assert_allclose(_data_lines(ax)[0].get_ydata(), 0.0, atol=1e-9)  # the driver
    assert "% of the mean" in ax.get_ylabel()
    with pytest.raises(TypeError, match="relative must be True or False"):
        plot_speed(dsol, relative="yes")


@pytest.mark.parametrize("index", [300, -1])
def test_plot_snapshot_open_strand(engaged, tmp_path, index):
    scene, sol = engaged
    ax = plot_snapshot(scene, sol, index)
    i = index % sol.ts.shape[0]
    pos_mm = np.asarray(sol.roller_position[i]) * 1e3
    coll = _roller_collection(ax)
    np.testing.assert_allclose(coll.get_offsets(), pos_mm)
    np.testing.assert_allclose(coll.get_widths(), 2e3 * float(scene.roller_radius))
    # colours: the force at that time, on that time's scale (the run's with scale="run"),
    # 0 N masked
    force = np.asarray(sol.roller_sprocket_force[i])
    arr = coll.get_array()
    np.testing.assert_allclose(arr.filled(0.0), force)
    assert np.array_equal(np.ma.getmaskarray(arr), force == 0)
    assert coll.get_clim() == (0.0, pytest.approx(float(np.max(force))))
    run = _roller_collection(plot_snapshot(scene, sol, index, scale="run"))
    assert run.get_clim() == (0.0, pytest.approx(float(np.max(sol.roller_sprocket_force))))
    assert float(np.max(force)) < float(np.max(sol.roller_sprocket_force))  # they differ
    assert coll.colorbar is not None and "[N]" in coll.colorbar.ax.get_ylabel()
    (chain,) = [ln for ln in ax.get_lines() if ln.get_label() == "chain"]
    np.testing.assert_allclose(np.column_stack(chain.get_data()), pos_mm)  # open: not closed
    # the sprocket outline turned by its angle at that time, about its centre
    (patch,) = ax.patches
    spr = scene.sprockets[0]
    a = float(sol.sprocket_angle[i, 0])
    rot = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    expect = np.asarray(spr.profile.sprocket_outline()) @ rot.T + np.asarray(spr.centre)
    np.testing.assert_allclose(patch.get_xy()[: len(expect)], expect * 1e3, atol=1e-9)
    assert f"{float(sol.ts[i]) * 1e3:.2f} ms" in ax.get_title()
    assert "[mm]" in ax.get_xlabel() and "[mm]" in ax.get_ylabel()
    assert ax.get_aspect() == 1.0
    # every roller is inside the view
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    assert np.all((pos_mm[:, 0] > x0) & (pos_mm[:, 0] < x1))
    assert np.all((pos_mm[:, 1] > y0) & (pos_mm[:, 1] < y1))
    _savefig(ax, tmp_path / "snapshot.png")


def test_plot_snapshot_closed_chain(closed_drive, tmp_path):
    scene, sol = closed_drive
    ax = plot_snapshot(scene, sol, 1)
    pos_mm = np.asarray(sol.roller_position[1]) * 1e3
    np.testing.assert_allclose(_roller_collection(ax).get_offsets(), pos_mm)
    (chain,) = [ln for ln in ax.get_lines() if ln.get_label() == "chain"]
    xy = np.column_stack(chain.get_data())
    assert len(xy) == scene.n_rollers + 1
    np.testing.assert_allclose(xy[0], xy[-1])  # closed loop
    assert len(ax.patches) == 2
    centres = [p.get_xy()[:-1].mean(0) for p in ax.patches]
    np.testing.assert_allclose(centres[1], np.asarray(scene.sprockets[1].centre) * 1e3, atol=0.5)
    _savefig(ax, tmp_path / "drive.png")


def test_plot_snapshot_options(engaged):
    scene, sol = engaged
    fig, ax = plt.subplots()
    assert plot_snapshot(scene, sol, 0, ax=ax, color_by=None) is ax
    assert _roller_collection(ax).colorbar is None and len(fig.axes) == 1
    ax = plot_snapshot(scene, sol, 0, color_by="speed")
    coll = _roller_collection(ax)
    speed = np.linalg.norm(np.asarray(sol.roller_velocity[0]), axis=-1)
    np.testing.assert_allclose(coll.get_array(), speed)
    assert "[m/s]" in coll.colorbar.ax.get_ylabel()
    with pytest.raises(ValueError, match="color_by"):
        plot_snapshot(scene, sol, color_by="tension")
    with pytest.raises(ValueError, match="scale"):
        plot_snapshot(scene, sol, scale="all")
    n = sol.ts.shape[0]  # 501
    with pytest.raises(IndexError, match=f"index {n} out of range: the solution has {n} save"):
        plot_snapshot(scene, sol, n)


def test_animate_gif(engaged, tmp_path):
    scene, sol = engaged
    n_figs = len(plt.get_fignums())
    path = animate(scene, sol, tmp_path / "drive.gif", stride=50, fps=10, dpi=40)
    assert path == tmp_path / "drive.gif"
    assert path.stat().st_size > 0
    with Image.open(path) as im:
        assert im.n_frames == len(range(0, sol.ts.shape[0], 50))  # 11
        im.seek(im.n_frames - 1)
    assert len(plt.get_fignums()) == n_figs  # its own figure is closed again


def test_animate_into_given_figure(engaged, tmp_path):
    scene, sol = engaged
    fig = plt.figure()
    fig.add_subplot().plot([0, 1])
    path = animate(scene, sol, str(tmp_path / "a.GIF"), stride=200, dpi=30, fig=fig)
    with Image.open(path) as im:
        assert im.n_frames == 3  # saves 0, 200, 400 of 501
    assert plt.fignum_exists(fig.number) and len(fig.axes) == 2  # drive + colorbar


def test_animate_bad_arguments(engaged, tmp_path, monkeypatch):
    scene, sol = engaged
    with pytest.raises(ValueError, match=r"\.avi.*\.gif, \.mp4"):
        animate(scene, sol, tmp_path / "drive.avi")
    with pytest.raises(ValueError, match="unsupported"):
        animate(scene, sol, tmp_path / "drive")
    with pytest.raises(ValueError, match="stride"):
        animate(scene, sol, tmp_path / "drive.gif", stride=0)
    monkeypatch.setattr(manimation.writers, "is_available", lambda name: False)
    with pytest.raises(ValueError, match="ffmpeg.*gif|gif.*ffmpeg"):
        animate(scene, sol, tmp_path / "drive.mp4")
    assert not (tmp_path / "drive.mp4").exists()

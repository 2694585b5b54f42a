"""Saving and loading tooth profiles (``profile.save`` / ``jc.load_profile``): every kind
reads back equal leaf for leaf, bit for bit, static fields included; the file is plain
JSON a person can read; bad files and traced profiles are refused with the reason; the
main job writes its delivered design so."""

import json

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxchain as jc
from jaxchain._profiles.record import profile_to_dict

CH = jc.ChainSpec.iso606("08B")
Z = 18
ISO = jc.ToothProfile.iso606(CH, Z, "mid")
HALF = float(ISO.seating_angle) / 2
KAPPA = 1 / float(ISO.flank_radius)


def assert_bitwise(a, b):
    """Same class, same static fields and tree structure, every leaf the same shape,
    dtype and bytes."""
    assert type(a) is type(b)
    la, ta = jax.tree_util.tree_flatten(a)
    lb, tb = jax.tree_util.tree_flatten(b)
    assert ta == tb  # the treedef holds the static fields (teeth, min_tip_width)
    assert a.teeth == b.teeth and isinstance(b.teeth, int)
    for x, y in zip(la, lb, strict=True):
        x, y = np.asarray(x), np.asarray(y)
        assert (x.shape, x.dtype) == (y.shape, y.dtype)
        assert x.tobytes() == y.tobytes()


def round_trip(profile, tmp_path, name="profile.json"):
    path = profile.save(tmp_path / name)
    assert path == tmp_path / name
    loaded = jc.load_profile(path)
    assert_bitwise(profile, loaded)
    return loaded, json.loads(path.read_text())


def per_gap(seed=0, k=3):
    """A free-form profile with every shape leaf per gap, each side its own flanks."""
    rng = np.random.default_rng(seed)

    def flank(shift):
        return jc.Flank(
            HALF + shift + rng.uniform(-0.04, 0.04, Z),
            KAPPA * (1 + rng.uniform(-0.2, 0.25, (Z, k))),
            np.sort(rng.uniform(0.15, 0.85, (Z, k - 1)), -1),
        )

    return jc.FreeformProfile.from_iso(
        ISO,
        k,
        seating_radius=float(ISO.seating_radius) + rng.uniform(0, 60e-6, Z),
        seat_offset=rng.uniform(-40e-6, 40e-6, Z),
        phase=rng.uniform(-0.003, 0.003, Z),
        tip_diameter=float(ISO.tip_diameter) * 0.99,
        cw=flank(-0.02),
        ccw=flank(0.02),
    )


def asymmetric():
    """Asymmetric uniform tooth (README's example), a tip land asked for."""
    return jc.FreeformProfile.from_iso(
        ISO,
        3,
        cw=jc.Flank(HALF - 0.05, [1.2 * KAPPA, KAPPA, 0.9 * KAPPA], [0.3, 0.6]),
        ccw=jc.Flank(HALF + 0.03, [0.9 * KAPPA, KAPPA, KAPPA], [0.3, 0.6]),
        min_tip_width=0.25e-3,
    )


# ---------------------------------------------------------------------- round trips
@pytest.mark.parametrize(
    "chain, teeth, form",
    [("08B", 18, "min"), ("08B", 18, "max"), ("08B", 18, "mid"), ("06B", 120, "max")],
)
def test_iso_forms_read_back_bit_for_bit(tmp_path, chain, teeth, form):
    """The ISO 606 forms, 06B z = 120's with its tip lowered to where the flanks meet."""
    prof = jc.ToothProfile.iso606(chain, teeth, form)
    _, data = round_trip(prof, tmp_path)
    assert data["kind"] == "ToothProfile" and data["chain"] == chain and data["teeth"] == teeth
    assert data["seating_radius"] == float(prof.seating_radius)


def test_a_tooth_profile_between_the_forms_reads_back(tmp_path):
    lim = jc.iso606_limits(CH, Z)
    prof = jc.ToothProfile(
        teeth=Z,
        pitch=CH.pitch,
        roller_diameter=CH.roller_diameter,
        **{n: lo + 0.3 * (hi - lo) for n, (lo, hi) in lim.items()},
    )
    loaded, _ = round_trip(prof, tmp_path)
    assert float(loaded.flank_radius) == float(prof.flank_radius)


def test_per_gap_free_form_reads_back_with_every_leaf_per_gap(tmp_path):
    prof = per_gap()
    loaded, data = round_trip(prof, tmp_path)
    for name in ("seating_radius", "seat_offset", "phase"):
        assert np.shape(getattr(loaded, name)) == (Z,)
        assert data[name] == np.asarray(getattr(prof, name)).tolist()
    for side in ("cw", "ccw"):
        f = data[side]
        assert f["kind"] == "Flank"
        assert np.shape(f["seat_angle"]) == (Z,)
        assert np.shape(f["curvature"]) == (Z, 3) and np.shape(f["breaks"]) == (Z, 2)
    assert not np.array_equal(loaded.cw.curvature, loaded.ccw.curvature)


def test_asymmetric_free_form_reads_back_with_its_static_fields(tmp_path):
    prof = asymmetric()
    loaded, data = round_trip(prof, tmp_path)
    assert loaded.min_tip_width == 0.25e-3 and data["min_tip_width"] == 0.25e-3
    assert data["cw"]["breaks"] == [0.3, 0.6]
    assert data["cw"]["seat_angle"] != data["ccw"]["seat_angle"]


def test_one_arc_per_gap_keeps_the_shape_of_its_empty_breaks(tmp_path):
    """K = 1 with per-gap curvature (z, 1): breaks are (z, 0), read back as (z, 0)."""
    kap = KAPPA * (1 + 0.05 * np.sin(np.arange(Z)))[:, None]
    prof = jc.FreeformProfile.from_iso(ISO, 1, cw=jc.Flank(HALF, kap), ccw=jc.Flank(HALF, kap))
    assert prof.cw.breaks.shape == (Z, 0)
    round_trip(prof, tmp_path)
    # a uniform K = 1 flank: breaks (0,)
    uniform = jc.FreeformProfile.from_iso(ISO)
    round_trip(uniform, tmp_path, "uniform.json")
    # uniform curvature (1,) beside per-gap empty breaks (z, 0), as eqx.tree_at makes it
    # (the Flank constructor would shape them (0,)): read back as saved
    mixed = eqx.tree_at(lambda p: p.cw.breaks, uniform, jnp.zeros((Z, 0)))
    loaded, _ = round_trip(mixed, tmp_path, "mixed.json")
    assert loaded.cw.breaks.shape == (Z, 0) and loaded.ccw.breaks.shape == (0,)


def test_a_loaded_profile_makes_the_same_contact(tmp_path):
    """gap_contact of the loaded profile is the original's, bit for bit, at points in
    seats, on flanks, at tips and between gaps."""
    contact = jax.jit(jax.vmap(jc.gap_contact, (None, 0)))
    r = float(ISO.pitch_radius)
    ang = np.array([0.0, 0.05, -0.08, np.pi / Z, 0.9, 2.0, 4.0])
    rad = r + np.array([0.0, 0.002, 0.001, 0.004, -0.001, 0.003, 0.0])
    pts = jnp.asarray(np.stack([rad * np.cos(ang), rad * np.sin(ang)], -1))
    for prof in (ISO, per_gap(1)):
        loaded, _ = round_trip(prof, tmp_path)
        (d0, n0), (d1, n1) = contact(prof, pts), contact(loaded, pts)
        assert np.all(np.isfinite(d0)) and np.ptp(np.asarray(d0)) > 1e-4  # points differ
        assert np.asarray(d0).tobytes() == np.asarray(d1).tobytes()
        assert np.asarray(n0).tobytes() == np.asarray(n1).tobytes()


def test_the_file_is_plain_json_a_person_reads(tmp_path):
    path = asymmetric().save(tmp_path / "p.json")
    text = path.read_text()

    def no_constants(name):
        raise AssertionError(f"non-standard JSON constant {name}")

    data = json.loads(text, parse_constant=no_constants)
    assert list(data)[:5] == ["format", "version", "kind", "chain", "units"]
    assert data["format"] == "jaxchain.profile" and data["version"] == 1
    assert data["pitch"] == 0.0127 and data["roller_diameter"] == 0.00851
    assert '"curvature": [' in text and len(text.splitlines()) < 40
    # a chain that is not ISO 606 has no designation
    odd = jc.ToothProfile(
        teeth=Z, pitch=0.0127, roller_diameter=0.0085,
        seating_radius=ISO.seating_radius, seating_angle=ISO.seating_angle,
        flank_radius=ISO.flank_radius, tip_diameter=ISO.tip_diameter,
    )  # fmt: skip
    _, data = round_trip(odd, tmp_path, "odd.json")
    assert data["chain"] is None


def test_an_unfinished_write_leaves_the_old_file(tmp_path, monkeypatch):
    """The file is replaced whole: a failure while writing keeps the old one."""
    path = ISO.save(tmp_path / "p.json")
    before = path.read_text()
    import jaxchain._checks as io  # (profiles and rings write through its helper)

    def broken(*a, **k):
        raise OSError("disk full")

    monkeypatch.setattr(io.os, "replace", broken)
    with pytest.raises(OSError, match="disk full"):
        per_gap().save(path)
    assert path.read_text() == before
    assert [p.name for p in tmp_path.iterdir()] == ["p.json"]  # no temporary left


# ---------------------------------------------------------------------- bad input
def test_a_missing_file_is_named(tmp_path):
    path = tmp_path / "nowhere" / "profile.json"
    with pytest.raises(FileNotFoundError, match="nowhere"):
        jc.load_profile(path)
    with pytest.raises(IsADirectoryError):
        jc.load_profile(tmp_path)
    # writing into a missing folder names the path given, not the temporary beside it
    with pytest.raises(FileNotFoundError, match=r"cannot write the profile file '.*nowhere/p"):
        ISO.save(path)
    with pytest.raises(FileNotFoundError, match=r"cushion ring file '.*nowhere/profile.json'"):
        jc.elements.CushionRing(0.03).save(path)


def _saved(tmp_path, change=None, text=None):
    data = profile_to_dict(asymmetric())
    if change:
        change(data)
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(data) if text is None else text)
    return path


@pytest.mark.parametrize(
    "change, text, match",
    [
        (None, "{not json", "not a jaxchain profile: not JSON"),
        (None, "[1, 2]", "not a jaxchain profile"),
        (None, '{"summary": {}, "settings": {}}', "not a jaxchain profile"),
        (lambda d: d.update(kind="ChainSpec"), None, "unknown profile kind 'ChainSpec'"),
        (lambda d: d.update(version=2), None, "version 2, newer than this jaxchain reads"),
        (lambda d: d.update(version="1"), None, "positive integer"),
        (lambda d: d.pop("tip_diameter"), None, r"missing \['tip_diameter'\]"),
        (lambda d: d.update(colour="red"), None, r"unknown \['colour'\]"),
        (lambda d: d["cw"].update(kind="Gear"), None, "cw: unknown part kind 'Gear'"),
        (lambda d: d.update(pitch="12.7 mm"), None, "pitch must be a number"),
        (lambda d: d.update(phase=[0.0, None]), None, "phase must be a number"),
        (lambda d: d.update(teeth=[18]), None, "teeth must be a number"),
        (lambda d: d["cw"].update(curvature=[[1.0], [2.0, 3.0]]), None, "unequal lengths"),
        (lambda d: d.update(teeth=18.0), None, "teeth must be an integer"),
        # a valid file whose values make no valid tooth: the construction's own check
        (lambda d: d.update(seating_radius=0.001), None, "seating_radius of gap 0"),
    ],
)
def test_a_bad_file_is_refused_with_what_is_wrong(tmp_path, change, text, match):
    path = _saved(tmp_path, change, text)
    with pytest.raises(ValueError, match=match) as e:
        jc.load_profile(path)
    assert str(path) in str(e.value)


def test_a_traced_profile_is_not_saved(tmp_path):
    def inside(prof):
        prof.save(tmp_path / "traced.json")
        return prof.pitch

    with pytest.raises(TypeError, match="traced"):
        jax.jit(inside)(ISO)
    with pytest.raises(TypeError, match="traced"):
        jax.grad(lambda r: inside(jc.FreeformProfile.from_iso(ISO, seating_radius=r)))(
            ISO.seating_radius
        )
    assert not (tmp_path / "traced.json").exists()


# ---------------------------------------------------------------------- the main job
def test_the_main_job_writes_its_delivered_design_loadable(tmp_path):
    """The job's final writing stage (write_design) and the rebuild of a run's design
    from its results.json (for runs made before it wrote profile.json)."""
    from optimize.problem import Settings, make_problem, profile_values
    from optimize.run import (
        PROFILE,
        delivered_profile,
        jsonable,
        write_design,
        write_profile_from_results,
    )

    problem = make_problem(Settings())  # the default problem: the free-form tooth
    u = jnp.linspace(-1.5, 2.0, len(problem.space.lower))
    design = problem.space.profile(u)
    write_design(tmp_path, design)
    assert_bitwise(design, jc.load_profile(tmp_path / PROFILE))
    assert (tmp_path / "sprocket.dxf").stat().st_size > 10_000

    results = {
        "settings": Settings().as_dict(),
        "optimized": {
            "u": np.asarray(u).tolist(),
            "params": profile_values(design, problem.space),
        },
    }
    folder = tmp_path / "old_run"
    folder.mkdir()
    (folder / "results.json").write_text(json.dumps(jsonable(results), indent=1))
    assert_bitwise(design, jc.load_profile(write_profile_from_results(folder)))
    results["optimized"]["params"]["seating_radius"] *= 1.01
    with pytest.raises(ValueError, match="cannot be rebuilt"):
        delivered_profile(results)


def test_a_part_is_read_as_its_fields_declared_class(tmp_path):
    """A free-form profile's flanks load as the library's Flank even where a class of that
    name is defined after it (a notebook's own): the field's declared class comes first."""

    class Flank(eqx.Module):  # noqa: F841  (shadows the part's name, on purpose)
        x: float = 0.0

    profile = jc.FreeformProfile.from_iso(jc.ToothProfile.iso606("08B", 18, "min"))
    profile.save(tmp_path / "p.json")
    loaded = jc.load_profile(tmp_path / "p.json")
    assert type(loaded.cw) is type(profile.cw) and type(loaded.ccw) is type(profile.ccw)

"""The main job's command line is generated from its settings: every Settings field has
its option (or says it has none), with its default in the help, and parses into the
field."""

import dataclasses

import pytest

from optimize.__main__ import FAST, FLAGS, parse
from optimize.problem import Settings


def test_every_setting_has_its_option_and_parses_into_its_field():
    fields = [f for f in dataclasses.fields(Settings) if f.metadata.get("flag", "") is not None]
    assert {f.name for f in dataclasses.fields(Settings)} - {f.name for f in fields} == {
        "remeasure_rtol"  # --fast's 1e-6, else the default: no option of its own
    }
    values = {int: "21", float: "0.125"}
    for f in fields:
        default = getattr(Settings(), f.name)
        if f.metadata.get("choices"):
            text = [c for c in f.metadata["choices"] if c != default][0]
        elif isinstance(default, tuple):
            text = "1,0.5"
        elif isinstance(default, str):
            continue  # chain and optimizer: names checked by Settings.validate
        else:
            text = values[type(default)]
        argv = [FLAGS[f.name], text] + (["--scene", "drive"] if f.name == "wear" else [])
        if f.name == "wear":
            argv[1] = "0,0"  # the drive scene models an unworn chain
        s, _ = parse(argv)
        got = getattr(s, f.name)
        want = (
            tuple(float(v) for v in argv[1].split(","))
            if isinstance(default, tuple)
            else (type(default)(text) if not f.metadata.get("choices") else text)
        )
        assert got == want, (f.name, got, want)


def test_fast_and_the_scene_dependent_default():
    s, args = parse(["--fast", "--iterations", "7"])
    assert s.iterations == 7 and args.given == {"iterations"}  # given: kept
    assert s.periods == FAST["periods"] and s.baseline_budget == FAST["baseline_budget"]
    assert parse([])[0].load == 1000.0 and parse(["--scene", "drive"])[0].load == 20.0
    with pytest.raises(SystemExit):
        parse(["--horizon", "longest"])

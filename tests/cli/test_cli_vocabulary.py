"""One command-line vocabulary: the shared options' canonical names and forms, the older spellings
as hidden aliases (same value, nothing new printed, not in --help), closed sets as argparse choices
(docs/trials.md, "Common options"; grasp_ctrl/cli/_common_options.py). In-process: parsers and main."""

from __future__ import annotations

import argparse
import re
from pathlib import Path

import pytest

from grasp_ctrl.cli import build_parser, main
from grasp_ctrl.controller.registry import controller_names
from grasp_ctrl.files.paths import default_objects_file

OBJECTS = str(default_objects_file())


@pytest.fixture(scope="module")
def commands() -> dict[str, argparse.ArgumentParser]:
    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    return dict(sub.choices)


def _parse(argv: list[str], capsys: pytest.CaptureFixture[str]) -> argparse.Namespace:
    args = build_parser().parse_args(argv)
    assert capsys.readouterr() == ("", ""), argv  # an old spelling prints nothing
    return args


def _flags(parser: argparse.ArgumentParser) -> dict[str, argparse.Action]:
    return {s: a for a in parser._actions for s in a.option_strings}


# ----- old spellings: the same value, nothing printed ------------------------------------------


@pytest.mark.parametrize("command", ["run", "tune", "view", "lift-capacity", "grasp-contacts"])
def test_every_object_file_option_is_object_file_with_objects_file_as_alias(command, capsys):
    extra = {"tune": ["--object", "lego", "--param", "tau_n=2"], "view": ["--object", "lego"]}.get(command, [])
    extra += ["--out", "x.csv"] if command == "grasp-contacts" else []
    new = _parse([command, *extra, "--object-file", "my.toml"], capsys)
    old = _parse([command, *extra, "--objects-file", "my.toml"], capsys)
    assert new.object_file == old.object_file == "my.toml"
    assert not hasattr(new, "objects_file") and vars(new) == vars(old)


def test_lift_capacity_takes_names_separated_by_spaces_or_commas_or_all(capsys):
    words = _parse(["lift-capacity", "--objects", "lego", "paper_cup"], capsys)
    commas = _parse(["lift-capacity", "--objects", "lego,paper_cup"], capsys)
    assert words.objects == commas.objects == "lego,paper_cup"
    assert _parse(["lift-capacity", "--objects", "all"], capsys).objects == "all"
    assert _parse(["lift-capacity"], capsys).objects is None  # the object file's default_set


def _lift_capacity(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    rc = main(["lift-capacity", "--variation", "nominal", *argv])
    out, err = capsys.readouterr()
    return rc, out, err


def test_lift_capacity_old_and_new_spellings_print_the_same(capsys):
    old = _lift_capacity(["--objects-file", OBJECTS, "--objects", "lego", "paper_cup"], capsys)
    new = _lift_capacity(["--object-file", OBJECTS, "--objects", "lego,paper_cup"], capsys)
    assert old == new and old[0] == 0 and old[2] == ""
    assert [ln.split()[0] for ln in old[1].splitlines()[3:]] == ["lego", "paper_cup"]


def test_lift_capacity_all_and_an_unknown_name(capsys):
    from grasp_ctrl.config.objects import load_objects

    names = list(load_objects(OBJECTS))
    _, out, _ = _lift_capacity(["--objects", "all"], capsys)
    assert [ln.split()[0] for ln in out.splitlines()[3:] if not ln.startswith("lift-capacity:")] == names
    rc, out, err = _lift_capacity(["--objects", "lego", "nope"], capsys)
    assert (rc, out) == (2, "")
    assert err.strip() == f"grasp-ctrl: error: --objects: unknown object 'nope' (known: {', '.join(names)})"


def test_pushing_gt_box_file_with_object_as_alias(tmp_path, capsys):
    new = _parse(["pushing-gt", "--trajectory", "t.csv", "--box-file", "box.toml", "--out", "f.csv"], capsys)
    old = _parse(["pushing-gt", "--trajectory", "t.csv", "--object", "box.toml", "--out", "f.csv"], capsys)
    assert new.box_file == old.box_file == "box.toml" and vars(new) == vars(old)
    results = []
    for flag in ("--box-file", "--object"):  # the same run, the same words
        argv = ["pushing-gt", "--trajectory", "t.csv", flag, str(tmp_path / "missing.toml"), "--out", "f.csv"]
        results.append((main(argv), *capsys.readouterr()))
    assert results[0] == results[1] and results[0][0] == 2
    assert main(["pushing-gt", "--trajectory", "t.csv", "--out", "f.csv"]) == 2
    err = capsys.readouterr().err
    assert "--box-file" in err.splitlines()[-1] and "--object" not in err  # the alias is not named


def test_run_force_is_both_new_flags(capsys):
    plain = _parse(["run"], capsys)
    assert (plain.force_resume, plain.force_capacity) == (False, False)
    old = _parse(["run", "--force"], capsys)
    assert (old.force_resume, old.force_capacity) == (True, True)  # as the one --force did
    resume = _parse(["run", "--force-resume"], capsys)
    assert (resume.force_resume, resume.force_capacity) == (True, False)
    capacity = _parse(["run", "--force-capacity"], capsys)
    assert (capacity.force_resume, capacity.force_capacity) == (False, True)
    assert not hasattr(old, "force")


def test_jobs_defaults(capsys):
    assert _parse(["run"], capsys).jobs is None  # one per core for 8+ simulated trials (cmd_run.auto_jobs)
    assert _parse(["tune", "--object", "lego", "--param", "tau_n=2"], capsys).jobs == 1
    assert _parse(["run", "--jobs", "3", "--executor", "ray", "--address", "auto"], capsys).address == "auto"


# ----- the new forms ------------------------------------------------------------------------------


@pytest.mark.parametrize("command", ["run", "tune", "lift-capacity", "grasp-contacts"])
def test_every_object_list_is_a_comma_list_or_all(commands, command):
    action = _flags(commands[command])["--objects"]
    assert action.metavar == "a,b|all" and action.default is None
    argv = {"tune": ["--param", "tau_n=2"], "grasp-contacts": ["--out", "x.csv"]}.get(command, [])
    for spec in ("lego,paper_cup", "all"):
        assert build_parser().parse_args([command, *argv, "--objects", spec]).objects == spec


def test_every_shared_option_has_one_form(commands):
    """--hand, --object-file, --controller, --variation, --jobs/--executor/--address look the same in
    every command that takes them."""
    for name, parser in commands.items():
        flags = _flags(parser)
        if "--hand" in flags:
            assert flags["--hand"].metavar == "FILE", name
        if "--object-file" in flags or "--objects-file" in flags:
            assert flags["--object-file"].dest == flags["--objects-file"].dest == "object_file", name
            assert flags["--object-file"].metavar == "FILE", name
        if "--controller" in flags:
            assert tuple(flags["--controller"].choices) == controller_names(), name
        if "--variation" in flags:
            assert sorted(flags["--variation"].choices) == ["bench", "nominal"], name
        if "--executor" in flags:
            assert tuple(flags["--executor"].choices) == ("local", "ray"), name
            assert {"--jobs", "--address"} <= set(flags), name
    takes = {n for n, p in commands.items() if "--object-file" in _flags(p)}
    assert takes == {"run", "tune", "view", "lift-capacity", "grasp-contacts"}


# ----- --help: no hidden alias --------------------------------------------------------------------

HIDDEN = {
    "run": [r"--objects-file", r"--force(?![-\w])"],
    "tune": [r"--objects-file"],
    "view": [r"--objects-file"],
    "lift-capacity": [r"--objects-file"],
    "grasp-contacts": [r"--objects-file"],
    "pushing-gt": [r"--object(?![-\w])"],
}


@pytest.mark.parametrize("command", sorted(HIDDEN))
def test_help_does_not_show_the_aliases(command, capsys):
    assert main([command, "--help"]) == 0
    text = capsys.readouterr().out
    for pattern in HIDDEN[command]:
        assert not re.search(pattern, text), (command, pattern)
    canonical = {"pushing-gt": "--box-file", "run": "--force-capacity"}.get(command, "--object-file")
    assert canonical in text


# ----- closed sets: argparse's one-line error -----------------------------------------------------


@pytest.mark.parametrize(
    "argv",
    [
        ["run", "--controller", "nope"],
        ["tune", "--object", "lego", "--param", "tau_n=2", "--controller", "nope"],
    ],
)
def test_an_unknown_controller_is_argparses_one_line_error(argv, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    out, err = capsys.readouterr()
    errors = [ln for ln in err.splitlines() if "error:" in ln]
    assert out == "" and len(errors) == 1 and err.startswith("usage: ")
    assert errors[0].startswith(f"grasp-ctrl {argv[0]}: error: argument --controller: invalid choice: 'nope'")
    assert all(name in errors[0] for name in controller_names())
    assert list(Path(tmp_path).iterdir()) == []  # refused before anything ran


def test_an_unknown_preset_is_argparses_one_line_error(capsys):
    assert main(["run", "--preset", "nope"]) == 2
    errors = [ln for ln in capsys.readouterr().err.splitlines() if "error:" in ln]
    assert len(errors) == 1 and "argument --preset: invalid choice: 'nope'" in errors[0] and "paper" in errors[0]

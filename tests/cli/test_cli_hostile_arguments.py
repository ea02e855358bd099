"""Property tests: commands driven with hostile files and arguments, in-process.

For every example: no traceback (one ``error:`` line when the status is not 0), nothing
written outside the paths the command was given (a file that a symlink points to is
never changed, a run's managed files are never an output), and no hang (each case
runs under an alarm). Trials are stubbed, so a case takes milliseconds; the example
counts are small because CI runs the whole suite in minutes.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import shutil
import signal
import tempfile
from collections.abc import Iterator
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from grasp_ctrl.cli import main
from grasp_ctrl.files.paths import policies_dir

SETTINGS = settings(
    max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture]
)
CASE_TIMEOUT_S = 30

HOSTILE_BYTES = st.one_of(
    st.binary(max_size=300),
    st.sampled_from(
        [
            b"",
            b"\x00" * 64,
            b"[" * 3000,
            b"{" * 3000,
            b'{"format": 1}',
            b"nan,nan\n1,2\n",
            ("9" * 5000).encode(),
            b"\xff\xfe\xfd",
            b"t,x\n" + b"1," * 70000,
        ]
    ),
    st.text(max_size=300).map(lambda s: s.encode("utf-8", "surrogatepass")),
)
PLATE_HEADER = (
    "trial_id,sample_idx,timestamp,t_rel_s,pdc,"
    + ",".join(f"e{i}" for i in range(1, 20))
    + ",nx,ny,nz,label_norm,in_paper_trial"
)
CELL = st.sampled_from(["0", "1", "3000", "-1", "nan", "inf", "1e308", "", "x", "0.5", "9" * 400, "\x00"])
OUTPUT_KIND = st.sampled_from(["symlink", "managed", "directory", "bad_extension", "missing_folder", "plain"])


class _Hang(Exception):
    pass


@contextlib.contextmanager
def _deadline(seconds: int) -> Iterator[None]:
    def fire(*_a):
        raise _Hang(f"a case ran longer than {seconds} s")

    old = signal.signal(signal.SIGALRM, fire)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)


@contextlib.contextmanager
def _sandbox() -> Iterator[Path]:
    old = os.getcwd()
    with tempfile.TemporaryDirectory() as d:
        os.chdir(d)
        try:
            yield Path(d)
        finally:
            os.chdir(old)


def _call(argv: list[str]) -> tuple[int, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err), _deadline(CASE_TIMEOUT_S):
        try:
            rc = main(argv)
        except SystemExit as exc:
            rc = exc.code if isinstance(exc.code, int) else 2
    text = err.getvalue()
    assert "Traceback" not in text
    if rc != 0:
        assert len([ln for ln in text.splitlines() if "error:" in ln]) == 1, text
    return rc, text


def _snapshot(root: Path) -> dict[Path, bytes]:
    return {p: p.read_bytes() for p in root.rglob("*") if p.is_file() and not p.is_symlink()}


@pytest.fixture(scope="module")
def stub_run(tmp_path_factory) -> Path:
    """A finished 2-trial run (stubbed trials) that each example copies."""
    from grasp_ctrl.trials.episode import runner

    def fake_trial_fn(hand, policies, settings=None, threads=1, **_kw):
        def run(p, obj, k, seed, log):
            return {"object": obj.name, "policy": p, "trial": k, "seed": seed, "success": True, "reason": None}

        return run

    real = runner.sim_trial_fn
    runner.sim_trial_fn = fake_trial_fn
    try:
        run_dir = tmp_path_factory.mktemp("stub") / "run"
        assert (
            main(
                [
                    "run",
                    "--backend",
                    "mock",
                    "--objects",
                    "lego",
                    "--trials",
                    "2",
                    "--quiet",
                    "--no-tick-logs",
                    "--out",
                    str(run_dir),
                ]
            )
            == 0
        )
    finally:
        runner.sim_trial_fn = real
    return run_dir


def _output(root: Path, run_dir: Path, kind: str, ext: str) -> tuple[str, Path]:
    """An output path of ``kind`` and the victim file outside the command's paths."""
    victim = root / "elsewhere" / "victim.txt"
    victim.parent.mkdir(exist_ok=True)
    victim.write_text("untouched\n")
    if kind == "symlink":
        link = root / f"out.{ext}"
        link.symlink_to(victim)
        return str(link), victim
    if kind == "managed":
        return str(run_dir / "run.json"), victim
    if kind == "directory":
        (root / "adir").mkdir(exist_ok=True)
        return str(root / "adir"), victim
    if kind == "bad_extension":
        return str(root / "out.nonsense"), victim
    if kind == "missing_folder":
        return str(root / "no" / "such" / f"out.{ext}"), victim
    return str(root / f"out.{ext}"), victim


def _check_nothing_outside(before: dict[Path, bytes], root: Path, allowed: list[Path], victim: Path) -> None:
    assert victim.read_text() == "untouched\n"
    after = _snapshot(root)
    for path, data in after.items():
        if any(path == a or a in path.parents for a in allowed):
            continue
        assert before.get(path) == data, f"{path} was written"


@SETTINGS
@given(kind=OUTPUT_KIND, command=st.sampled_from(["score", "compare"]))
def test_score_and_compare_outputs_go_only_where_asked(stub_run, kind, command):
    with _sandbox() as root:
        run_dir = root / "run"
        shutil.copytree(stub_run, run_dir)
        ext = "json" if command == "score" else "png"
        out, victim = _output(root, run_dir, kind, ext)
        managed = {p: p.read_bytes() for p in [run_dir / "run.json", run_dir / "summary.json"]}
        before = _snapshot(root)
        flag = "--json" if command == "score" else "--png"
        rc, _ = _call([command, str(run_dir), flag, out])
        assert all(p.read_bytes() == b for p, b in managed.items())
        allowed = [Path(out)] + ([run_dir / "compare.png"] if command == "compare" else [])
        _check_nothing_outside(before, root, allowed, victim)
        if kind in ("managed", "directory", "bad_extension") and not (command == "score" and kind == "bad_extension"):
            assert rc != 0


@contextlib.contextmanager
def _stubbed_trials() -> Iterator[None]:
    from grasp_ctrl.trials.episode import runner

    def fake_trial_fn(hand, policies, settings=None, threads=1, **_kw):
        def run(p, obj, k, seed, log):
            return {"object": obj.name, "policy": p, "trial": k, "seed": seed, "success": True, "reason": None}

        return run

    real = runner.sim_trial_fn
    runner.sim_trial_fn = fake_trial_fn
    try:
        yield
    finally:
        runner.sim_trial_fn = real


@SETTINGS
@given(target=st.sampled_from(["run.json", "summary.json", "trials/lego_record"]), content=HOSTILE_BYTES)
def test_a_hostile_run_file_gives_one_line_to_score_compare_and_resume(stub_run, target, content):
    with _sandbox() as root:
        run_dir = root / "run"
        shutil.copytree(stub_run, run_dir)
        path = (
            run_dir / target if target != "trials/lego_record" else next(run_dir.glob("trials/*/lego/trial_000.json"))
        )
        path.write_bytes(content)
        before = _snapshot(root)
        for argv in (["score", str(run_dir)], ["compare", str(run_dir), "--no-plot"]):
            _call(argv)
        assert _snapshot(root) == before  # score and compare write nothing unasked
        with _stubbed_trials():
            rc, _ = _call(["run", "--resume", str(run_dir), "--quiet", "--jobs", "1"])
        assert rc in (0, 2)
        after = {p for p in _snapshot(root) if p not in before}
        assert all(run_dir in p.parents for p in after)


@SETTINGS
@given(rows=st.lists(st.lists(CELL, min_size=0, max_size=30), min_size=1, max_size=6), skip=st.booleans())
def test_hostile_plate_recordings_give_one_line_naming_the_line(rows, skip):
    with _sandbox() as root:
        data = root / "plate.csv"
        body = "\n".join(",".join(["A"] + r) for r in rows)
        data.write_text(f"{PLATE_HEADER}\n{body}\n", encoding="utf-8", errors="surrogateescape")
        before = _snapshot(root)
        argv = ["evaluate-direction", "--data", str(data), "--estimators", "analytic", "--trials", "A,B"]
        rc, err = _call(argv + (["--skip-bad-rows"] if skip else []))
        if rc != 0 and not skip and "line" in err:
            assert "line " in err and str(data) in err
        assert _snapshot(root) == before


@SETTINGS
@given(content=HOSTILE_BYTES, kind=OUTPUT_KIND)
def test_hostile_trajectories_for_pushing_gt(content, kind):
    with _sandbox() as root:
        traj = root / "push.csv"
        traj.write_bytes(content)
        obj = root / "box.toml"
        obj.write_text("mass_kg = 0.65\nsize_m = [0.12, 0.16]\nmu = 0.1\n")
        out, victim = _output(root, root / "norun", kind, "csv")
        before = _snapshot(root)
        rc, _ = _call(["pushing-gt", "--trajectory", str(traj), "--object", str(obj), "--out", out])
        _check_nothing_outside(before, root, [Path(out)], victim)
        assert rc != 0 or kind in ("plain", "symlink")


@SETTINGS
@given(
    meta=st.recursive(
        st.one_of(st.none(), st.floats(), st.integers(), st.text(max_size=5)),
        lambda inner: st.one_of(st.lists(inner, max_size=3), st.dictionaries(st.text(max_size=5), inner, max_size=3)),
        max_leaves=6,
    ),
    edit=st.sampled_from(["replace_policy", "nested_run_json", "setting", "objects"]),
)
def test_resume_never_mixes_a_changed_run(stub_run, meta, edit):
    with _sandbox() as root:
        run_dir = root / "run"
        shutil.copytree(stub_run, run_dir)
        next(run_dir.glob("trials/*/lego/trial_001.json")).unlink()
        doc = json.loads((run_dir / "run.json").read_text())
        if edit == "replace_policy":
            pol = root / "p.json"
            shutil.copy(policies_dir() / "linear_mock.json", pol)
            doc["policies"] = [str(pol)]
        elif edit == "nested_run_json":
            doc["fingerprint"] = meta
        elif edit == "setting":
            doc["settings"]["ramp_tolerance_n"] = meta
        else:
            doc["objects"][0]["tau_n"] = meta
        if json.dumps(doc) == (run_dir / "run.json").read_text():
            return
        (run_dir / "run.json").write_text(json.dumps(doc))
        records = sorted(p.read_bytes() for p in run_dir.glob("trials/*/*/*.json"))
        with _stubbed_trials():
            rc, _ = _call(["run", "--resume", str(run_dir), "--quiet", "--jobs", "1"])
        if rc == 0:  # nothing that decides a trial changed: one fingerprint across the run
            fp = json.loads((run_dir / "run.json").read_text())["fingerprint"]["sha256"]
            prints = {json.loads(p.read_text()).get("fingerprint") for p in run_dir.glob("trials/*/*/*.json")}
            assert prints == {fp}
        else:  # refused: nothing ran
            assert rc == 2
            assert sorted(p.read_bytes() for p in run_dir.glob("trials/*/*/*.json")) == records


def _numeric_flags() -> list[tuple[str, str]]:
    """(command, flag) for every number flag of every command."""
    from grasp_ctrl.cli import build_parser

    out = []
    sub = next(a for a in build_parser()._actions if a.choices and isinstance(a.choices, dict))
    for name, parser in sub.choices.items():
        for action in parser._actions:
            flag = next((s for s in action.option_strings if s.startswith("--")), None)
            if flag and getattr(action.type, "__name__", "") in ("float", "int") and action.type not in (int, float):
                out.append((name, flag))
    return sorted(out)


NUMERIC_FLAGS = _numeric_flags()


def test_every_float_flag_of_every_command_is_checked():
    assert ("plot", "--fps") in NUMERIC_FLAGS and ("pushing-gt", "--k") in NUMERIC_FLAGS
    assert len({c for c, _ in NUMERIC_FLAGS}) >= 10


@settings(max_examples=40, deadline=None)
@given(
    case=st.sampled_from(NUMERIC_FLAGS),
    value=st.sampled_from(["nan", "-nan", "inf", "-inf", "1e999", "-1e999", "9" * 400, "-" + "9" * 400, "x", ""]),
)
def test_hostile_numbers_in_any_command_flag_are_one_line(case, value):
    command, flag = case
    with _sandbox() as root:
        rc, err = _call([command, f"{flag}={value}"])
        assert rc == 2 and flag in err
        assert list(root.iterdir()) == []

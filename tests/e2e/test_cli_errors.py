"""The command line never shows a traceback: bad arguments, outputs and inputs give one line.

Usage errors exit with status 2, failures while running with status 1. Each case here was a
traceback (or a silently accepted nonsense value) before.
"""

from __future__ import annotations

import ctypes
import importlib
import importlib.metadata
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from cptbt import cli
from cptbt.cli import inspect_cmds

ROOT = Path(__file__).resolve().parents[2]
MISSION = str(ROOT / "missions/tro2006_msn007.yaml")
SCRIPT = Path(sys.executable).parent / "cptbt"


def cptbt(*args: str, **kw: object) -> subprocess.CompletedProcess[str]:
    return subprocess.run([str(SCRIPT), *args], cwd=ROOT, text=True, capture_output=True,
                          timeout=120, **kw)  # type: ignore[call-overload]


def one_line(res: subprocess.CompletedProcess[str], status: int) -> str:
    """The single stderr line of a failed command, after checking its status."""
    assert res.returncode == status, (res.returncode, res.stderr)
    assert "Traceback" not in res.stderr
    lines = res.stderr.splitlines()
    assert len(lines) == 1, lines
    return lines[0]


@pytest.mark.parametrize(("args", "expected"), [
    (["--grid", "0x3"], "argument --grid: '0x3'"),
    (["--grid", "3xa"], "is not a grid"),
    (["--starts-x", "0:100:0"], "STEP must be more than 0"),
    (["--starts-x", "0:100"], "is not a range"),
    (["--starts-x", "100:0:5"], "X1 must not be less than X0"),
    (["--starts-x", "0:1e9:1e-300"], "more than 100000 starts"),
    (["--starts-x", "0:inf:1"], "finite"),
    (["--starts", "1,2;3"], "'3' is not a start"),
    (["--starts", "nan,0"], "'nan' must be a finite number"),
    (["--starts", "0,1e309"], "must be a finite number"),
    (["--runs-per-start", "0"], "argument --runs-per-start: 0 must be at least 1"),
    (["--runs-per-start", "1.5"], "is not an integer"),
    (["--workers", "0"], "argument --workers: 0 must be at least 1"),
    (["--time-limit", "nan"], "argument --time-limit: 'nan' must be a finite number"),
    (["--time-limit", "inf"], "must be a finite number"),
    (["--time-limit", "-5"], "must be more than 0"),
    (["--time-limit", "0"], "must be more than 0"),
    (["--seed", "-1"], "argument --seed: -1 must be 0 or more"),
    # a review: 2**63 flew a group, then failed writing it, on every resume
    (["--seed", str(2**63)], f"argument --seed: {2**63} must be below 2**63"),
    # a review: an unset shell variable (--out "$OUT") wrote the study into the current folder
    (["--out", ""], "argument --out: an empty folder name"),
    # a review: the second --sweep of a path had silently replaced the first
    (["--sweep", "speed_mps=1", "--sweep", "speed_mps=2"],
     "--sweep speed_mps is given twice (speed_mps=1 and speed_mps=2)"),
    # a review: within every other bound, 10^11 runs took 24 GB before flying one
    (["--grid", "1000x100", "--runs-per-start", "1000000"],
     "100,000,000,000 runs, more than 10,000,000: split the study"),
    (["--y", "nan"], "must be a finite number"),
    (["--sweep", "speed_mps"], "expected PATH=V1,V2"),
    (["--scheduler-timeout", "0"], "must be more than 0"),
    (["--grid", "2x2", "--starts", "0,0"], "not allowed with argument"),
])
def test_bad_batch_argument_is_one_usage_line(
    tmp_path: Path, args: list[str], expected: str
) -> None:
    res = cptbt("batch", MISSION, "--amp-only", *args, "--out", str(tmp_path / "out"))
    line = one_line(res, 2)
    assert line.startswith("cptbt batch: error: ") and expected in line, line
    assert not (tmp_path / "out").exists()


def test_an_output_that_is_the_mission_file_is_refused(tmp_path: Path) -> None:
    """A review: ``cptbt tree m.yaml --dot m.yaml`` and ``cptbt run m.yaml --log m.yaml``
    replaced the mission with their output and exited 0."""
    mission = tmp_path / "m.yaml"
    text = (ROOT / "missions/tro2006_msn007.yaml").read_text(encoding="utf-8")
    mission.write_text(text, encoding="utf-8")
    (tmp_path / "sub").mkdir()
    for args in (["tree", str(mission), "--dot", str(mission)],
                 ["phases", str(mission), "--dot", str(tmp_path / "sub" / ".." / "m.yaml")],
                 ["run", str(mission), "--log", str(mission), "--out", str(tmp_path / "r")]):
        line = one_line(cptbt(*args), 2)
        assert "is the mission file this command reads" in line, line
        assert mission.read_text(encoding="utf-8") == text


def test_more_workers_than_cpus_can_use_are_capped_and_said(tmp_path: Path) -> None:
    """A review's --workers 100000 forked 500 processes and the out-of-memory killer fired."""
    res = cptbt("batch", "missions/ab2001_strategy1.yaml", "--grid", "2x1", "--time-limit", "5",
                "--workers", "100000", "--no-plots", "--quiet", "--out", str(tmp_path / "o"))
    assert res.returncode == 0, res.stderr
    cap = 4 * (os.cpu_count() or 1)
    assert f"--workers 100000 is more than 4 per CPU ({os.cpu_count()} here): {cap} workers" \
        in res.stderr, res.stderr


def test_bad_arguments_of_other_commands_are_one_usage_line() -> None:
    assert "argument --seed" in one_line(cptbt("run", MISSION, "--seed", "x"), 2)
    assert "required: COMMAND" in one_line(cptbt(), 2)
    assert "invalid choice: 'nope'" in one_line(cptbt("nope"), 2)
    assert "required: --out" in one_line(cptbt("batch", MISSION), 2)
    # an unknown option is the sub-command's, pointed at its --help (a review: cptbt --help)
    assert one_line(cptbt("run", MISSION, "--bogus"), 2) == (
        "cptbt run: error: unrecognized arguments: --bogus (see cptbt run --help)")
    assert "-q is cptbt's own option, given before the command (cptbt -q validate ...)" in \
        one_line(cptbt("validate", MISSION, "-q"), 2)
    assert "-vv is cptbt's own option" in one_line(cptbt("validate", MISSION, "-vv"), 2)
    # before the command it is cptbt's; a nested command's is its own (a diff review)
    assert one_line(cptbt("--bogus", "validate", MISSION), 2) == (
        "cptbt: error: unrecognized arguments: --bogus (see cptbt --help)")
    assert one_line(cptbt("log", "summary", "x.mcap", "--bogus"), 2) == (
        "cptbt log summary: error: unrecognized arguments: --bogus (see cptbt log summary "
        "--help)")
    # the same word before and after the command is the stray one after it (a second review)
    assert "-v is cptbt's own option" in one_line(cptbt("-v", "validate", MISSION, "-v"), 2)
    assert one_line(cptbt("run", MISSION, "run"), 2).startswith("cptbt run: error: ")


def test_a_sweep_path_that_names_nothing_is_a_usage_error(tmp_path: Path) -> None:
    res = cptbt("batch", MISSION, "--amp-only", "--sweep", "nope=1,2", "--out", str(tmp_path))
    line = one_line(res, 2)
    # found after parsing, worded as argparse's own usage errors (PROG: error: MESSAGE)
    assert line.startswith("cptbt batch: error: sweep path 'nope': no such mission field"), line


def test_usage_errors_found_after_parsing_read_as_argparse_ones(tmp_path: Path) -> None:
    res = cptbt("batch", MISSION, "--out", str(tmp_path / "o"))
    line = one_line(res, 2)
    assert line.startswith(f"cptbt batch: error: {MISSION} has a mission_a section"), line
    res = cptbt("run", "missions/small_oparea.yaml", "--log", str(tmp_path / "x.mcap"),
                "--out", str(tmp_path / "r"), "--quiet")  # (its source near a wall is warned of)
    assert one_line(res, 2).startswith("cptbt run: error: --log records the AMP session")


def test_version_is_the_installed_distribution() -> None:
    res = cptbt("--version")
    assert res.returncode == 0, res.stderr
    assert res.stdout == f"cptbt {importlib.metadata.version('cptbt')}\n"


def _without_root_powers() -> None:  # pragma: no cover - runs in the child
    """Drop the capabilities that let root write into any folder (for the child we exec)."""
    libc = ctypes.CDLL(None, use_errno=True)
    for cap in (1, 2, 3):  # CAP_DAC_OVERRIDE, CAP_DAC_READ_SEARCH, CAP_FOWNER
        if libc.prctl(24, cap, 0, 0, 0) != 0:  # PR_CAPBSET_DROP
            raise OSError(ctypes.get_errno(), "prctl(PR_CAPBSET_DROP)")


def test_read_only_out_is_one_line_exit_1(tmp_path: Path) -> None:
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    root = hasattr(os, "geteuid") and os.geteuid() == 0
    if root and not sys.platform.startswith("linux"):
        pytest.skip("root writes into read-only folders; dropping that power needs Linux")
    try:
        res = cptbt("batch", MISSION, "--amp-only", "--out", str(ro), "--no-plots",
                    preexec_fn=_without_root_powers if root else None)
    finally:
        ro.chmod(0o755)
    assert one_line(res, 1) == f"cptbt: {ro / 'parts'}: Permission denied"


@pytest.mark.parametrize(("out", "expected"), [
    ("/proc/cptbt-test/out", "/proc/cptbt-test: No such file or directory"),
    ("FILE", "FILE exists and is not a folder"),
    ("FILE/below", "FILE/below/parts: Not a directory"),
    # an attacker's parts/ that was a file: "File exists" had said nothing
    ("DIR", "DIR/parts exists and is not a folder (a study keeps its runs there): move it aside"),
])
def test_unusable_out_is_one_line_exit_1(tmp_path: Path, out: str, expected: str) -> None:
    regular = tmp_path / "a-file"
    regular.write_text("not a folder")
    folder = tmp_path / "a-folder"
    folder.mkdir()
    (folder / "parts").write_text("not a folder")
    res = cptbt("batch", MISSION, "--amp-only", "--out",
                out.replace("FILE", str(regular)).replace("DIR", str(folder)), "--no-plots")
    assert one_line(res, 1) == "cptbt: " + expected.replace("FILE", str(regular)).replace(
        "DIR", str(folder))
    assert regular.read_text() == "not a folder"


def test_dot_into_a_missing_folder_is_one_line_exit_1(tmp_path: Path) -> None:
    dot = tmp_path / "missing" / "tree.dot"
    for cmd in ("tree", "phases"):
        line = one_line(cptbt(cmd, MISSION, "--dot", str(dot)), 1)
        assert line == f"cptbt: {dot}: No such file or directory"


@pytest.mark.parametrize("content", [b"", b"garbage\x00\xff" * 50, b"PAR1" + b"\0" * 64])
def test_plot_of_garbage_parquet_is_one_line_exit_1(tmp_path: Path, content: bytes) -> None:
    table = tmp_path / "results.parquet"
    table.write_bytes(content)
    line = one_line(cptbt("plot", str(table)), 1)
    assert line.startswith(f"cptbt: {table}: ") and ("unreadable" in line or "empty" in line)
    line = one_line(cptbt("plot", str(tmp_path)), 1)  # the folder holding it
    assert line.startswith(f"cptbt: {table}: ")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["results.parquet"]


@pytest.mark.parametrize(("content", "expected"), [
    ("", "empty file"),
    ("config,replicate\n", "no results in it"),
    ("config,replicate\n0,0\n",
     "not a cptbt results table (no column start, start_x, start_y, success)"),
    ("a,b\n1,2,3\n", "unreadable (a row has more fields than the header)"),
])
def test_plot_of_garbage_csv_is_one_line_exit_1(
    tmp_path: Path, content: str, expected: str
) -> None:
    table = tmp_path / "results.csv"
    table.write_text(content)
    assert one_line(cptbt("plot", str(table)), 1) == f"cptbt: {table}: {expected}"


def test_plot_of_a_mission_file_says_it_is_no_results_table() -> None:
    """A review: ``cptbt plot MISSION.yaml`` read the mission as CSV ("a row has more fields
    than the header")."""
    mission = ROOT / "missions" / "omae2003.yaml"
    assert one_line(cptbt("plot", str(mission)), 1) == (
        f"cptbt: {mission} is not a results table (results.parquet or results.csv) or a "
        "study's folder")


def test_plot_of_a_folder_of_garbage_parts_is_one_line_exit_1(tmp_path: Path) -> None:
    part = tmp_path / "parts" / "c000-r00000.parquet"
    part.parent.mkdir()
    part.write_bytes(b"\x00garbage" * 100)
    line = one_line(cptbt("plot", str(tmp_path)), 1)
    assert line.startswith(f"cptbt: {tmp_path}: no part could be read: {part.name} "
                           "(unreadable ("), line


def test_plot_of_a_folder_without_results_is_one_line_exit_1(tmp_path: Path) -> None:
    line = one_line(cptbt("plot", str(tmp_path)), 1)
    assert line == f"cptbt: {tmp_path} holds no results table (results.parquet or " \
                   "results.csv) and no parts/"
    # worded as every other missing file ("cptbt: PATH: No such file or directory")
    nope = tmp_path / "nope"
    assert one_line(cptbt("plot", str(nope)), 1) == f"cptbt: {nope}: No such file or directory"
    assert list(tmp_path.iterdir()) == []


def test_unreachable_scheduler_fails_fast_with_one_line(tmp_path: Path) -> None:
    pytest.importorskip("distributed")
    t0 = time.monotonic()
    res = cptbt("batch", MISSION, "--amp-only",
                "--scheduler", "tcp://127.0.0.1:1", "--scheduler-timeout",
                "1", "--out", str(tmp_path), "--no-plots")
    line = one_line(res, 1)
    assert line.startswith("cptbt: cannot reach the Dask scheduler at tcp://127.0.0.1:1: ")
    assert time.monotonic() - t0 < 60


def test_unexpected_error_is_one_line_unless_debugging(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    def broken(args: object) -> int:
        raise ZeroDivisionError("division by zero\nsecond line")

    monkeypatch.setattr(inspect_cmds, "cmd_behaviours", broken)
    monkeypatch.delenv(cli.DEBUG_ENV, raising=False)
    assert cli.main(["behaviours"]) == 1
    err = capsys.readouterr().err
    assert err == ("cptbt: internal error: ZeroDivisionError: division by zero second line "
                   "(run with CPTBT_DEBUG=1 for the traceback)\n")
    monkeypatch.setenv(cli.DEBUG_ENV, "1")
    with pytest.raises(ZeroDivisionError):
        cli.main(["behaviours"])


def test_os_error_is_file_and_reason(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    def full(args: object) -> int:
        raise OSError(28, "No space left on device", "/data/out.parquet")

    monkeypatch.setattr(inspect_cmds, "cmd_schema", full)
    monkeypatch.delenv(cli.DEBUG_ENV, raising=False)
    assert cli.main(["schema"]) == 1
    assert capsys.readouterr().err == "cptbt: /data/out.parquet: No space left on device\n"


@pytest.mark.parametrize(("value", "fragment"), [
    ("bogus", "use auto, fleet or tree"),
    ("fleet", "watch every cycle"),  # TRO's declaration watches: no array form
])
def test_a_planner_choice_it_cannot_honour_is_a_usage_error(tmp_path: Path, value: str,
                                                             fragment: str) -> None:
    out = tmp_path / "o"
    res = cptbt("batch", MISSION, "--amp-only", "--grid", "2x1", "--out", str(out),
                env={**os.environ, "CPTBT_PLANNER": value})
    assert fragment in one_line(res, 2)
    assert not out.exists()  # refused before any folder is made


def test_a_launch_beyond_the_give_back_distance_is_refused(tmp_path: Path,
                                                          capsys: pytest.CaptureFixture[str]
                                                          ) -> None:
    """Without a mission_a the AMP drives from the launch; 7 km out it gave control back at
    t = 0.1 s ("relinquished", 0x real time). Now a validation line at environment.launch."""
    base = (ROOT / "missions/oblique_flow.yaml").read_text(encoding="utf-8")
    assert "mission_a" not in base and base.rstrip().endswith("seed: 7")
    bad = tmp_path / "far.yaml"
    bad.write_text(base.rstrip() + "\n  launch: [7000, 0]\n", encoding="utf-8")
    assert cli.main(["run", str(bad), "--no-figure"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    lines = len(base.rstrip().splitlines()) + 1
    assert len(err) == 1 and f":{lines}: environment.launch: " in err[0], err
    assert "gives control back 30 m outside" in err[0]


def test_a_simulator_command_that_cannot_import_says_why(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """A review's mixed install (an old copy's leftovers hiding the editable one) made
    `cptbt batch` read "invalid choice: 'batch'": the import error was swallowed."""
    real = importlib.import_module

    def broken(name: str, *args: object) -> object:
        if name == "cptbt.cli.batch_cmd":
            raise ImportError("cannot import name '__version__' from 'cptbt'")
        return real(name, *args)  # type: ignore[arg-type]

    monkeypatch.setattr(importlib, "import_module", broken)
    assert cli.main(["batch", MISSION, "--out", "x"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("cptbt batch: error: needs the simulator, which did not import "
                          "(ImportError: cannot import name '__version__' from 'cptbt')")
    assert "invalid choice" not in err and len(err.strip().splitlines()) == 1
    assert cli.main(["validate", MISSION]) == 0  # the planner's commands still work


def test_behaviours_tells_a_plug_in_family_one_slip_from_a_slot(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """A review's plug-in family "find_plum" was listed as a family of its own, silently."""
    from typing import ClassVar

    from cptbt.node import PlanBehaviour
    from cptbt.registry import load_entry_points

    class Mower(PlanBehaviour):
        family: ClassVar[str] = "find_plum"
        variant: ClassVar[str] = "lawnmower"

    registry = load_entry_points()
    registry.register(Mower)
    monkeypatch.setattr(inspect_cmds, "default_registry", lambda: registry)
    assert cli.main(["behaviours"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert "find_plum  (not a TRO slot: one slip from find_plume; misspelt?)" in lines
    assert "find_plume" in lines  # the slot itself, unmarked


def test_a_study_is_not_told_its_mission_has_no_start(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The no-start warning is for cptbt run; a study's runs each have a start (a review saw
    it under --grid 1x1)."""
    root = Path(__file__).resolve().parents[2]
    text = (root / "missions" / "tro2006_msn007.yaml").read_text(encoding="utf-8")
    path = tmp_path / "nostart.yaml"
    path.write_text("\n".join(line for line in text.splitlines()
                              if not line.startswith("start:")) + "\n", encoding="utf-8")
    mission = inspect_cmds.load(str(path), warn=False)
    assert any("no start" in msg for _, msg in mission.advisories())
    inspect_cmds.warn_swept(mission, [], str(path))
    assert "no start" not in capsys.readouterr().err

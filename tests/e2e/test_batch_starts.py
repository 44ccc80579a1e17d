"""Starts given on the command line: negative coordinates parse, and a start outside the
OpArea (e.g. typed in the wrong frame) is refused before anything runs."""

from __future__ import annotations

from pathlib import Path

import pytest

from cptbt.cli import main

ROOT = Path(__file__).resolve().parents[2]
AB2 = str(ROOT / "missions/ab2001_strategy2.yaml")
MSN010 = str(ROOT / "missions/tro2006_msn010.yaml")  # frame: geodetic


@pytest.mark.parametrize("args", [
    [MSN010, "--amp-only", "--starts", "-60,71"],      # N-E metres where lat, lon are expected
    [AB2, "--starts", "500,500"],
    [AB2, "--starts", "50,0;-5,0"],
    [AB2, "--starts-x", "-10:100:10"],
    [AB2, "--starts-x", "0:100:50", "--y", "-60"],
])
def test_a_start_outside_the_oparea_is_one_usage_error(
    args: list[str], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "study"
    assert main(["batch", *args, "--runs-per-start", "1", "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "outside the OpArea" in err, err
    assert not out.exists()  # refused before any folder is made


def test_negative_starts_parse_and_fly(tmp_path: Path) -> None:
    out = tmp_path / "study"
    assert main(["batch", AB2, "--starts", "50,-5;60,-10", "--runs-per-start", "1",
                 "--time-limit", "5", "--workers", "1", "--no-plots", "--quiet",
                 "--out", str(out)]) == 0
    assert (out / "results.parquet").exists()


def test_a_leading_minus_with_an_exponent_parses_and_grouped_digits_are_refused(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A review: --starts "-40,1e1" was taken for an option, and "1_0" read as 10 (Python's
    float takes it; a mission file refuses it)."""
    out = tmp_path / "study"
    assert main(["batch", AB2, "--starts", "-1e1,5e0", "--runs-per-start", "1",
                 "--time-limit", "5", "--workers", "1", "--no-plots", "--quiet",
                 "--out", str(out)]) == 2  # parsed: refused as outside the OpArea, not as usage
    assert "outside the OpArea" in capsys.readouterr().err
    with pytest.raises(SystemExit) as stop:  # a usage error, as argparse reports one
        main(["batch", AB2, "--starts=50,1_0", "--runs-per-start", "1", "--quiet",
              "--out", str(tmp_path / "s2")])
    assert stop.value.code == 2
    assert "'1_0' is not a number" in capsys.readouterr().err

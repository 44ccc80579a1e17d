"""cptbt serve with no vehicle on the link: one line, exit 1, and no folder of nothing."""

from __future__ import annotations

from pathlib import Path

import pytest

from cptbt.cli import main

MSN007 = str(Path(__file__).resolve().parents[2] / "missions/tro2006_msn007.yaml")


def test_no_vehicle_writes_nothing(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                   capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.chdir(tmp_path)
    code = main(["serve", MSN007, "--link", "backseat:udp:127.0.0.1:47991", "--connect-timeout",
                 "0.3", "--quiet"])
    assert code == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no vehicle" in err[0]
    assert not (tmp_path / "runs").exists()

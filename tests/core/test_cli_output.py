"""The output helpers cptbt run and cptbt serve share."""

from __future__ import annotations

import math
from pathlib import Path

from cptbt.cli.output import fmt, fresh_folder, time_share


def test_fresh_folder_never_reuses_one(tmp_path: Path) -> None:
    base = tmp_path / "m-served"
    assert fresh_folder(base) == base
    base.mkdir()
    assert fresh_folder(base) == tmp_path / "m-served-2"
    (tmp_path / "m-served-2").mkdir()
    assert fresh_folder(base) == tmp_path / "m-served-3"


def test_time_share_leaves_out_only_an_empty_none() -> None:
    assert time_share({"a.b": 0.5, "none": 0.001}) == "a.b 50%"
    assert time_share({"a.b": 0.9, "none": 0.1}) == "a.b 90%, none 10%"
    assert fmt(None) == fmt(math.nan) == "—" and fmt(3.14159, " m") == "3.1 m"

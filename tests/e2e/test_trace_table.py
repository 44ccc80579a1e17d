"""The trace table is written from column buffers: the same table pyarrow builds, no pandas."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

pa = pytest.importorskip("pyarrow")

from cptbt.cli.run_cmd import arrow_table  # noqa: E402


def test_arrow_table_equals_pyarrow_own_conversion() -> None:
    cols = {
        "t": np.array([0.0, 1.0, 2.0, 3.0]),
        "concentration": np.array([0.5, np.nan, -0.0, 1e300]),
        "detected": np.array([True, False, True, True]),
        "active": ["find_plume.billiard", "", "déclaré", "x" * 300],
    }
    ours, theirs = arrow_table(cols), pa.table(cols)
    assert ours.schema == theirs.schema
    for name in cols:
        a, b = ours.column(name).to_pylist(), theirs.column(name).to_pylist()
        if name == "concentration":
            np.testing.assert_array_equal(np.array(a), np.array(b))  # NaN == NaN here
        else:
            assert a == b


def test_arrow_table_of_no_rows() -> None:
    table = arrow_table({"t": np.zeros(0), "detected": np.zeros(0, bool), "active": []})
    assert table.num_rows == 0
    assert table.schema == pa.table({"t": np.zeros(0), "detected": np.zeros(0, bool),
                                     "active": pa.array([], pa.string())}).schema


def test_writing_a_trace_does_not_import_pandas(tmp_path) -> None:
    code = (
        "import sys, numpy as np, pyarrow.parquet as pq\n"
        "from cptbt.cli.run_cmd import arrow_table\n"
        f"pq.write_table(arrow_table({{'t': np.arange(3.0), 'a': ['x', 'y', 'z']}}), "
        f"{str(tmp_path / 't.parquet')!r})\n"
        "assert 'pandas' not in sys.modules, 'pandas imported'\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True)

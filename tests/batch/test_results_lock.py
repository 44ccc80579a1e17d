"""One study writes a results folder at a time; the lock dies with its holder."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from cptbt.batch.errors import BatchError
from cptbt.batch.store import LOCK_NAME, ResultStore

pytest.importorskip("fcntl")

META = {"mission": "m"}
HOLDER = """
import sys
from pathlib import Path
from cptbt.batch.store import ResultStore
ResultStore(Path(sys.argv[1])).open({"mission": "m"}, study="s", code="c")
print("holding", flush=True)
sys.stdin.read()  # until the parent closes our stdin
"""


def test_a_second_writer_is_refused_in_one_line_and_admitted_once_the_first_ends(
    tmp_path: Path,
) -> None:
    out = tmp_path / "study"
    holder = subprocess.Popen([sys.executable, "-c", HOLDER, str(out)], stdin=subprocess.PIPE,
                              stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout is not None and holder.stdout.readline().strip() == "holding"
        with pytest.raises(BatchError) as err:
            ResultStore(out).open(META, study="s", code="c")
        message = str(err.value)
        assert "\n" not in message
        assert f"pid {holder.pid}" in message and "another cptbt batch" in message
    finally:
        assert holder.stdin is not None
        holder.stdin.close()
        holder.wait(timeout=30)
    # The holder is gone (it did not unlock: the kernel did): the folder is free again.
    ResultStore(out).open(META, study="s", code="c")
    assert (out / LOCK_NAME).exists()


def test_one_store_may_open_its_folder_again(tmp_path: Path) -> None:
    store = ResultStore(tmp_path / "study")
    store.open(META, study="s", code="c")
    store.open({**META, "runs_per_start": 4}, study="s", code="c")  # --until-sem does this


def test_a_batch_that_ended_leaves_no_pid_in_the_lock(tmp_path: Path) -> None:
    """A finished folder's .lock named the pid of a process long gone (a review)."""
    out = tmp_path / "study"
    code = "import sys\nfrom pathlib import Path\nfrom cptbt.batch.store import ResultStore\n" \
           "ResultStore(Path(sys.argv[1])).open({'mission': 'm'}, study='s', code='c')\n"
    subprocess.run([sys.executable, "-c", code, str(out)], check=True, timeout=60)
    assert (out / LOCK_NAME).read_text() == ""
    ResultStore(out).open(META, study="s", code="c")  # and the folder is free

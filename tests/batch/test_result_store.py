"""The results folder on its own (Parquet and CSV): parts carry their group, study and checksum,
and every way a part can go wrong is caught, with its reason; no simulation is flown here."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import pytest

from cptbt.batch.errors import BatchError, CodeChanged
from cptbt.batch.integrity import code_identity, rows_checksum, source_hash
from cptbt.batch.starts import line_xs
from cptbt.batch.store import ResultStore, StudyMismatch, load_results
from cptbt.batch.study import GroupTask
from cptbt.batch.worker import run_group

FORMATS = ["parquet", "csv"]


def tasks(replicates: int = 2, starts: int = 3) -> list[GroupTask]:
    return [GroupTask(0, r, "name: m", tuple((float(i), 0.0) for i in range(starts)), 1, 0.0)
            for r in range(replicates)]


def rows_of(task: GroupTask) -> list[dict[str, Any]]:
    return [{"config": task.config, "replicate": task.replicate, "start": i, "start_x": x,
             "start_y": y, "success": i % 2 == 0, "t3": None if i else 12.5, "error_m": math.nan,
             "outcome": "declared" if i % 2 == 0 else "timeout"}
            for i, (x, y) in enumerate(task.starts)]


def opened(folder: Path, fmt: str, study: str = "s1", code: str = "c1",
           restart: bool = False) -> ResultStore:
    store = ResultStore(folder, fmt)
    store.open({"note": "test"}, study=study, code=code, restart=restart)
    return store


@pytest.fixture(params=FORMATS)
def fmt(request: pytest.FixtureRequest) -> str:
    return str(request.param)


def test_written_groups_read_back_and_consolidate(tmp_path: Path, fmt: str) -> None:
    store = opened(tmp_path, fmt)
    ts = tasks()
    for t in ts:
        store.write_group(t, rows_of(t))
    resume = store.check(ts)
    assert resume.done == {"c000-r00000", "c000-r00001"} and resume.rerun == {}
    assert (resume.runs, resume.successes) == (6, 4)
    table = store.consolidate(ts)
    rows = load_results(table)
    assert len(rows) == 6 and rows[0]["t3"] == 12.5 and rows[1]["t3"] is None
    assert rows_checksum(load_results(tmp_path)) == rows_checksum(rows)  # NaN != NaN
    assert not list(tmp_path.rglob(".*.tmp"))


def test_parts_of_an_unfinished_study_load_without_a_table(tmp_path: Path, fmt: str) -> None:
    store = opened(tmp_path, fmt)
    first, second = tasks()
    store.write_group(second, rows_of(second))
    store.write_group(first, rows_of(first))
    rows = load_results(tmp_path)
    assert [(r["replicate"], r["start"]) for r in rows] == [(0, 0), (0, 1), (0, 2),
                                                            (1, 0), (1, 1), (1, 2)]


def test_a_folder_read_from_its_parts_leaves_out_another_studys(tmp_path: Path,
                                                                 fmt: str) -> None:
    """A review: ``cptbt plot`` of a folder without its table (a stopped study) tabled a part
    copied in from another study (52 runs under a header of 48; a part in place of one of its
    own gave its runs twice), where ``cptbt batch`` refused it; a damaged part stopped the
    plot. Each is left out of the rows, and said."""
    store = opened(tmp_path / "mine", fmt)
    other = opened(tmp_path / "other", fmt, study="s2")
    ts = tasks(replicates=3)
    for t in ts[:2]:
        store.write_group(t, rows_of(t))
    other.write_group(ts[0], rows_of(ts[0]))

    def copy(src: Path, dst: Path) -> None:
        dst.write_bytes(src.read_bytes())
        if fmt == "csv":
            dst.with_name(dst.name + ".json").write_bytes(
                src.with_name(src.name + ".json").read_bytes())

    copy(other.path(ts[0].key), store.path(ts[2].key))  # another study's, under a free name
    notes: list[str] = []
    rows = load_results(tmp_path / "mine", notes)
    assert [(r["replicate"], r["start"]) for r in rows] == [(r, i) for r in (0, 1)
                                                            for i in range(3)]
    assert len(notes) == 1 and notes[0].startswith("1 part left out of the tables: ")
    assert f"{ts[2].key}{store.format.suffix} (from another study" in notes[0]
    # one of its own parts copied under another's name: its runs are not tabled twice
    copy(store.path(ts[0].key), store.path(ts[2].key))
    notes = []
    assert len(load_results(tmp_path / "mine", notes)) == 6
    assert f"(holds group {ts[0].key})" in notes[0]
    # a damaged part: the others are tabled
    store.path(ts[2].key).write_bytes(b"\xff\xfe garbage \x00" * 40)
    notes = []
    assert len(load_results(tmp_path / "mine", notes)) == 6 and "left out" in notes[0]
    # a replicate beyond the study's count (a larger flight's, kept on disk): left out
    record = tmp_path / "mine" / "study.json"
    meta = json.loads(record.read_text(encoding="utf-8"))
    record.write_text(json.dumps({**meta, "runs_per_start": 1}), encoding="utf-8")
    notes = []
    assert [r["replicate"] for r in load_results(tmp_path / "mine", notes)] == [0, 0, 0]
    assert "beyond the study's 1 runs per start" in notes[0]
    record.write_text(json.dumps({**meta, "runs_per_start": 1, "until_sem": 0.1}),
                      encoding="utf-8")  # adaptive: its count is the last round's
    assert len(load_results(tmp_path / "mine", [])) == 6
    # no study.json: tabled, and said that nothing vouches for the parts
    store.path(ts[2].key).unlink()
    (tmp_path / "mine" / "study.json").unlink()
    notes = []
    assert len(load_results(tmp_path / "mine", notes)) == 6
    assert notes and "cannot be checked to be one study's" in notes[-1]


def _damage_data(path: Path, fmt: str) -> None:
    """Change one value of a part, keeping its metadata (so its recorded checksum)."""
    if fmt == "csv":
        path.write_text(path.read_text().replace("12.5", "12.0"))
        return
    import pyarrow.parquet as pq

    t = pq.read_table(path)
    i = t.column_names.index("start_x")
    pq.write_table(t.set_column(i, "start_x", [[9.0, 1.0, 2.0]]), path)


@pytest.mark.parametrize(("damage", "reason"), [
    ("missing", None),
    ("empty", "empty file"),
    ("truncated", "unreadable ("),
    ("garbage", "unreadable ("),
    ("altered", "checksum mismatch (changed since it was written)"),
    ("foreign", "from another study or code version (its fingerprint differs)"),
    ("swapped", "holds group c000-r00000, not c000-r00001"),
    ("wrong rows", "its rows are not the 3 runs of group c000-r00001"),
])
def test_each_damaged_part_is_named_with_its_reason(
    tmp_path: Path, fmt: str, damage: str, reason: str | None
) -> None:
    store = opened(tmp_path / "study", fmt)
    first, second = tasks()
    store.write_group(first, rows_of(first))
    path = store.path(second.key)
    if damage == "foreign":  # the same group of a study with another seed
        other = opened(tmp_path / "other", fmt, study="s2")
        other.write_group(second, rows_of(second))
        path.write_bytes(other.path(second.key).read_bytes())
        if fmt == "csv":
            path.with_name(path.name + ".json").write_bytes(
                other.path(second.key).with_name(path.name + ".json").read_bytes())
    elif damage == "swapped":
        path.write_bytes(store.path(first.key).read_bytes())
        if fmt == "csv":
            path.with_name(path.name + ".json").write_bytes(
                store.path(first.key).with_name(f"{first.key}.csv.json").read_bytes())
    elif damage == "wrong rows":
        store.write_group(second, rows_of(second)[:2])
    elif damage != "missing":
        store.write_group(second, rows_of(second))
        data = path.read_bytes()
        if damage == "empty":
            path.write_bytes(b"")
        elif damage == "truncated":
            path.write_bytes(data[: len(data) // 2])
        elif damage == "garbage":
            path.write_bytes(b"\xff\xfe garbage \x00" * 40)
        elif damage == "altered":
            _damage_data(path, fmt)
    if damage == "truncated" and fmt == "csv":  # fewer rows still parse: the checksum tells
        reason = "checksum mismatch"
    resume = store.check([first, second])
    assert resume.done == {first.key}
    if reason is None:
        assert resume.rerun == {}
    else:
        assert resume.rerun[second.key].startswith(reason), resume.rerun
        with pytest.raises(BatchError, match=f"{second.key}"):
            store.rows([first, second])


def test_csv_part_without_its_checksum_file_is_rerun(tmp_path: Path) -> None:
    store = opened(tmp_path, "csv")
    (task,) = tasks(1)
    store.write_group(task, rows_of(task))
    store.path(task.key).with_name(f"{task.key}.csv.json").unlink()
    assert store.check([task]).rerun == {
        task.key: "no checksum (written by an older cptbt, or not by cptbt)"}


def test_altered_results_table_is_refused_by_plot(tmp_path: Path, fmt: str) -> None:
    store = opened(tmp_path, fmt)
    ts = tasks(1)
    store.write_group(ts[0], rows_of(ts[0]))
    table = store.consolidate(ts)
    _damage_data(table, fmt)
    with pytest.raises(BatchError, match="checksum mismatch"):
        load_results(tmp_path)
    # ... saying the way out (a review): the parts are read without it
    with pytest.raises(BatchError, match="the study's parts/ are read without it: delete it"):
        load_results(table)
    table.unlink()
    assert len(load_results(tmp_path)) == 3


def test_results_table_made_elsewhere_loads_without_a_checksum(tmp_path: Path) -> None:
    table = tmp_path / "mine.csv"
    table.write_text("config,replicate,start,start_x,start_y,success\n0,0,0,1.5,0,True\n")
    assert load_results(table) == [{"config": 0, "replicate": 0, "start": 0, "start_x": 1.5,
                                    "start_y": 0, "success": True}]


def test_a_folder_with_a_table_but_no_study_is_not_written_over(tmp_path: Path) -> None:
    """A review: ``--out`` into a folder of the user's own replaced its results.parquet."""
    (tmp_path / "results.parquet").write_bytes(b"mine")
    with pytest.raises(StudyMismatch, match=r"holds a results table but no study\.json"):
        ResultStore(tmp_path).open({}, study="s1", code="c1")
    assert (tmp_path / "results.parquet").read_bytes() == b"mine"
    assert not (tmp_path / "parts").exists()


def test_a_different_study_is_told_by_what_differs(tmp_path: Path) -> None:
    meta = {"mission": "m.yaml", "runs_per_start": 10, "root_seed": 1, "time_limit_s": 600.0,
            "starts": [[0, 0]], "sweeps": {}, "config_missions": ["a"]}
    ResultStore(tmp_path).open(meta, study="s1", code="c1")
    other = {**meta, "runs_per_start": 20, "root_seed": 2, "time_limit_s": 900.0,
             "starts": [[0, 0], [1, 1]], "config_missions": ["b"]}
    with pytest.raises(StudyMismatch) as caught:
        ResultStore(tmp_path).open(other, study="s2", code="c1")
    assert str(caught.value) == (f"{tmp_path} holds a different study (root seed 1 there, 2 "
                                 "here; time limit (s) 600.0 there, 900.0 here; starts differ; "
                                 "and 1 more)")  # runs per start: not a different study
    # a sweep: each swept path that differs, its values whole (a review: the two JSON texts,
    # cut at 40 characters, hid the value that differed)
    swept = {"maintain_plume.variant+reacquire_plume.variant": ["strategy_1", "strategy_3"]}
    ResultStore(tmp_path / "sw").open({**meta, "sweeps": swept}, study="s5", code="c1")
    with pytest.raises(StudyMismatch) as caught:
        ResultStore(tmp_path / "sw").open(
            {**meta, "sweeps": {k: ["strategy_1", "strategy_2"] for k in swept}},
            study="s6", code="c1")
    assert ('sweep maintain_plume.variant+reacquire_plume.variant strategy_3 there only; '
            'strategy_2 here only') in str(caught.value)
    # a whole behaviour's mappings: the one that differs, not all of them cut short
    whole = [{"variant": "likelihood_map", "radius_m": r, "upflow_check_m": 10} for r in (8, 12)]
    ResultStore(tmp_path / "wh").open({**meta, "sweeps": {"declare_source": whole}},
                                      study="s7", code="c1")
    with pytest.raises(StudyMismatch) as caught:
        ResultStore(tmp_path / "wh").open(
            {**meta, "sweeps": {"declare_source": [whole[0], {**whole[1], "radius_m": 9}]}},
            study="s8", code="c1")
    assert ("sweep declare_source {variant: likelihood_map, radius_m: 12, upflow_check_m: 10} "
            "there only; {variant: likelihood_map, radius_m: 9, upflow_check_m: 10} here only"
            ) in str(caught.value)
    # the same values in another order: said so, not every configuration's mission diff (a
    # diff review read "... and 57 more")
    ResultStore(tmp_path / "ord").open({**meta, "config_missions": ["a: 1", "a: 2"]},
                                       study="s9", code="c1")
    with pytest.raises(StudyMismatch, match=r"the same configurations in another order"):
        ResultStore(tmp_path / "ord").open({**meta, "config_missions": ["a: 2", "a: 1"]},
                                           study="s10", code="c1")
    with pytest.raises(StudyMismatch, match=r"\(other missions or options\)$"):
        ResultStore(tmp_path).open(meta, study="s3", code="c1")  # nothing recorded differs
    # the mission's path is no difference (a copy elsewhere is the same study); an option
    # not given is the mission's own value, not "null"
    moved = {**meta, "mission": "/tmp/copy.yaml", "time_limit_s": None}
    told = r"\(time limit \(s\) 600.0 there, the mission's here\)$"
    with pytest.raises(StudyMismatch, match=told):
        ResultStore(tmp_path).open(moved, study="s4", code="c1")


def test_a_different_mission_is_told_by_the_settings_that_differ(tmp_path: Path) -> None:
    """A resume refused for "the missions' settings differ" left the user to diff two YAML
    files by hand: the message names the settings, by their dotted keys."""
    there = "speed_mps: 1.5\ndeclare_source:\n  variant: likelihood_map\n  radius_m: 10\n"
    here = "speed_mps: 1.5\ndeclare_source:\n  variant: likelihood_map\n  radius_m: 8\n" \
           "  flyby: true\n"
    meta = {"runs_per_start": 10, "root_seed": 1, "config_missions": [there]}
    ResultStore(tmp_path).open(meta, study="s1", code="c1")
    with pytest.raises(StudyMismatch) as caught:
        ResultStore(tmp_path).open({**meta, "config_missions": [here]}, study="s2", code="c1")
    assert str(caught.value).endswith("(mission declare_source.flyby not set there, true here; "
                                      "mission declare_source.radius_m 10 there, 8 here)")
    # inside the list of behaviours too (a review was told the whole list, cut at 40
    # characters before the change)
    there = ("behaviours:\n- safety: {variant: oparea}\n"
             "- declare_source: {variant: likelihood_map}\n")
    here = there.replace("likelihood_map}", "likelihood_map, radius_m: 8}")
    ResultStore(tmp_path / "b").open({**meta, "config_missions": [there]}, study="b1", code="c1")
    with pytest.raises(StudyMismatch) as caught:
        ResultStore(tmp_path / "b").open({**meta, "config_missions": [here]}, study="b2",
                                         code="c1")
    assert str(caught.value).endswith(
        "(mission behaviours[1].declare_source.radius_m not set there, 8 here)")
    with pytest.raises(StudyMismatch, match=r"\(configurations 1 there, 2 here\)$"):
        ResultStore(tmp_path).open({**meta, "config_missions": [there, here]}, study="s3",
                                   code="c1")


def test_open_refuses_other_code_and_other_studies(tmp_path: Path, fmt: str) -> None:
    store = opened(tmp_path, fmt)
    (task,) = tasks(1)
    store.write_group(task, rows_of(task))
    with pytest.raises(CodeChanged, match=f"{tmp_path} was made by cptbt c1, this is c2"):
        opened(tmp_path, fmt, code="c2")
    with pytest.raises(StudyMismatch, match="holds a different study"):
        opened(tmp_path, fmt, study="s2", restart=True)
    assert store.path(task.key).exists()
    again = opened(tmp_path, fmt)  # same study, same code: resume
    assert again.check([task]).done == {task.key}
    (tmp_path / "parts" / f"my{store.format.suffix}").write_text("mine")  # not a group's
    renewed = opened(tmp_path, fmt, code="c2", restart=True)
    assert not store.path(task.key).exists()
    assert (tmp_path / "parts" / f"my{store.format.suffix}").read_text() == "mine"
    assert json.loads((tmp_path / "study.json").read_text())["code"] == "c2"
    assert renewed.check([task]).done == set()


def test_part_of_the_same_study_by_other_code_is_rerun(tmp_path: Path, fmt: str) -> None:
    (task,) = tasks(1)
    old = opened(tmp_path / "old", fmt, code="c1")
    old.write_group(task, rows_of(task))
    new = opened(tmp_path / "new", fmt, code="c2")
    new.path(task.key).write_bytes(old.path(task.key).read_bytes())
    if fmt == "csv":
        sidecar = f"{task.key}.csv.json"
        (new.parts / sidecar).write_bytes((old.parts / sidecar).read_bytes())
    assert "fingerprint differs" in new.check([task]).rerun[task.key]


def test_checksum_is_of_values_not_column_order() -> None:
    a = [{"x": 1.0, "y": math.nan, "z": None}]
    b = [{"z": None, "y": math.nan, "x": 1.0}]
    assert rows_checksum(a) == rows_checksum(b)
    assert rows_checksum(a) != rows_checksum([{"x": 1.0000000000000002, "y": math.nan, "z": None}])


def test_code_identity_is_the_version_and_a_hash_of_source_plugins_and_libraries() -> None:
    import hashlib

    from cptbt import __version__
    from cptbt.batch.integrity import environment_hash

    both = hashlib.sha256(f"{source_hash()}+{environment_hash()}".encode()).hexdigest()
    assert code_identity() == f"{__version__}+src.{both[:16]}"
    assert len(source_hash()) == 64


def test_a_plugins_source_and_numpys_version_are_part_of_the_code(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import importlib
    import sys

    import cptbt.registry as registry_module
    from cptbt.batch import integrity
    from cptbt.node import BehaviourParams
    from cptbt.registry import BehaviourSpec, Registry

    package = tmp_path / "cptbt_test_plugin_pkg"
    package.mkdir()
    (package / "__init__.py").write_text("from .rules import build\n")
    (package / "rules.py").write_text("def build(params, namespace):\n    return None\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    plugin = importlib.import_module("cptbt_test_plugin_pkg")
    registry = Registry()
    registry.register(BehaviourSpec("find_plume", "test_plugin", BehaviourParams, plugin.build))
    monkeypatch.setattr(registry_module, "_DEFAULT", registry)
    assert sorted(p.name for p in integrity.plugin_sources()) == ["__init__.py", "rules.py"]
    before = integrity.environment_hash.__wrapped__()
    (package / "rules.py").write_text("def build(params, namespace):\n    return 1\n")
    assert integrity.environment_hash.__wrapped__() != before  # the plug-in changed
    (package / "rules.py").write_text("def build(params, namespace):\n    return None\n")
    assert integrity.environment_hash.__wrapped__() == before
    # a study counts only the plug-ins it flies: a review's edit to an unrelated plug-in had
    # stopped every study from resuming
    uses = frozenset({("find_plume", "test_plugin")})
    assert integrity.plugin_packages(uses) == {"cptbt_test_plugin_pkg"}
    assert integrity.plugin_packages({("find_plume", "billiard")}) == frozenset()
    own = integrity.environment_hash.__wrapped__(integrity.plugin_packages(uses))
    other = integrity.environment_hash.__wrapped__(frozenset())
    (package / "rules.py").write_text("def build(params, namespace):\n    return 2\n")
    assert integrity.environment_hash.__wrapped__(integrity.plugin_packages(uses)) != own
    assert integrity.environment_hash.__wrapped__(frozenset()) == other
    (package / "rules.py").write_text("def build(params, namespace):\n    return None\n")
    monkeypatch.setattr(integrity, "RESULT_DEPENDENCIES", ("numpy", "py_trees", "pytest"))
    assert integrity.environment_hash.__wrapped__() != before  # another library's version
    sys.modules.pop("cptbt_test_plugin_pkg", None)
    sys.modules.pop("cptbt_test_plugin_pkg.rules", None)


def test_a_study_without_plug_ins_keeps_the_identity_it_had() -> None:
    """Scoped to the plug-ins a study flies, a study of built-in behaviours has the identity
    the formula before gave without plug-ins (source hash + library versions), whatever
    plug-ins are installed: studies made before still resume."""
    import hashlib
    from importlib.metadata import version

    from cptbt import __version__
    from cptbt.batch import integrity

    libs = hashlib.sha256()
    for name in integrity.RESULT_DEPENDENCIES:
        libs.update(f"{name}=={version(name.replace('_', '-'))}\0".encode())
    both = hashlib.sha256(f"{source_hash()}+{libs.hexdigest()}".encode()).hexdigest()
    flies = (("declare_source", "upflow_cluster"), ("find_plume", "billiard"))
    assert code_identity(flies) == f"{__version__}+src.{both[:16]}"


def test_a_sweep_between_a_plug_in_and_a_built_in_flies_every_group(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A review: the study's identity counted the plug-in of one configuration, each worker
    only its own group's, so every built-in group was refused ("install the same cptbt on
    every worker"). Every task carries the study's behaviours and is checked against them."""
    import importlib
    import sys

    import cptbt.registry as registry_module
    from cptbt.batch.scenario import Environment
    from cptbt.batch.study import Study, configurations
    from cptbt.batch.sweeps import Sweep
    from cptbt.batch.worker import worker_code
    from cptbt.loader import load_mission
    from cptbt.registry import load_entry_points

    package = tmp_path / "cptbt_test_sweep_plugin"
    package.mkdir()
    (package / "__init__.py").write_text(
        "from typing import ClassVar\nfrom cptbt.node import PlanBehaviour\n"
        "class Lawn(PlanBehaviour):\n    family: ClassVar[str] = 'find_plume'\n"
        "    variant: ClassVar[str] = 'test_lawn'\n"
        "    def decide(self, p):\n        return self.command(0.0)\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    plugin = importlib.import_module("cptbt_test_sweep_plugin")
    registry = load_entry_points()
    registry.register(plugin.Lawn)
    monkeypatch.setattr(registry_module, "_DEFAULT", registry)
    mission = load_mission(Path(__file__).resolve().parents[2] / "missions/small_oparea.yaml",
                           registry, Environment)
    configs = configurations(mission, [Sweep.parse("find_plume.variant=billiard,test_lawn")],
                             "m.yaml")
    study = Study(configs, [(0.0, 0.0)], 1, 7, 0.0, 5.0)
    code = code_identity(study.flies())
    assert code != code_identity((("find_plume", "billiard"),))  # the plug-in counts
    for task in study.tasks(code):
        assert worker_code(task) == code, task.coords
    sys.modules.pop("cptbt_test_sweep_plugin", None)


def test_worker_running_other_code_refuses_the_group() -> None:
    task = GroupTask(0, 0, "name: m", ((0.0, 0.0),), 1, 0.0, code="0.0.1+src.other")
    with pytest.raises(BatchError, match="install the same cptbt on every worker"):
        run_group(task)


def test_line_of_starts_includes_its_end() -> None:
    assert line_xs("0:100:5") == [5.0 * i for i in range(21)]
    assert line_xs("0:0.3:0.1") == pytest.approx([0.0, 0.1, 0.2, 0.3])
    assert line_xs("7:7:1") == [7.0]


def test_the_fast_kernel_tier_is_another_code_identity() -> None:
    from cptbt.sim import kernels

    if not kernels.HAVE_NUMBA:
        pytest.skip("needs numba (pip install '.[fast]')")
    before = kernels.tier()
    try:
        kernels.use("exact")
        exact = code_identity()
        kernels.use("fast")
        assert code_identity() == f"{exact}+kernels.fast"
    finally:
        kernels.use(before)


def test_a_journal_keeps_only_sound_lines_of_its_own_group(tmp_path: Path) -> None:
    """The runs an interrupted group finished come back from its journal; a line torn by a
    kill, edited, of another study or group, or a start flown twice, does not."""
    from cptbt.batch.journal import journal_line

    store = opened(tmp_path, "parquet")
    task = tasks(replicates=2, starts=4)[1]
    rows = rows_of(task)
    path = store.journal_path(task.key)
    good = [journal_line(store.fingerprint, task.key, r) for r in rows[:3]]
    edited = json.loads(good[1])
    edited["row"]["success"] = not edited["row"]["success"]  # its checksum no longer holds
    lines = [good[0], json.dumps(edited) + "\n", good[2], good[0],  # start 0 again
             journal_line("another study", task.key, rows[3]),
             journal_line(store.fingerprint, "c000-r00000", rows[3]),
             good[1][: len(good[1]) // 2]]  # torn by a kill mid-write
    path.write_text("".join(lines), encoding="utf-8")
    kept = store.journal_rows(task)
    assert [r["start"] for r in kept] == [0, 2]
    assert kept[0] == json.loads(good[0])["row"]  # the row as written
    resume = store.check(tasks(replicates=2, starts=4))
    assert resume.partial == {task.key: kept} and resume.runs == 2
    store.write_group(task, rows)  # the group's part, written whole, retires its journal
    assert not path.exists()


def test_a_folder_of_parts_reads_the_runs_its_journals_hold(tmp_path: Path, fmt: str) -> None:
    """A review: ``cptbt plot`` on a study stopped part way tabled 48 of the 63 runs the batch
    said were saved (a group under way keeps its runs in its journal). Sound lines of groups
    with no part count; a group's journal left beside its part (killed between the two) does
    not count twice; another study's lines do not count."""
    from cptbt.batch.journal import journal_line

    store = opened(tmp_path, fmt)
    done, under_way, stale = tasks(replicates=3, starts=3)[:3]
    store.write_group(done, rows_of(done))
    rows = rows_of(under_way)
    store.journal_path(under_way.key).write_text(
        journal_line(store.fingerprint, under_way.key, rows[0])
        + journal_line(store.fingerprint, under_way.key, rows[2])
        + journal_line("another study", under_way.key, rows[1]), encoding="utf-8")
    store.write_group(stale, rows_of(stale))
    store.journal_path(stale.key).write_text(  # a leftover journal beside its part
        journal_line(store.fingerprint, stale.key, rows_of(stale)[0]), encoding="utf-8")
    got = load_results(tmp_path)
    assert [(r["replicate"], r["start"]) for r in got] == [
        (done.replicate, 0), (done.replicate, 1), (done.replicate, 2),
        (stale.replicate, 0), (stale.replicate, 1), (stale.replicate, 2),
        (under_way.replicate, 0), (under_way.replicate, 2)]
    for p in store.parts.glob(f"*{'.parquet' if fmt == 'parquet' else '.csv'}"):
        p.unlink()  # a study stopped in its first group: its journal alone
    assert [(r["replicate"], r["start"]) for r in load_results(tmp_path)] == [
        (under_way.replicate, 0), (under_way.replicate, 2), (stale.replicate, 0)]


def test_journal_rows_read_as_the_parts_beside_them_do(tmp_path: Path, fmt: str) -> None:
    """A diff review: beside CSV parts, which give a list-valued setting back as its text, a
    journal's rows kept the list, and a stopped study's configurations were no longer paired
    (their pairing keys differed)."""
    from cptbt.batch.journal import journal_line

    store = opened(tmp_path, fmt)
    done, under_way = tasks(replicates=2, starts=2)
    store.write_group(done, [{**r, "environment.source": [40, 10]} for r in rows_of(done)])
    store.journal_path(under_way.key).write_text("".join(
        journal_line(store.fingerprint, under_way.key, {**r, "environment.source": [40, 10]})
        for r in rows_of(under_way)), encoding="utf-8")
    got = load_results(tmp_path)
    assert len(got) == 4 and len({repr(r["environment.source"]) for r in got}) == 1, got


def test_a_journal_survives_arrays_and_a_torn_line_before_it(tmp_path: Path) -> None:
    """A review: a row holding a numpy array failed the whole group (JSON cannot hold it);
    a line appended after one a kill tore joined it and was lost with it."""
    import numpy as np

    from cptbt.batch.journal import journal_line
    from cptbt.batch.journal import open_journal as _open_journal

    store = opened(tmp_path, "parquet")
    task = tasks(replicates=1, starts=2)[0]
    rows = rows_of(task)
    line = journal_line(store.fingerprint, task.key, {**rows[1], "extra": np.array([1.0, 2.0])})
    assert json.loads(line)["row"]["extra"] == [1.0, 2.0]
    path = store.journal_path(task.key)
    torn = journal_line(store.fingerprint, task.key, rows[0])
    path.write_text(torn[: len(torn) // 2], encoding="utf-8")  # killed mid-line
    with _open_journal(path) as f:
        f.write(line)
    assert [r["start"] for r in store.journal_rows(task)] == [1]
    # one stray byte that is not UTF-8 is one bad line, not a lost journal (a review)
    with path.open("ab") as raw:
        raw.write(b"\xff\xfe\n")
    assert [r["start"] for r in store.journal_rows(task)] == [1]


def test_a_resumed_group_keeps_the_runs_it_had_when_the_rest_meets_an_error(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The rest of an interrupted group met a bug: the runs kept from before stay as they
    were flown, as they do uninterrupted (a run that raises is an error row alone: a review
    saw three runs home by 474 s made error rows by another run's error at 983 s)."""
    from cptbt.batch import runner
    from cptbt.batch.journal import journal_line
    from cptbt.batch.outcome import ERROR_OUTCOME
    from cptbt.batch.worker import error_rows

    store = opened(tmp_path, "parquet")
    task = tasks(replicates=1, starts=4)[0]
    kept = rows_of(task)[:2]
    store.journal_path(task.key).write_text(
        "".join(journal_line(store.fingerprint, task.key, r) for r in kept), encoding="utf-8")
    flown: list[tuple[int, ...]] = []

    def meets_a_bug(t: GroupTask) -> list[dict[str, Any]]:
        flown.append(t.ids)
        return error_rows(t, "ZeroDivisionError: boom (at mine.py:3)")

    monkeypatch.setattr(runner, "run_group", meets_a_bug)
    runner.run_study([task], store, quiet=True)
    assert flown == [(2, 3)]  # the rest alone
    rows = store.rows([task])
    assert [r["start"] for r in rows] == [0, 1, 2, 3]
    assert [r["outcome"] == ERROR_OUTCOME for r in rows] == [False, False, True, True]
    assert [r.get("error") for r in rows[2:]] == ["ZeroDivisionError: boom (at mine.py:3)"] * 2

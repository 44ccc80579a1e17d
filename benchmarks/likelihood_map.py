"""Declaration study (issue 13): the likelihood map against TRO's and OMAE's rules, paired seeds.

(a) TRO MSN007 (``missions/tro2006_msn007.yaml``, the AMP alone, as ``cptbt batch`` flies it:
    ``cptbt.batch.engine.simulate``, no Mission A), ``N`` plume realisations; replicate ``r``
    flies the same plume, vehicle noise and start in every configuration:

    - ``upflow_cluster`` (TRO IV-D, the mission as shipped), ``recent_box`` and
      ``upflow_spread`` (OMAE v1/v2), each with the TRO cloverleaf reacquire;
    - ``likelihood_map`` (cloverleaf reacquire; the map with its meander state and the up-flow
      check, the default), ``likelihood_map+flyby`` and ``likelihood_map+map_guided``
      (map-guided reacquire instead of the cloverleaf);
    - without the up-flow check (``radius_m`` 8, the rule before it): ``likelihood_map (no
      up-flow check)``, the same with ``detection_weight`` 0.7, and the map before the meander
      state (``independent cycles``: ``meander_memory_s`` None, non-detections tempered by 0.3,
      detections by 0.3 or 0.5), for comparison.

    Per configuration: declared %, false declarations (error > 15 m), error median / 95th /
    max, mean T_D share of the mission time to declaration (T_D / T_total, T_total = t3 - t0,
    TRO Table III; t0 is 0 here), mean D3
    (TRO Table IV) and its paired change against ``upflow_cluster``, fly-bys and withdrawals.
(b) ``missions/two_sources.yaml`` (or ``--two-mission``), ``N2`` realisations: both sources
    declared within 15 m, false declarations.
(c) Per-cycle cost of the map (``watch``): TRO MSN007 at 1 Hz (~7 100 cells) and the AB 100 ×
    100 m area at 10 Hz (2 500 cells), mean and 99th percentile.

Usage::

    python benchmarks/likelihood_map.py --runs 40 --two-runs 20        # a few minutes, 2 cores
    python benchmarks/likelihood_map.py --runs 1000 --two-runs 200     # the issue's N
    python benchmarks/likelihood_map.py --runs 40 --two-runs 20 --seed 77 --configs "" \
        --extra "tau 60|declare_source.variant=likelihood_map,declare_source.meander_memory_s=60" \
        --two-set "declare_source.meander_memory_s=60"                 # tuning a setting
    python benchmarks/likelihood_map.py --runs 0 --two-runs 40 --cost-seeds 0 \
        --two-mission missions/two_sources_wide.yaml \
        --out benchmarks/results/likelihood_map_wide.md                 # a wide OpArea

The table is printed and written as Markdown to ``--out`` (default
``runs/likelihood_map/likelihood_map.md``, a scratch folder); per-run rows go next to it as
JSON lines. The committed tables are under ``benchmarks/results/``: ``--out
benchmarks/results/likelihood_map.md`` flies the reported table again and replaces it, and
``--from-rows --out benchmarks/results/likelihood_map.md`` tabulates its committed rows.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shlex
import statistics
import sys
import time
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from cptbt.batch.comparison import td_share
from cptbt.batch.engine import simulate
from cptbt.batch.intervals import wilson
from cptbt.batch.scenario import Environment, launch_pose, to_sim_params
from cptbt.batch.study import group_seeds
from cptbt.batch.summary import summarise
from cptbt.batch.sweeps import apply_setting
from cptbt.loader import load_mission, loads_mission
from cptbt.mission import MissionBase, mission_to_data
from cptbt.registry import default_registry
from cptbt.types import Point

ROOT = Path(__file__).resolve().parents[1]
MSN007 = ROOT / "missions/tro2006_msn007.yaml"
TWO = ROOT / "missions/two_sources.yaml"
FALSE_M = 15.0
SEED = 2024

NO_CHECK: dict[str, Any] = {"declare_source.variant": "likelihood_map",
                            "declare_source.upflow_check_m": None, "declare_source.radius_m": 8.0}
"""The map's rule before the up-flow check (declaring within 8 m of the peak)."""

INDEPENDENT: dict[str, Any] = {**NO_CHECK, "declare_source.meander_memory_s": None,
                               "declare_source.nondetection_weight": 0.3}
"""The map before the meander state: cycles independent given the source, tempered."""

CONFIGS: dict[str, dict[str, Any]] = {
    "upflow_cluster": {},
    "recent_box": {"declare_source.variant": "recent_box"},
    "upflow_spread": {"declare_source.variant": "upflow_spread"},
    "likelihood_map": {"declare_source.variant": "likelihood_map"},
    "likelihood_map+flyby": {"declare_source.variant": "likelihood_map",
                             "declare_source.flyby": True},
    "likelihood_map+map_guided": {"declare_source.variant": "likelihood_map",
                                  "reacquire_plume.variant": "map_guided"},
    "likelihood_map (no up-flow check)": NO_CHECK,
    "likelihood_map (no up-flow check; detection_weight 0.7)": {
        **NO_CHECK, "declare_source.detection_weight": 0.7},
    "likelihood_map (no up-flow check; independent cycles)": {
        **INDEPENDENT, "declare_source.detection_weight": 0.3},
    "likelihood_map (no up-flow check; independent cycles; detection_weight 0.5)": {
        **INDEPENDENT, "declare_source.detection_weight": 0.5},
}


def mission_with(path: Path, settings: dict[str, Any], *, add_map: bool = False) -> MissionBase:
    """A shipped mission with settings applied and Mission A removed (the AMP alone).

    ``add_map`` puts a likelihood-map declaration under safety (for missions without one).
    """
    base = load_mission(path, default_registry(), Environment)
    data = mission_to_data(base)
    data["mission_a"] = None
    if add_map:
        data["behaviours"].insert(1, {"declare_source": {"variant": "likelihood_map"}})
    for key, value in settings.items():
        apply_setting(data, key, value)
    return loads_mission(yaml.safe_dump(data, sort_keys=False), str(path), default_registry(),
                         Environment)


def fly(job: tuple[str, str, dict[str, Any], int, int]) -> dict[str, Any]:
    """One run: (study, mission path, settings, replicate, root seed) → its summary row."""
    study, path, settings, r, seed = job
    mission = mission_with(Path(path), settings)
    params = to_sim_params(mission, seed)
    env_rng, vehicle_rngs = group_seeds(seed, r, 1)
    (run,), _, wall = simulate(mission, params, [launch_pose(mission)], env_rng=env_rng,
                               vehicle_rngs=vehicle_rngs)
    sources = [Point(*params.source_xy_m), *(Point(*xy) for xy in params.extra_sources_xy_m)]
    s = summarise(run, mission, sources[0], seed, wall, sources=sources,
                  success_radius_m=FALSE_M).to_dict()
    keep = ("outcome", "error_m", "t3", "T_D", "T_total", "D3", "sources_true", "sources_declared",
            "sources_found", "false_declarations", "flybys", "withdrawn", "upflow_checks",
            "upflow_vetoes", "trace_vetoes", "visits", "visits_ended", "unchecked", "sim_time_s",
            "wall_time_s")
    return {"study": study, "replicate": r, **{k: s[k] for k in keep}}


def _q(values: list[float], q: float) -> float | None:
    return float(np.quantile(values, q)) if values else None


def _f(v: float | None, fmt: str = ".1f") -> str:
    return "—" if v is None else format(v, fmt)


def table_msn007(rows: list[dict[str, Any]], n: int) -> list[str]:
    """The side-by-side table of (a)."""
    by = {name: {r["replicate"]: r for r in rows if r["study"] == name} for name in CONFIGS}
    base = by["upflow_cluster"]
    out = [f"| rule (MSN007, up to N = {n} paired) | N | declared | false (> 15 m; its rate's "
           "95% Wilson interval) | error "
           "median / p95 / max (m) | T_D share (mean) | D3 mean (m) | D3 paired change vs "
           "upflow_cluster | fly-bys / withdrawn | up-flow check legs / vetoes (by a trace) / "
           "visits (timed out) / unchecked |",
           "|---|---|---|---|---|---|---|---|---|---|"]
    for name, runs in by.items():
        got = list(runs.values())
        if not got:
            continue
        dec = [r for r in got if r["t3"] is not None]
        err = [r["error_m"] for r in dec if r["error_m"] is not None]
        false = sum(e > FALSE_M for e in err)
        share = [s for s in map(td_share, dec) if s is not None]
        d3 = [r["D3"] for r in dec if r["D3"] is not None]
        both = [k for k, r in runs.items()
                if r["D3"] is not None and k in base and base[k]["D3"] is not None]
        paired = [runs[k]["D3"] / base[k]["D3"] - 1 for k in both if base[k]["D3"]]
        of_means = (statistics.fmean([runs[k]["D3"] for k in both])
                    / statistics.fmean([base[k]["D3"] for k in both]) - 1) if both else None
        fly = sum(r["flybys"] or 0 for r in got)
        wd = sum(r["withdrawn"] or 0 for r in got)
        # rules without the check (and rows flown before it) have none: "—"
        check = ([sum(r.get(k) or 0 for r in got) for k in ("upflow_checks", "upflow_vetoes",
                                                           "unchecked")]
                 if any(r.get("upflow_checks") is not None for r in got) else None)
        traces = (f" ({sum(r.get('trace_vetoes') or 0 for r in got)})"
                  if any(r.get("trace_vetoes") is not None for r in got) else "")
        visits = (f"{sum(r.get('visits') or 0 for r in got)}"
                  if any(r.get("visits") is not None for r in got) else "—")
        if any(r.get("visits_ended") is not None for r in got):
            visits += f" ({sum(r.get('visits_ended') or 0 for r in got)})"
        out.append(
            f"| {name} | {len(got)} | {100 * len(dec) / len(got):.1f}% ({len(dec)}/{len(got)}) | "
            f"{false} ({rate_interval(false, len(got))}) | "
            f"{_f(_q(err, 0.5))} / {_f(_q(err, 0.95))} / {_f(max(err) if err else None)} | "
            f"{_f(100 * statistics.fmean(share) if share else None)}% | "
            f"{_f(statistics.fmean(d3) if d3 else None, '.0f')} | "
            f"{_f(100 * of_means if of_means is not None else None, '+.0f')}% of means, "
            f"{_f(100 * statistics.median(paired) if paired else None, '+.0f')}% median ratio | "
            f"{fly} / {wd} | "
            + (f"{check[0]} / {check[1]}{traces} / {visits} / {check[2]}" if check is not None
               else "—")
            + " |"
        )
    return out


def rate_interval(k: int, n: int) -> str:
    """The 95% Wilson interval of a rate of ``k`` in ``n``, in per cent: a count of 0 or 1 in
    1000 runs is a rate, and the interval says how well those runs pin it down."""
    lo, hi = wilson(k, n)
    return f"{100 * lo:.2f}-{100 * hi:.2f}%"


def table_two(rows: list[dict[str, Any]]) -> list[str]:
    """The two-source line of (b)."""
    got = [r for r in rows if r["study"] == "two_sources"]
    if not got:
        return []
    both = sum(r["sources_found"] == 2 for r in got)
    false = sum(r["false_declarations"] for r in got)
    one = sum(r["sources_found"] == 1 for r in got)
    t = [r["t3"] for r in got if r["sources_found"] == 2 and r["t3"] is not None]
    bad = sum(r["false_declarations"] > 0 for r in got)
    return ["| two_sources (likelihood_map, max_sources 2) | runs | both within 15 m | one | "
            "false declarations (runs with one; their rate's 95% Wilson interval) | time to the "
            "second declaration, median (s) |",
            "|---|---|---|---|---|---|",
            f"| | {len(got)} | {100 * both / len(got):.1f}% ({both}) | {one} | {false} ({bad}; "
            f"{rate_interval(bad, len(got))}) | "
            f"{_f(statistics.median(t) if t else None, '.0f')} |"]


def cycle_cost(seeds: int) -> list[str]:
    """(c): time per call of the map's watch, TRO at 1 Hz and AB at 10 Hz."""
    from cptbt.behaviours.likelihood import LikelihoodMapDeclare

    times: list[float] = []
    cpu: list[float] = []
    original: Callable[..., None] = LikelihoodMapDeclare.watch

    def timed(self: LikelihoodMapDeclare, p: Any) -> None:
        t0, c0 = time.perf_counter(), time.process_time()
        original(self, p)
        cpu.append(time.process_time() - c0)
        times.append(time.perf_counter() - t0)

    LikelihoodMapDeclare.watch = timed  # type: ignore[method-assign]
    lines = ["| setting | cells | cycles timed | CPU mean (ms) | CPU p99 (ms) | wall mean (ms) "
             "| wall p99 (ms) |", "|---|---|---|---|---|---|---|"]
    try:
        cases = [("TRO MSN007, 1 Hz", MSN007, {"declare_source.variant": "likelihood_map"}, False),
                 ("AB 100 x 100 m, 10 Hz (Strategy III tree)",
                  ROOT / "missions/ab2001_strategy3.yaml", {}, True)]
        for label, path, settings, add_map in cases:
            times.clear()
            cpu.clear()
            mission = mission_with(path, settings, add_map=add_map)
            area = mission.op_area_geometry()
            cells = int(np.ceil((area.xmax - area.xmin) / 2.0)
                        * np.ceil((area.ymax - area.ymin) / 2.0))
            for r in range(seeds):
                params = to_sim_params(mission, SEED)
                env_rng, vehicle_rngs = group_seeds(SEED, r, 1)
                simulate(mission, params, [launch_pose(mission)], env_rng=env_rng,
                         vehicle_rngs=vehicle_rngs)
            ms, cms = np.array(times) * 1e3, np.array(cpu) * 1e3
            lines.append(f"| {label} | {cells} | {len(ms)} | {cms.mean():.3f} | "
                         f"{np.quantile(cms, 0.99):.3f} | {ms.mean():.3f} | "
                         f"{np.quantile(ms, 0.99):.3f} |")
    finally:
        LikelihoodMapDeclare.watch = original  # type: ignore[method-assign]
    return lines


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=40, help="MSN007 replicates per rule")
    ap.add_argument("--two-runs", type=int, default=20, help="two-source replicates")
    ap.add_argument("--configs", default=",".join(CONFIGS), help="comma-separated rule names")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--seed", type=int, default=SEED,
                    help=f"root seed (default {SEED}, the reported table's; tune on another)")
    ap.add_argument("--cost-seeds", type=int, default=2,
                    help="seeds for the per-cycle cost table (0: skip it)")
    ap.add_argument("--out", default=str(ROOT / "runs/likelihood_map/likelihood_map.md"),
                    help="the table; its rows go next to it (.jsonl). Default: runs/likelihood_"
                    "map/, a scratch folder (a review: the default had been the committed "
                    "evidence, which a quick run replaced)")
    ap.add_argument("--from-rows", action="store_true",
                    help="only tabulate the rows already in the .jsonl next to --out (a study "
                    "stopped early, or several studies' rows put together; each rule's N is its "
                    "own, paired changes use the replicates both rules have)")
    ap.add_argument("--extra", action="append", default=[], metavar="LABEL|KEY=VALUE,...",
                    help="fly another rule as well (repeatable; for tuning), e.g. "
                    "'lm tau 60|declare_source.variant=likelihood_map,"
                    "declare_source.meander_memory_s=60'; values are read as YAML")
    ap.add_argument("--two-set", default="", metavar="KEY=VALUE,...",
                    help="settings for the two-source runs (for tuning; values read as YAML)")
    ap.add_argument("--two-mission", default=str(TWO), metavar="PATH",
                    help="the several-source mission of (b) (default: "
                    "missions/two_sources.yaml)")
    args = ap.parse_args()
    names = [c for c in args.configs.split(",") if c]
    for extra in args.extra:
        label, _, body = extra.partition("|")
        if not label or not body:
            ap.error(f"--extra {extra!r}: expected LABEL|KEY=VALUE,...")
        settings: dict[str, Any] = {}
        for item in body.split(","):
            key, eq, value = item.partition("=")
            if not eq:
                ap.error(f"--extra {extra!r}: {item!r} is not KEY=VALUE")
            settings[key.strip()] = yaml.safe_load(value)
        CONFIGS[label] = settings
        names.append(label)
    two_settings: dict[str, Any] = {}
    for item in filter(None, args.two_set.split(",")):
        key, eq, value = item.partition("=")
        if not eq:
            ap.error(f"--two-set: {item!r} is not KEY=VALUE")
        two_settings[key.strip()] = yaml.safe_load(value)
    # Replicate by replicate, so the rows written so far always hold whole paired replicates.
    jobs = []
    for r in range(max(args.runs, args.two_runs)):
        if r < args.runs:
            jobs += [(name, str(MSN007), CONFIGS[name], r, args.seed) for name in names]
        if r < args.two_runs:
            jobs.append(("two_sources", args.two_mission, two_settings, r, args.seed))
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    rows_path = out.with_suffix(".jsonl")
    wall0 = time.perf_counter()
    load0 = os.getloadavg()[0]
    rows: list[dict[str, Any]] = []
    if args.from_rows:
        rows = [json.loads(line) for line in rows_path.read_text(encoding="utf-8").splitlines()]
        rows = [r for r in rows if r["study"] in names or r["study"] == "two_sources"]
        args.runs = max((sum(r["study"] == name for r in rows) for name in names), default=0)
        args.two_runs = sum(r["study"] == "two_sources" for r in rows)
        jobs = []
    else:
        with ProcessPoolExecutor(max_workers=args.workers) as pool, \
                rows_path.open("w", encoding="utf-8") as f:
            for row in pool.map(fly, jobs, chunksize=1):
                rows.append(row)
                f.write(json.dumps(row) + "\n")
                f.flush()
    wall = time.perf_counter() - wall0
    machine = (f"{platform.machine()}, {os.cpu_count()} CPUs (shared), Python "
               f"{platform.python_version()}, NumPy {np.__version__} (its floating point "
               f"shapes the rows), {args.workers} workers")
    if not args.from_rows:
        machine += (f", 1-min load average {load0:.1f} at the start and "
                    f"{os.getloadavg()[0]:.1f} at the end")
    # the whole command as given (a review re-ran a header that had left --configs out)
    command = shlex.join(["python", "benchmarks/likelihood_map.py", *sys.argv[1:]])
    lines = [
        "# Likelihood-map declaration study (issue 13)",
        "",
        (f"Tabulated by `{command}` from the rows in "
         f"`{rows_path.name}` ({args.runs} MSN007 replicates at most per rule, {args.two_runs} "
         f"two-source runs; how they were flown: the notes) on {machine}" if args.from_rows else
         f"Produced by `{command}` on {machine}")
        + ("" if args.from_rows else f": {len(jobs)} runs in {wall / 60:.1f} min")
        + f". Root seed {args.seed}; replicate r flies the same plume, vehicle noise and start in "
        "every rule (paired)."
        + ("" if args.from_rows or Path(args.two_mission).resolve() == TWO.resolve() else
           f" The several-source mission of (b): `{args.two_mission}`"
           + (f", with {args.two_set}" if args.two_set else "") + "."),
        "",
        *(["## (a) TRO MSN007, the AMP alone (`cptbt.batch.engine.simulate`)", "",
           *table_msn007(rows, args.runs), ""] if args.runs else []),
        "## (b) Two sources",
        "",
        *table_two(rows),
        "",
        "## (c) Per-cycle cost of the map (`LikelihoodMapDeclare.watch`)",
        "",
        "CPU time of the calling process (`time.process_time`, 10 ms-class resolution on some "
        "kernels, so the mean is the figure to read) and wall time (inflated by other jobs on "
        "the shared machine).",
        "",
        *(cycle_cost(args.cost_seeds) if args.cost_seeds > 0
          else ["(not measured: --cost-seeds 0)"]),
        "",
    ]
    text = "\n".join(lines)
    print(text)
    out.write_text(text, encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())

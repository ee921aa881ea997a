"""A study planned and run in shards from Python, on a Dask cluster, merged to the same
runs.csv and report as ``mpm study`` in one process."""

import csv
import os
import re

import pytest

import sparse_mpm
import sparse_mpm.study as study


def table_without_wall_clock(path):
    """runs.csv as rows, without the ``*_seconds`` columns (wall-clock times)."""
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    keep = [i for i, name in enumerate(rows[0]) if not name.endswith("_seconds")]
    assert len(keep) < len(rows[0]), "runs.csv has wall-clock columns"
    return [[row[i] for i in keep] for row in rows]


def report_text(path):
    with open(path) as f:
        return f.read()


def distributed():
    """dask.distributed: required in CI (installed by .ci/run), optional elsewhere."""
    if os.environ.get("CI"):
        import dask.distributed

        return dask.distributed
    return pytest.importorskip("dask.distributed")


@pytest.fixture(scope="module")
def single_process(tmp_path_factory, run_mpm):
    out = tmp_path_factory.mktemp("single")
    run_mpm("study", "--quick", "-o", out, "-q")
    return out


def test_a_study_on_a_dask_cluster_merges_to_the_single_process_study(tmp_path, single_process):
    dd = distributed()
    runs = study.plan(tmp_path, quick=True)
    assert runs > 3
    with dd.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        with dd.Client(cluster) as client:
            shares = study.run(tmp_path, client=client)
    assert len(shares) == 2
    assert sum(s[0] for s in shares) == runs, "the shards cover the plan"
    assert sum(s[1] for s in shares) == runs, "every run ran once"
    merged = study.merge(tmp_path)
    assert merged.missing == [] and merged.merged == runs
    assert table_without_wall_clock(merged.runs_csv) == table_without_wall_clock(single_process / "runs.csv")
    assert report_text(merged.report) == report_text(single_process / "report.md")


def test_shards_run_here_skip_complete_runs_and_a_partial_merge_lists_the_missing(tmp_path):
    runs = study.plan(tmp_path, quick=True, parts=["time_step", "single_point"])
    taken, ran, skipped, failed = study.run_shard(tmp_path, 1, 2)
    assert ran == taken and skipped == 0 and failed == 0
    partial = study.merge(tmp_path)
    assert partial.merged == taken and len(partial.missing) == runs - taken
    assert all(i % 2 == 1 for i in partial.missing), "shard 1 of 2 takes the even plan indices"
    with open(partial.report) as f:
        assert "Runs missing" in f.read()
    again = study.run(tmp_path)
    assert sum(s[1] for s in again) == runs - taken, "a second pass runs only what is missing"
    assert study.merge(tmp_path).missing == []


def test_a_plan_of_another_version_or_spec_is_refused(tmp_path):
    study.plan(tmp_path, quick=True, parts=["single_point"])
    with pytest.raises(sparse_mpm.MpmError, match="another spec"):
        study.plan(tmp_path, quick=True, parts=["time_step"])
    plan = tmp_path / "plan.json"
    text = plan.read_text()
    plan.write_text(re.sub(r'"version": "[^"]*"', '"version": "0.0.1"', text, count=1))
    with pytest.raises(sparse_mpm.MpmError, match="planned by sparse-mpm 0.0.1"):
        study.run_shard(tmp_path, 1, 1)


def test_bad_shards_are_refused_naming_the_argument(tmp_path):
    plan = tmp_path / "p"
    assert study.plan(plan, quick=True, parts="single_point") == 3  # a string: comma-separated parts
    for k, n in [(0, 3), (4, 3), (-1, 3), (1, -1), (2**70, 3)]:
        with pytest.raises(sparse_mpm.MpmError, match="1 <= k <= n"):
            study.run_shard(plan, k, n)
    for k, n in [(1.5, 3), (True, 3), (None, None), ("1", "3")]:
        with pytest.raises(TypeError, match="whole number"):
            study.run_shard(plan, k, n)
    for shards in [0, -2]:
        with pytest.raises(sparse_mpm.MpmError, match="shards"):
            study.run(plan, shards=shards)
    assert not (plan / "runs").exists(), "nothing ran"
    assert study.run(plan, shards=2) == [(2, 2, 0, 0), (1, 1, 0, 0)]


def test_the_library_error_crosses_a_process_pool_as_itself(tmp_path):
    import pickle
    from concurrent.futures import ProcessPoolExecutor

    err = pickle.loads(pickle.dumps(sparse_mpm.MpmError("x")))
    assert type(err) is sparse_mpm.MpmError and str(err) == "x"
    with ProcessPoolExecutor(1) as pool:
        with pytest.raises(sparse_mpm.MpmError, match="plan.json"):
            pool.submit(study.run_shard, str(tmp_path / "nope"), 1, 1).result()

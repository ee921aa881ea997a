"""A study split across processes and machines: plan it, run its shards anywhere, merge.

The same three steps as ``mpm study plan``, ``mpm study run DIR --shard K/N`` and
``mpm study merge DIR`` (docs/study.md). A plan folder is all the state there is: any process
that sees it (a Dask worker, a Slurm task, another machine on a shared file system) can run a
shard of it; runs already complete are skipped, so a shard submitted twice, or after an
interruption, only finishes what is missing. The merged ``runs.csv`` and ``report.md`` are the
same whichever engine ran the shards (the ``*_seconds`` columns, wall-clock times, aside)::

    import sparse_mpm.study as study
    from dask.distributed import Client, LocalCluster

    study.plan("out/study", quick=True)
    with Client(LocalCluster(n_workers=2)) as client:
        study.run("out/study", client=client)        # one shard per worker, by default
    report = study.merge("out/study")

Without ``client`` the shards run one after the other in this process.
"""

from __future__ import annotations

import os as _os
import typing as _t

from . import _core

__all__ = ["plan", "run", "run_shard", "merge", "MergeResult"]

_PathLike = _t.Union[str, "_os.PathLike[str]"]


class MergeResult(_t.NamedTuple):
    """What :func:`merge` wrote: the report, the CSV of every run, and the runs missing."""

    report: str
    runs_csv: str
    merged: int
    failed: int
    missing: _t.List[int]


def plan(
    out: _PathLike,
    *,
    quick: bool = False,
    spec: _t.Optional[str] = None,
    parts: _t.Optional[_t.Sequence[str]] = None,
) -> int:
    """Writes the plan of a study into ``out`` (``plan.json``, ``plan.csv``) and returns its
    number of runs. ``spec`` is the text of a study spec (TOML, docs/verification.md "Study
    spec keys"); without it the quick study (``quick=True``) or the full one. Planning the same
    spec again into the same folder keeps the runs already complete. ``parts`` is a list of part
    names, or one string of them separated by commas (as ``--parts``)."""
    if isinstance(parts, str):
        parts = parts.split(",")
    return _core.study_plan(_os.fspath(out), spec, quick, list(parts) if parts is not None else None)


def run_shard(plan_dir: _PathLike, k: int, n: int) -> _t.Tuple[int, int, int, int]:
    """Runs shard ``k`` of ``n`` (1 <= k <= n) of the plan in ``plan_dir``: the runs of plan
    index ``i`` with ``i % n == k - 1`` that are not complete. Returns ``(taken, ran, skipped,
    failed)``. A module-level function, so that Dask (or any pool) can ship it to a worker.
    ``k`` and ``n`` that are not whole numbers (``bool`` included) are a ``TypeError``, out of
    range an ``MpmError``. Ctrl-C stops the shard between two runs (the runs complete so far
    stay complete)."""
    k, n = _whole("k", k), _whole("n", n)
    if not 1 <= k <= n:
        raise _core.MpmError(f"k = {k}, n = {n}: give 1 <= k <= n (shard k of n)")
    return _core.study_run(_os.fspath(plan_dir), k, n)


def _whole(name: str, value: _t.Any) -> int:
    """``value`` as an int, when it is a whole number and not a ``bool``."""
    import numbers

    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise TypeError(f"{name} must be a whole number, not {type(value).__name__} {value!r}")
    return int(value)


def run(plan_dir: _PathLike, client: _t.Any = None, shards: _t.Optional[int] = None) -> _t.List[_t.Tuple[int, int, int, int]]:
    """Runs every shard of the plan in ``plan_dir``. With a Dask ``client``
    (``dask.distributed.Client``) the shards are submitted with ``client.submit`` and gathered
    (``shards`` defaults to the number of workers); without one they run here in turn
    (``shards`` defaults to 1). Returns each shard's ``(taken, ran, skipped, failed)``."""
    path = _os.fspath(plan_dir)
    if shards is not None:
        shards = _whole("shards", shards)
        if shards < 1:
            raise _core.MpmError(f"shards = {shards}: give at least 1")
    if client is None:
        n = shards or 1
        return [run_shard(path, k, n) for k in range(1, n + 1)]
    n = shards or max(1, len(client.scheduler_info().get("workers", {})))
    futures = [client.submit(run_shard, path, k, n, pure=False) for k in range(1, n + 1)]
    return list(client.gather(futures))


def merge(plan_dir: _PathLike) -> MergeResult:
    """Writes ``runs.csv``, the plots and ``report.md`` from the complete runs of the plan in
    ``plan_dir`` and lists the plan indices of the runs missing (the report lists them too).
    Runs of another crate version or plan raise ``MpmError`` (nothing is mixed)."""
    path = _os.fspath(plan_dir)
    merged, failed, missing = _core.study_merge(path)
    return MergeResult(
        report=_os.path.join(path, "report.md"),
        runs_csv=_os.path.join(path, "runs.csv"),
        merged=merged,
        failed=failed,
        missing=list(missing),
    )

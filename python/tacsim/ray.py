"""Datasets on a Ray cluster: a recipe's shards as Ray tasks, joined by the engine's merge.

Needs the ``ray`` extra (``pip install './python[ray]'``). Each task is the engine's own shard
(``tacsim generate --shard i/n``) on the cores it asks for, written under a folder every node
sees (a shared filesystem); the driver then merges them with the engine's ``merge``, which
checks every shard against its SHA256SUMS first, so the result has the bytes of
``tacsim generate`` on one machine. Rerunning the same call resumes: a shard's images already
written (and as recorded) are kept, and a task whose worker dies is retried by Ray and resumes
its shard the same way.

>>> import tacsim.ray
>>> data = tacsim.ray.generate("quick", "/shared/quick", shards=4)   # doctest: +SKIP
>>> len(data)                                                          # doctest: +SKIP
300

``docs/guide/cluster.md`` has the cluster's set-up (``ray start --head``, ``address=``) and the
same runs as a Slurm job array.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, List, Optional, Tuple, Union

from . import _tacsim

Progress = Union[bool, Callable[[int, int], None]]


def _ray():
    try:
        import ray
    except ImportError as e:  # pragma: no cover - the message is the point
        raise ImportError(
            "tacsim.ray needs Ray: pip install './python[ray]' (or pip install 'ray>=2.9')"
        ) from e
    return ray


@dataclass(frozen=True)
class ShardRun:
    """What one shard's task did: the engine's summary of its last attempt."""

    shard: int
    shards: int
    folder: str
    images: int
    written: int
    skipped: int
    rewritten: int
    wall_s: float


def _check_count(name: str, value, lo: int, hi: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not lo <= value <= hi:
        raise ValueError(f"{name} must be a whole number in [{lo}, {hi}], got {value!r}")
    return value


def _writable_folder(path: Path, what: str) -> None:
    """Refuses, before any task runs, a folder that cannot be made or written."""
    if path.exists() and not path.is_dir():
        raise ValueError(f"{what} {path} exists and is not a folder: name another")
    probe = path if path.exists() else next((p for p in path.parents if p.exists()), Path("."))
    if not os.access(probe, os.W_OK | os.X_OK):
        raise PermissionError(f"{what} {path}: {probe} is not writable; name a folder you can write")


def _absolute_if_file(value: Optional[str]) -> Optional[str]:
    """A recipe's or sensor's file as an absolute path (a built-in name as it is)."""
    return str(Path(value).absolute()) if value is not None and Path(value).is_file() else value


def _node_cpus(ray) -> int:
    """The fewest CPUs of any alive node: a task that asks for them fits on every node."""
    cpus = [int(n["Resources"].get("CPU", 0)) for n in ray.nodes() if n.get("Alive")]
    cpus = [c for c in cpus if c > 0]
    return min(cpus) if cpus else 1


def _shard_task(ray):
    """The remote function of one shard (made once per Ray session)."""

    def run(recipe, folder, shard, shards, threads, options, progress_actor, kill_after, marker):
        def report(done: int, _total: int) -> None:
            if progress_actor is not None:
                progress_actor.update.remote(shard, done)
            # The tests' killed worker: the first attempt dies after `kill_after` images.
            if kill_after is not None and done >= kill_after and not os.path.exists(marker):
                Path(marker).write_text(str(os.getpid()))
                os.kill(os.getpid(), signal.SIGKILL)

        summary = _tacsim.generate(
            recipe,
            folder,
            threads=threads,
            resume=True,
            progress=report,
            shard=(shard, shards),
            **options,
        )
        return ShardRun(
            shard=shard,
            shards=shards,
            folder=folder,
            images=summary["images"],
            written=summary["written"],
            skipped=summary["skipped"],
            rewritten=summary["rewritten"],
            wall_s=summary["wall_s"],
        )

    return run


def _progress_actor(ray):
    @ray.remote(num_cpus=0)
    class ShardProgress:
        def __init__(self) -> None:
            self.shards = {}

        def update(self, shard: int, done: int) -> None:
            self.shards[shard] = max(done, self.shards.get(shard, 0))

        def done(self) -> int:
            return sum(self.shards.values())

    return ShardProgress.remote()


def _reporter(progress: Progress) -> Optional[Callable[[int, int], None]]:
    if callable(progress):
        return progress
    if not progress:
        return None

    def line(done: int, total: int) -> None:
        end = "\n" if done >= total else ""
        print(f"\rtacsim.ray: {done}/{total} images", end=end, file=sys.stderr, flush=True)

    return line


def generate_shards(
    recipe: str,
    shard_root: str,
    shards: Optional[int] = None,
    address: Optional[str] = None,
    *,
    cpus_per_shard: Optional[int] = None,
    sensor: Optional[str] = None,
    seed: Optional[int] = None,
    size: Optional[int] = None,
    cells: Optional[int] = None,
    force: bool = False,
    max_retries: int = 3,
    progress: Progress = False,
    _kill_after: Optional[Tuple[int, int]] = None,
) -> List[ShardRun]:
    """Runs shard ``i`` of ``shards`` (default: one per alive node) for every ``i`` as a Ray task
    (``shard_root/shard-i-of-n``), each resuming what is there; returns each shard's :class:`ShardRun` in order. A task whose
    worker dies is retried up to ``max_retries`` times. ``cpus_per_shard`` (default: the fewest
    CPUs of any node, so a task takes a whole node) is both the task's Ray resource and the
    engine's threads. Connects to ``address`` (``ray.init``'s: ``"auto"``, ``"ray://host:10001"``)
    where Ray is not initialised yet, else starts a local cluster."""
    ray = _ray()
    if shards is not None:
        _check_count("shards", shards, 1, 100_000)
    _check_count("max_retries", max_retries, 0, 100)
    if cpus_per_shard is not None:
        _check_count("cpus_per_shard", cpus_per_shard, 1, 1024)
    # Workers need not share the driver's working directory: paths go to them absolute.
    root = Path(shard_root).absolute()
    _writable_folder(root, "shard folder")
    recipe, sensor = _absolute_if_file(recipe), _absolute_if_file(sensor)
    options = {"sensor": sensor, "seed": seed, "size": size, "cells": cells, "force": force}
    # The recipe, the sensor and the size limits, checked here before any task is handed out.
    images = _tacsim.plan(recipe, **options)
    if not ray.is_initialized():
        ray.init(address=address, include_dashboard=False, log_to_driver=False)
    if shards is None:
        shards = max(1, sum(1 for n in ray.nodes() if n.get("Alive")))
    cpus = cpus_per_shard if cpus_per_shard is not None else _node_cpus(ray)
    root.mkdir(parents=True, exist_ok=True)
    task = ray.remote(num_cpus=cpus, max_retries=max_retries)(_shard_task(ray))
    report = _reporter(progress)
    counter = _progress_actor(ray) if report is not None else None
    refs = []
    for i in range(shards):
        folder = str(root / f"shard-{i}-of-{shards}")
        kill = _kill_after[1] if _kill_after is not None and _kill_after[0] == i else None
        marker = str(root / f"shard-{i}-of-{shards}.killed")
        refs.append(task.remote(recipe, folder, i, shards, cpus, options, counter, kill, marker))
    pending = list(refs)
    while pending:
        _, pending = ray.wait(pending, num_returns=len(pending), timeout=0.5)
        if report is not None and pending:
            report(min(ray.get(counter.done.remote()), images - 1), images)
    runs = ray.get(refs)
    if report is not None:
        report(images, images)
    return runs


def generate(
    recipe: str,
    out: str,
    shards: Optional[int] = None,
    address: Optional[str] = None,
    *,
    shard_root: Optional[str] = None,
    keep_shards: bool = False,
    cpus_per_shard: Optional[int] = None,
    sensor: Optional[str] = None,
    seed: Optional[int] = None,
    size: Optional[int] = None,
    cells: Optional[int] = None,
    force: bool = False,
    max_retries: int = 3,
    progress: Progress = True,
) -> "_tacsim.Dataset":
    """The dataset of ``recipe`` (a file or a built-in name) in ``out``, made as ``shards`` Ray
    tasks (default: one per alive node) and merged: the bytes ``tacsim generate`` writes on one
    machine. The shards go to ``shard_root`` (default ``out`` + ``.shards``, beside it; on a
    filesystem every node sees) and are removed after the merge unless ``keep_shards``. Rerun
    the same call to resume. ``progress``: a line on stderr (True), nothing (False), or
    ``progress(done, total)``. Returns the merged :class:`tacsim.Dataset`."""
    _ray()  # its install hint before anything else
    target = Path(out)
    _writable_folder(target, "out")
    root = Path(shard_root) if shard_root is not None else target.with_name(target.name + ".shards")
    if root.resolve() == target.resolve() or target.resolve() in root.resolve().parents:
        raise ValueError(f"shard_root {root} lies inside out {target}: name a folder beside it")
    start = time.monotonic()
    runs = generate_shards(
        recipe,
        str(root),
        shards,
        address,
        cpus_per_shard=cpus_per_shard,
        sensor=sensor,
        seed=seed,
        size=size,
        cells=cells,
        force=force,
        max_retries=max_retries,
        progress=progress,
    )
    # Shards that are removed next give their images up: renamed, not copied.
    _tacsim.merge(str(target), [r.folder for r in runs], move=not keep_shards)
    if keep_shards:
        record = {"wall_s": time.monotonic() - start, "shards": [r.__dict__ for r in runs]}
        (root / "runs.json").write_text(json.dumps(record, indent=1))
    else:
        shutil.rmtree(root)
    return _tacsim.Dataset(str(target))


__all__ = ["ShardRun", "generate", "generate_shards"]


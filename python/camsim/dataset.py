"""Synthetic raw datasets at scale, and raw folders developed at scale, on Ray.

:func:`generate` renders the samples of a dataset spec (the TOML ``camsim dataset`` reads; see
``docs/scale.md``) as Ray tasks, on the cluster at ``address`` or on a local one. Each sample
is a pure function of (spec, dataset seed, index) and is written into its own folder through
a temporary name, so a task retried after a failure, or run twice, leaves one copy, and the
dataset is byte for byte the one ``camsim dataset --range 0..N`` writes in one process::

    import camsim.dataset
    summary = camsim.dataset.generate("spec.toml", "/data/out", address="auto")
    report = camsim.dataset.manifest("/data/out")    # writes /data/out/manifest.jsonl

:func:`sample` makes one sample in this process (no Ray), :func:`develop` runs the ISP over a
list of raw files (DNG) as Ray tasks.

Ray is imported only by the functions that use it (``pip install "ray>=2.9"``).
"""

from __future__ import annotations

import json
import os
import sys
import time
from typing import Any, Dict, Iterable, List, Mapping, Optional, Sequence, Tuple, Union

from . import _camsim

__all__ = ["generate", "sample", "manifest", "develop"]

PathLike = Union[str, "os.PathLike[str]"]
Spec = Union[PathLike, Mapping[str, Any]]


def _spec(spec: Spec) -> Tuple[str, str]:
    """The spec's TOML text and the folder its relative paths are relative to."""
    if isinstance(spec, Mapping):
        from ._sim import _toml

        return _toml(spec), os.getcwd()
    path = os.path.abspath(os.fspath(spec))
    with open(path, encoding="utf-8") as f:
        return f.read(), os.path.dirname(path)


def _ray():
    try:
        import ray
    except ImportError as e:  # pragma: no cover - the test environment has Ray
        raise ImportError(
            "camsim.dataset needs Ray for generate() and develop(): pip install 'ray>=2.9' "
            "(or run `camsim dataset --shard K/N` under any scheduler)"
        ) from e
    return ray


def sample(spec: Spec, out: PathLike, index: int, *, threads: int = 0) -> Dict[str, Any]:
    """Generates sample ``index`` of ``spec`` into ``out`` in this process (the GIL released),
    ``threads`` render threads (0: every core). Returns ``{"index", "status": "written" or
    "present", and seconds by step (render_s, sensor_s, isp_s, write_s, total_s) when
    written}``."""
    text, base = _spec(spec)
    out = os.fspath(out)
    _camsim.dataset_prepare(text, base, out)
    return json.loads(_camsim.dataset_sample(text, base, out, int(index), int(threads)))


def _sample_task(
    text: str,
    base: str,
    out: str,
    index: int,
    threads: int,
    failure: Optional[Tuple[str, Sequence[int]]] = None,
) -> Dict[str, Any]:
    """One Ray task: one sample. ``failure`` (tests only) makes the first attempt at the
    listed indices fail after leaving a half-written folder, as a worker killed mid-sample
    would."""
    if failure is not None and index in failure[1]:
        marker = os.path.join(failure[0], f"failed-{index}")
        if not os.path.exists(marker):
            open(marker, "w").close()
            partial = os.path.join(out, f".partial-{index:06}-{os.getpid()}-injected")
            os.makedirs(partial, exist_ok=True)
            with open(os.path.join(partial, "raw.dng"), "wb") as f:
                f.write(b"II*\0 half a file")
            raise RuntimeError(f"injected failure of sample {index}")
    return json.loads(_camsim.dataset_sample(text, base, out, index, threads))


class _Progress:
    """One line on stderr, rewritten in place on a terminal, every few seconds otherwise."""

    def __init__(self, what: str, total: int, enabled: bool):
        self.what, self.total, self.enabled = what, total, enabled
        self.start = time.perf_counter()
        self.last = self.start
        self.tty = enabled and sys.stderr.isatty()

    def update(self, done: int, present: int, final: bool = False) -> None:
        if not self.enabled:
            return
        now = time.perf_counter()
        if not (final or self.tty or now - self.last >= 5.0):
            return
        self.last = now
        rate = (done - present) / max(now - self.start, 1e-9)
        line = (
            f"[camsim] {self.what}: {done}/{self.total} ({present} already complete), "
            f"{rate:.2f}/s, {now - self.start:.0f} s"
        )
        end = "\n" if final or not self.tty else ""
        sys.stderr.write(("\r" if self.tty else "") + line + end)
        sys.stderr.flush()


def _run(ray, refs: List[Any], progress: _Progress) -> List[Dict[str, Any]]:
    results: List[Dict[str, Any]] = []
    pending = list(refs)
    present = 0
    while pending:
        done, pending = ray.wait(pending, num_returns=min(len(pending), 8), timeout=1.0)
        for r in ray.get(done):
            results.append(r)
            present += r.get("status") == "present"
        progress.update(len(results), present)
    progress.update(len(results), present, final=True)
    return results


def _init(ray, address: Optional[str], workers: Optional[int]) -> bool:
    """Connects to Ray unless already connected; True when this call started it."""
    if ray.is_initialized():
        return False
    if address is None:
        ray.init(num_cpus=workers, include_dashboard=False, log_to_driver=False)
    else:
        ray.init(address=address, log_to_driver=False)
    return True


def generate(
    spec: Spec,
    out: PathLike,
    n: Optional[int] = None,
    *,
    address: Optional[str] = None,
    workers: Optional[int] = None,
    threads: int = 1,
    retries: int = 3,
    progress: bool = True,
    _failure: Optional[Tuple[str, Sequence[int]]] = None,
) -> Dict[str, Any]:
    """Generates samples ``0..n`` of ``spec`` (a TOML path or a dict with its tables; ``n``
    defaults to the spec's ``dataset.count``) into ``out`` as Ray tasks.

    ``address``: the Ray cluster's (``"auto"``, ``"ray://head:10001"``); ``None`` starts a
    local one with ``workers`` worker processes (default: one per core), shut down after.
    An already connected session (``ray.init`` called by the caller) is used as it is. Each
    task renders with ``threads`` threads and asks Ray for as many CPUs. A failed task is
    retried up to ``retries`` times; retries write nothing twice (finished samples are
    skipped; unfinished ones are temporary folders). Progress goes to stderr.

    Returns ``{"written", "present", "seconds", "samples_per_s", "samples": [per-sample
    results in index order]}``."""
    ray = _ray()
    text, base = _spec(spec)
    out = os.path.abspath(os.fspath(out))
    count = _camsim.dataset_prepare(text, base, out)
    n = count if n is None else int(n)
    if not 0 <= n <= count:
        raise _camsim.OptionError(f"n {n}: at most the spec's count, {count}")
    started = _init(ray, address, workers)
    try:
        task = ray.remote(
            num_cpus=max(int(threads), 1), max_retries=int(retries), retry_exceptions=True
        )(_sample_task)
        begin = time.perf_counter()
        refs = [task.remote(text, base, out, i, int(threads), _failure) for i in range(n)]
        results = _run(ray, refs, _Progress("dataset", n, progress))
        seconds = time.perf_counter() - begin
    finally:
        if started:
            ray.shutdown()
    results.sort(key=lambda r: r["index"])
    written = sum(r["status"] == "written" for r in results)
    return {
        "written": written,
        "present": n - written,
        "seconds": seconds,
        "samples_per_s": written / seconds if seconds > 0 else 0.0,
        "samples": results,
    }


def manifest(out: PathLike) -> Dict[str, Any]:
    """Gathers the dataset in ``out`` into ``out/manifest.jsonl`` (one JSON record per line,
    what ``pyarrow.json.read_json`` and ``pandas.read_json(..., lines=True)`` read) and checks
    every sample's files against its record. Returns ``{"count", "complete", "missing":
    [indices], "corrupt": [[index, why]], "partial": [unfinished temporary folders]}``;
    raises nothing for a missing sample: check ``complete == count``."""
    return json.loads(_camsim.dataset_manifest(os.fspath(out)))


def _develop_task(path: str, out: str, options: Dict[str, Any], suffix: str) -> Dict[str, Any]:
    """One Ray task: one raw file developed into ``out``, written through a temporary name."""
    from . import imread

    stem = os.path.splitext(os.path.basename(path))[0]
    target = os.path.join(out, stem + suffix)
    if os.path.exists(target):
        return {"path": path, "output": target, "status": "present"}
    start = time.perf_counter()
    with imread(path) as raw:
        rgb = raw.postprocess(**options)
    bits = 16 if rgb.dtype.itemsize == 2 else 8
    tmp = os.path.join(out, f".partial-{stem}-{os.getpid()}{suffix}")
    _camsim.imwrite(tmp, rgb.astype("uint16"), bits)
    os.replace(tmp, target)
    return {
        "path": path,
        "output": target,
        "status": "written",
        "seconds": time.perf_counter() - start,
    }


def develop(
    paths: Iterable[PathLike],
    out: PathLike,
    options: Optional[Mapping[str, Any]] = None,
    *,
    address: Optional[str] = None,
    workers: Optional[int] = None,
    retries: int = 3,
    suffix: str = ".png",
    progress: bool = True,
) -> List[Dict[str, Any]]:
    """Develops each raw file of ``paths`` with :meth:`camsim.Raw.postprocess` (``options``
    as its keywords; ``out_bits=16`` for 16-bit output) into ``out/<stem><suffix>`` (PNG, or
    PPM for ``suffix=".ppm"``) as Ray tasks, on the cluster at ``address`` or a local one of
    ``workers`` processes. Outputs already there are skipped; each is written through a
    temporary name, so retries and reruns leave one copy. The options are checked on the
    first file before any task starts. Returns one dict per file, in the order given."""
    ray = _ray()
    paths = [os.path.abspath(os.fspath(p)) for p in paths]
    options = dict(options or {})
    if options.get("linear"):
        raise _camsim.OptionError("linear: develop() writes PNG or PPM; use Raw.postprocess")
    if "threads" not in options:
        options["threads"] = 1
    out = os.path.abspath(os.fspath(out))
    os.makedirs(out, exist_ok=True)
    stems = [os.path.splitext(os.path.basename(p))[0] for p in paths]
    if len(set(stems)) != len(stems):
        raise _camsim.OptionError("paths: two files share a name; outputs are named by it")
    if paths:
        from . import imread

        with imread(paths[0]) as raw:  # refuses bad options here, not in 1000 tasks
            raw.postprocess(**options)
    started = _init(ray, address, workers)
    try:
        task = ray.remote(max_retries=int(retries), retry_exceptions=True)(_develop_task)
        refs = [task.remote(p, out, options, suffix) for p in paths]
        results = _run(ray, refs, _Progress("develop", len(paths), progress))
    finally:
        if started:
            ray.shutdown()
    order = {p: i for i, p in enumerate(paths)}
    results.sort(key=lambda r: order[r["path"]])
    return results

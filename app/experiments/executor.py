"""Where the runs of an experiment execute: in this process, on this machine's cores, or
on a Dask cluster. One interface for ``sweep``, ``compare``, ``tune`` and the ablation.

``serial``
    One after the other in this process (no start-up cost; what a test or a debugger
    wants).
``local`` (the default)
    A pool of ``--workers`` processes on this machine (default: every CPU this process
    may use, :func:`available_cpus`). The processes are started with ``forkserver`` on
    Linux and the BSDs and with ``spawn`` on macOS and Windows: never ``fork``, which
    copies the parent's threads' locks (rich's progress bar refreshes from a thread)
    and is unsafe on macOS. The fork server imports fuzzynav once and each worker forks
    from it, so a pool starts in well under a second.
``dask``
    A ``dask.distributed`` cluster: the one at ``--scheduler tcp://HOST:8786``, or, with
    no scheduler, a ``LocalCluster`` of ``--workers`` processes (one thread each: a run
    holds the GIL) bound to 127.0.0.1 with no dashboard. Needs ``pip install
    'fuzzynav[dask]'`` here and the same fuzzynav on every worker.

Tasks are chunks of several items (:func:`chunk_size`), so the cost of sending a task
(about a millisecond on a pool, a few on Dask) stays small against the runs it carries
(0.1-0.5 s each). Task functions must be top-level functions of an importable module
and their items picklable (no lambdas, no closures): that is what ``spawn`` and a
remote worker can import. Results do not depend on the executor or the number of
workers: each item carries everything its result depends on (a layout is seeded by its
index), and :meth:`Executor.map` keeps the order.

Workers run one BLAS thread each (:data:`SINGLE_THREAD_ENV`) and ignore SIGINT: Ctrl-C reaches the parent, which stops the pool (terminating
runs in progress) and keeps what had arrived.
"""

from __future__ import annotations

import contextlib
import itertools
import math
import multiprocessing
import os
import signal
import sys
from collections.abc import Callable, Iterable, Iterator

from fuzzynav.app.args import UsageError, integer_in

__all__ = [
    "EXECUTORS",
    "Executor",
    "SerialExecutor",
    "LocalExecutor",
    "DaskExecutor",
    "available_cpus",
    "chunk_size",
    "default_start_method",
    "make_executor",
    "add_executor_options",
    "executor_from_args",
]

EXECUTORS = ("serial", "local", "dask")
TASKS_PER_WORKER = 8  # tasks per worker at least: evens out slow and fast runs
MAX_CHUNK = 4  # items per task at most: ~1 s of runs, so Ctrl-C loses little
WORKER_PRELOAD = ("fuzzynav.app.runs", "fuzzynav.world.shortest_path")
# One BLAS/OpenMP thread per worker (unless the user chose): the workers already fill
# the cores, and OpenBLAS's threads on the plant's tiny matrices cost more than they
# give: a run takes 1.65x the CPU time with them on this 2-core machine (measured:
# 12 paper runs, 1.02 s against 0.62 s of CPU). Dask's nanny does the same.
SINGLE_THREAD_ENV = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


def available_cpus() -> int:
    """The CPUs this process may run on (its affinity mask, or cgroup's count where
    Python 3.13's ``os.process_cpu_count`` knows it), at least 1."""
    count = getattr(os, "process_cpu_count", None)
    if count is not None:
        n = count()
    elif hasattr(os, "sched_getaffinity"):
        n = len(os.sched_getaffinity(0))
    else:  # macOS, Windows before 3.13
        n = os.cpu_count()
    return max(1, n or 1)


def default_start_method() -> str:
    """``forkserver`` where it exists and is safe (Linux, the BSDs), else ``spawn``."""
    if sys.platform in ("darwin", "win32"):
        return "spawn"
    return "forkserver" if "forkserver" in multiprocessing.get_all_start_methods() else "spawn"


def _is_main_guard(node) -> bool:
    """Whether ``node`` is ``if __name__ == "__main__":`` (either side of the ``==``)."""
    import ast

    test = getattr(node, "test", None)
    if not (isinstance(test, ast.Compare) and len(test.ops) == 1):
        return False
    if not isinstance(test.ops[0], ast.Eq):
        return False
    sides = [test.left, test.comparators[0]]
    names = [s for s in sides if isinstance(s, ast.Name) and s.id == "__name__"]
    texts = [s for s in sides if isinstance(s, ast.Constant) and s.value == "__main__"]
    return bool(names and texts)


def _unguarded_main_line() -> tuple[str, int] | None:
    """(script, line) when a pool is being started from the top-level code of the
    ``__main__`` script outside ``if __name__ == "__main__":``; None otherwise (the
    guard is there, no script is running, or its source cannot be read).

    ``spawn`` and ``forkserver`` start each worker by running that script again (as
    ``__mp_main__``): without the guard every worker starts the pool again, fails
    ("An attempt has been made to start a new process before the current process has
    finished its bootstrapping phase"), and the pool replaces it, for ever
    (``fuzzynav.sweep('paper', n=4, workers=2)`` at the top of a script printed 626
    tracebacks in 45 s and never ended)."""
    import ast

    main = sys.modules.get("__main__")
    path = getattr(main, "__file__", None)
    if main is None or not path:
        return None  # python -c, a notebook, an interactive session: nothing re-runs
    frame = sys._getframe(1)
    while frame is not None:
        if frame.f_globals is vars(main) and frame.f_code.co_name == "<module>":
            break
        frame = frame.f_back
    if frame is None:
        return None  # the script's top level has finished: nothing calls this again
    line = frame.f_lineno
    try:
        with open(path, encoding="utf-8") as stream:
            tree = ast.parse(stream.read(), filename=path)
    except (OSError, SyntaxError, ValueError, UnicodeDecodeError):
        return None
    for node in ast.walk(tree):
        if _is_main_guard(node) and node.body:
            if node.body[0].lineno <= line <= node.body[-1].end_lineno:
                return None
    return path, line


def check_main_guard(start_method: str, what: str) -> None:
    """RuntimeError, at once and with a sentence, when starting worker processes now
    would start them again in every worker for ever (:func:`_unguarded_main_line`);
    ``fork`` does not run the script again, so it needs no guard."""
    if start_method == "fork":
        return
    found = _unguarded_main_line()
    if found is None:
        return
    path, line = found
    raise RuntimeError(
        f"{path}, line {line}: {what} is started here, and each worker runs this "
        'script again from the top, so without `if __name__ == "__main__":` every worker '
        "would start the workers again, for ever; put the script's work under "
        '`if __name__ == "__main__":`, or use workers=1'
    )


def chunk_size(n_items: int, n_workers: int) -> int:
    """Items per task: about :data:`TASKS_PER_WORKER` tasks per worker, at most
    :data:`MAX_CHUNK` items each, at least one."""
    if n_items <= 0:
        return 1
    return max(1, min(MAX_CHUNK, math.ceil(n_items / (TASKS_PER_WORKER * max(1, n_workers)))))


def _chunks(items: Iterable, size: int) -> Iterator[tuple[int, list]]:
    """(start, the next ``size`` items) until ``items`` (any iterable) is exhausted."""
    items = iter(items)
    start = 0
    while chunk := list(itertools.islice(items, size)):
        yield start, chunk
        start += len(chunk)


def run_chunk(function: Callable, items: list) -> list:
    """The task every executor sends: ``function`` on each item, in order (top level:
    picklable by reference)."""
    return [function(item) for item in items]


def _indexed_chunk(function: Callable, start: int, items: list) -> tuple[int, list]:
    return start, run_chunk(function, items)


@contextlib.contextmanager
def _single_threaded_children():
    """Within: processes started get one BLAS/OpenMP thread (where the user set none)."""
    added = [name for name in SINGLE_THREAD_ENV if name not in os.environ]
    for name in added:
        os.environ[name] = "1"
    try:
        yield
    finally:
        for name in added:
            os.environ.pop(name, None)


def _worker_init() -> None:
    # Ctrl-C in a terminal signals the whole process group: only the parent acts on it.
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _pool_task(packed):
    function, start, items = packed
    return _indexed_chunk(function, start, items)


class Executor:
    """Runs a function on many items. Subclasses: :class:`SerialExecutor`,
    :class:`LocalExecutor`, :class:`DaskExecutor`. A context manager (closes itself)."""

    kind = "?"
    workers = 1

    def imap_unordered(
        self, function: Callable, items: Iterable, total: int | None = None
    ) -> Iterator:
        """``function(item)`` for every item, yielded as each chunk finishes (in no set
        order); stopping the iteration early (or Ctrl-C) cancels what is left. With
        ``total`` (how many items there are) the items are taken as the workers need
        them, never as a list: an iterator of a sweep's jobs is made as it runs."""
        if total is None:
            items = list(items)
            total = len(items)
        for _, results in self._chunked(function, items, chunk_size(total, self.workers), total):
            yield from results

    def map(self, function: Callable, items: Iterable) -> list:
        """``[function(item) for item in items]``, in order (scipy's ``workers=``
        map-like)."""
        items = list(items)
        size = chunk_size(len(items), self.workers)
        out = [None] * len(items)
        for start, results in self._chunked(function, items, size, len(items)):
            out[start : start + len(results)] = results
        return out

    def _chunked(self, function, items, size, total) -> Iterator[tuple[int, list]]:
        """(start, results) of chunks of ``size`` of the ``total`` ``items`` (an
        iterable, taken as the chunks are sent)."""
        raise NotImplementedError

    def describe(self) -> str:
        return f"{self.kind}, {self.workers} worker{'s' if self.workers != 1 else ''}"

    def close(self) -> None:
        """Release the pool or the cluster connection (idempotent)."""

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False


class SerialExecutor(Executor):
    """Everything in this process, in order."""

    kind = "serial"

    def imap_unordered(self, function, items, total=None):
        for item in items:
            yield function(item)

    def map(self, function, items):
        return [function(item) for item in items]

    def _chunked(self, function, items, size, total):
        yield 0, [function(item) for item in items]


class LocalExecutor(Executor):
    """A process pool on this machine, started on first use and kept until :meth:`close`
    (``tune`` maps every generation through the same pool)."""

    kind = "local"

    def __init__(self, workers: int | None = None, start_method: str | None = None):
        self.workers = _check_workers(workers if workers is not None else available_cpus())
        self.start_method = start_method or default_start_method()
        if self.start_method not in multiprocessing.get_all_start_methods():
            raise ValueError(
                f"start_method = {self.start_method!r}: this platform has "
                f"{', '.join(multiprocessing.get_all_start_methods())}"
            )
        self._pool = None

    def _get_pool(self, tasks: int | None = None):
        if self._pool is None:
            context = multiprocessing.get_context(self.start_method)
            if self.start_method == "forkserver":
                context.set_forkserver_preload(list(WORKER_PRELOAD))
            # never more processes than the first use has tasks for (tune maps the same
            # number every generation)
            processes = self.workers if tasks is None else max(1, min(self.workers, tasks))
            check_main_guard(self.start_method, "a pool of worker processes")
            with _single_threaded_children():  # the fork server and workers start here
                self._pool = context.Pool(processes, initializer=_worker_init)
        return self._pool

    def _chunked(self, function, items, size, total):
        if not total:
            return
        packed = ((function, start, chunk) for start, chunk in _chunks(items, size))
        pool = self._get_pool(math.ceil(total / size))
        try:
            # the pool takes tasks from the generator as its queue to the workers drains
            yield from pool.imap_unordered(_pool_task, packed)
        except BaseException:
            self.terminate()  # Ctrl-C, an error in a run, or a consumer that stopped
            raise

    def terminate(self) -> None:
        """Stop the workers now (runs in progress are lost; nothing else is)."""
        if self._pool is not None:
            self._pool.terminate()
            self._pool.join()
            self._pool = None

    def close(self):
        if self._pool is not None:
            self._pool.close()
            self._pool.join()
            self._pool = None


class DaskExecutor(Executor):
    """A ``dask.distributed`` client: of the cluster at ``scheduler``, or of a
    ``LocalCluster`` of ``workers`` processes started here (and closed with it)."""

    kind = "dask"

    def __init__(self, workers: int | None = None, scheduler: str | None = None):
        try:
            from distributed import Client, LocalCluster
        except ImportError:
            raise ValueError(
                "--executor dask needs dask.distributed: pip install 'fuzzynav[dask]'"
            ) from None
        self.scheduler = scheduler
        self._cluster = None
        if scheduler is None:
            self.workers = _check_workers(workers if workers is not None else available_cpus())
            # the LocalCluster's workers are spawned processes too
            check_main_guard("spawn", "a Dask LocalCluster")
            self._cluster = LocalCluster(
                n_workers=self.workers,
                threads_per_worker=1,
                processes=True,
                host="127.0.0.1",
                dashboard_address=None,
            )
            self.client = Client(self._cluster)
        else:
            self.client = _connect(Client, scheduler)
            threads = sum(self.client.nthreads().values())
            if threads == 0:
                self.client.close()
                raise ValueError(f"--scheduler {scheduler}: the cluster has no workers")
            # the cluster decides how many run at once; --workers only sizes the chunks
            self.workers = _check_workers(workers) if workers is not None else threads

    def _chunked(self, function, items, size, total):
        from distributed import as_completed

        # A bounded window of chunks in flight: submitting every chunk at once built a
        # future (and pickled its items) for each before the first result came back.
        chunks = _chunks(items, size)
        window = DASK_CHUNKS_IN_FLIGHT_PER_WORKER * self.workers
        submitted = []

        def submit(start, chunk):
            future = self.client.submit(_indexed_chunk, function, start, chunk, pure=False)
            submitted.append(future)
            return future

        pending = as_completed([submit(*c) for c in itertools.islice(chunks, window)])
        try:
            for future in pending:
                yield future.result()
                submitted.remove(future)
                following = next(chunks, None)
                if following is not None:
                    pending.add(submit(*following))
        finally:
            self.client.cancel(submitted)

    def describe(self):
        where = self.scheduler or "a LocalCluster on this machine"
        return f"dask ({where}), {self.workers} worker{'s' if self.workers != 1 else ''}"

    def close(self):
        if getattr(self, "client", None) is not None:
            self.client.close()
            self.client = None
        if self._cluster is not None:
            self._cluster.close()
            self._cluster = None


#: Chunks a Dask executor keeps submitted per worker: enough to keep every worker busy
#: while results travel back, few enough that a 100,000-layout sweep is never a
#: future per chunk before its first row.
DASK_CHUNKS_IN_FLIGHT_PER_WORKER = 4

#: The most worker processes (or, with a scheduler, chunks in flight per round) one
#: command asks for: each process holds ~100 MB, and 150 of them on a laptop are a
#: typing slip, not a plan.
MAX_WORKERS = 256


#: How long joining a cluster may take, handshake included: a server that accepts and
#: never answers hung for 40 s despite Dask's own 10 s timeout (it applies per attempt).
CONNECT_TIMEOUT_S = 10.0
#: The address forms --scheduler takes: plain TCP. (``tls://`` needs certificates this
#: command line has no options for; ``ucx://`` needs ucx-py; both gave TypeErrors.)
SCHEDULER_SCHEMES = ("tcp://",)


def check_scheduler_address(scheduler: str) -> str:
    """``scheduler`` if it is ``tcp://HOST:PORT`` (or ``HOST:PORT``), else ValueError
    with the address shown escaped."""
    from fuzzynav.resources import shorten

    shown = shorten(str(scheduler), 200)
    text = str(scheduler)
    if "://" in text and not text.startswith(SCHEDULER_SCHEMES):
        raise ValueError(
            f"--scheduler {shown}: only tcp://HOST:PORT addresses are supported "
            f"(not {shorten(text.split('://', 1)[0], 20)}://)"
        )
    rest = text.split("://", 1)[-1]
    host, sep, port = rest.rpartition(":")
    if not sep or not host or not port.isdigit() or not 0 < int(port) < 65536:
        raise ValueError(f"--scheduler {shown}: must be tcp://HOST:PORT (a port from 1 to 65535)")
    return text


def _connect(client_class, scheduler: str):
    """A client of the cluster at ``scheduler``, or ValueError within
    :data:`CONNECT_TIMEOUT_S` (plus a second): whatever the server does (refuses,
    answers garbage, never answers), one line, never a traceback or a hang."""
    import threading

    from fuzzynav.resources import shorten

    shown = shorten(str(check_scheduler_address(scheduler)), 200)
    outcome: dict = {}

    def connect():
        try:
            outcome["client"] = client_class(scheduler, timeout=f"{CONNECT_TIMEOUT_S:g}s")
        except BaseException as exc:  # noqa: BLE001 - reported in the caller's thread
            outcome["error"] = exc

    thread = threading.Thread(target=connect, name="fuzzynav-dask-connect", daemon=True)
    thread.start()
    thread.join(CONNECT_TIMEOUT_S + 1.0)
    if thread.is_alive():  # the thread is left to Dask's own timeouts; nothing waits on it
        raise ValueError(
            f"--scheduler {shown}: no answer within {CONNECT_TIMEOUT_S:g} s (is it a Dask "
            "scheduler?)"
        )
    if "error" in outcome:
        exc = outcome["error"]
        if isinstance(exc, KeyboardInterrupt):
            raise exc
        reason = shorten(f"{type(exc).__name__}: {exc}", 200)
        raise ValueError(f"--scheduler {shown}: cannot connect ({reason})") from None
    return outcome["client"]


def _check_workers(workers) -> int:
    if isinstance(workers, bool) or not isinstance(workers, int) or not 1 <= workers <= MAX_WORKERS:
        raise ValueError(f"workers = {workers!r}: must be an integer from 1 to {MAX_WORKERS}")
    return workers


def make_executor(
    kind: str = "local", workers: int | None = None, scheduler: str | None = None
) -> Executor:
    """An executor (module docstring). ``workers`` None: every CPU this process may use
    (for ``dask`` with a scheduler: the cluster's threads). ``scheduler`` only with
    ``dask``."""
    if kind not in EXECUTORS:
        raise ValueError(f"executor = {kind!r}: choose from {', '.join(EXECUTORS)}")
    if scheduler is not None and kind != "dask":
        raise ValueError(f"--scheduler {scheduler}: only with --executor dask")
    if kind == "serial":
        if workers is not None:
            _check_workers(workers)
        return SerialExecutor()
    if kind == "local":
        return LocalExecutor(workers)
    return DaskExecutor(workers, scheduler)


def add_executor_options(parser) -> None:
    """``--executor``, ``--workers`` and ``--scheduler`` on an argparse parser."""

    parser.add_argument(
        "--executor",
        choices=EXECUTORS,
        default="local",
        help="serial: this process; local: a process pool on this machine; dask: a Dask "
        "cluster (default local)",
    )
    parser.add_argument(
        "--workers",
        type=integer_in(1, MAX_WORKERS),
        metavar="N",
        help=f"worker processes (default: the CPUs this process may use, here "
        f"{available_cpus()}; with --scheduler: the cluster's)",
    )
    parser.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="with --executor dask: join this cluster, e.g. tcp://HOST:8786 (default: a "
        "LocalCluster of --workers processes on this machine)",
    )


def executor_from_args(args, jobs: int | None = None) -> Executor:
    """The executor the parsed ``--executor/--workers/--scheduler`` ask for; bad values
    are a UsageError (exit status 2). ``jobs``: how many items it will run; never more
    worker processes are started on this machine (``--workers 150 --n 1`` starts one)."""

    workers = args.workers
    if jobs is not None and args.scheduler is None and args.executor != "serial":
        workers = max(1, min(workers if workers is not None else available_cpus(), jobs))
    try:
        return make_executor(args.executor, workers, args.scheduler)
    except ValueError as exc:
        raise UsageError(str(exc)) from None

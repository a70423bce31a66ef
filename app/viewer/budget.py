"""What a browser can make the viewer's server hold, bounded and counted together.

One :class:`MemoryBudget` per server (a classroom's tabs share their server's): the
2 GiB of :data:`world.simulation.MEMORY_BUDGET_BYTES`, the budget an uploaded
scenario's run is checked against. Each world has an :class:`Account` in it, and what
a tab can make its world keep is charged there as it is kept:

- uploads under way: each charged its declared size from its first message until it
  ends, is refused or times out; at most :data:`MAX_UPLOADS_IN_FLIGHT` per tab (per
  server without ``--classroom``), dropped :data:`UPLOAD_TIMEOUT_S` after they began
  (:mod:`.guards`);
- uploaded scenarios kept for the dropdown: the last :data:`MAX_KEPT_SCENARIOS` of a
  world, the oldest dropped (never the one loaded), each charged
  :data:`KEPT_SCENARIO_BYTES` plus :data:`KEPT_OBSTACLE_BYTES` per obstacle;
- obstacles added by "Obstacle: Add": a layout of at most :data:`MAX_LAYOUT_OBSTACLES`
  (and no more than keeps the run's log in its budget), each added one charged
  :data:`ADDED_OBSTACLE_BYTES`;
- the run's history for the time slider: at most :data:`HISTORY_BYTES` a world, thinned
  (every other step dropped, the stride doubled) when it would pass it
  (:class:`.history.StepHistory`).

A charge the server's budget cannot take is refused: an upload or an Add with a
message, the history thinned instead. ``serve --rrd``'s disk: :class:`RecordingBudget`.
"""

from __future__ import annotations

import collections
import threading
import time

from fuzzynav.world.simulation import MEMORY_BUDGET_BYTES

#: The most one server holds for what its tabs send and make (the sum of its accounts).
SERVER_BUDGET_BYTES = MEMORY_BUDGET_BYTES
#: Uploads under way at once, per tab (per server without ``--classroom``).
MAX_UPLOADS_IN_FLIGHT = 4
#: An upload not whole this long after its first message is dropped (512 KiB takes
#: well under a second on a school's network).
UPLOAD_TIMEOUT_S = 30.0
#: Uploaded scenarios a world keeps for its dropdown (the oldest goes first).
MAX_KEPT_SCENARIOS = 8
#: What a kept scenario is charged: a fixed part and a part per obstacle (measured:
#: 0.3 kB per obstacle, `tests/test_viewer_budget.py`).
KEPT_SCENARIO_BYTES = 16 * 1024
KEPT_OBSTACLE_BYTES = 1024
#: The most obstacles "Obstacle: Add" builds a layout up to (a scenario file may bring
#: more, up to world.scenario's 1000: Add then adds none). A step among 200 takes about
#: 4 ms on one core, a fifth of the 20 ms control period.
MAX_LAYOUT_OBSTACLES = 200
#: What an added obstacle is charged (its body, its scene nodes, its handle; measured
#: about 15 kB without a tab, `bench/bench_viewer_budget.py`).
ADDED_OBSTACLE_BYTES = 64 * 1024
#: The run's history (the time slider, the rule strip) of one world.
HISTORY_BYTES = 32 * 1024**2


class MemoryBudget:
    """The bytes a server's tabs have made it keep, against ``total`` (thread-safe)."""

    def __init__(self, total: int = SERVER_BUDGET_BYTES):
        self.total = int(total)
        self._lock = threading.Lock()
        self._used = 0

    @property
    def used(self) -> int:
        with self._lock:
            return self._used

    def _change(self, kind: str, delta: int, force: bool = False) -> bool:
        with self._lock:
            if delta > 0 and self._used + delta > self.total and not force:
                return False
            self._used += delta
            return True

    def account(self) -> Account:
        """A world's account in this budget."""
        return Account(self)


class Account:
    """One world's charges in a :class:`MemoryBudget`, by kind; :meth:`close` gives
    them all back (the tab closed, the server stopped)."""

    def __init__(self, budget: MemoryBudget):
        self.budget = budget
        self._lock = threading.Lock()
        self._held: collections.Counter = collections.Counter()

    def held(self, kind: str | None = None) -> int:
        with self._lock:
            return sum(self._held.values()) if kind is None else self._held[kind]

    def resize(self, kind: str, nbytes: int, force: bool = False) -> bool:
        """Hold ``nbytes`` for ``kind`` (more or less than now); False, and the charge
        as it was, when the server's budget cannot take the increase (``force``: what
        is held already, counted even so)."""
        nbytes = max(0, int(nbytes))
        with self._lock:
            delta = nbytes - self._held[kind]
            if not self.budget._change(kind, delta, force):
                return False
            self._held[kind] = nbytes
            return True

    def take(self, kind: str, nbytes: int) -> bool:
        with self._lock:
            held = self._held[kind]
        return self.resize(kind, held + nbytes)

    def give(self, kind: str, nbytes: int) -> None:
        with self._lock:
            nbytes = min(int(nbytes), self._held[kind])
            self.budget._change(kind, -nbytes)
            self._held[kind] -= nbytes

    def close(self) -> None:
        with self._lock:
            for kind, nbytes in self._held.items():
                self.budget._change(kind, -nbytes)
            self._held.clear()


def scenario_charge(scenario) -> int:
    """What keeping ``scenario`` for the dropdown is charged."""
    return KEPT_SCENARIO_BYTES + KEPT_OBSTACLE_BYTES * len(scenario.obstacles)


# -- serve --rrd: the disk ---------------------------------------------------------------

#: Recordings ``serve --rrd`` starts in any minute at most: a run beyond them is not
#: recorded, and the page says so (a Step then a Reset wrote a 747 kB file each time:
#: 150 presses, 112 MB in 14 s).
RRD_RUNS_PER_MINUTE = 6
#: The most one ``serve --rrd`` session writes: the run being recorded when it is
#: reached is completed there, and no later run is recorded.
RRD_SESSION_BYTES = 2 * 1024**3


class RecordingBudget:
    """How many recordings ``serve --rrd`` has started lately and what they wrote."""

    def __init__(
        self,
        runs_per_minute: int = RRD_RUNS_PER_MINUTE,
        session_bytes: int = RRD_SESSION_BYTES,
        clock=time.monotonic,
    ):
        self.runs_per_minute = int(runs_per_minute)
        self.session_bytes = int(session_bytes)
        self.clock = clock
        self.starts: collections.deque = collections.deque()
        self.written = 0  # bytes of the recordings completed

    def _forget_old(self) -> None:
        now = self.clock()
        while self.starts and now - self.starts[0] >= 60.0:
            self.starts.popleft()

    def why_not(self) -> str | None:
        """Why a new recording may not start now (None: it may)."""
        if self.written >= self.session_bytes:
            return (
                f"this session's recordings have reached {_size(self.session_bytes)}, the "
                "most serve --rrd writes; restart the viewer to record more"
            )
        self._forget_old()
        if len(self.starts) >= self.runs_per_minute:
            wait = 60.0 - (self.clock() - self.starts[0])
            return (
                f"at most {self.runs_per_minute} runs a minute are recorded; this run is "
                f"not (the next run started in {max(1, round(wait))} s or later is)"
            )
        return None

    def started(self) -> None:
        self.starts.append(self.clock())

    def full(self, current_bytes: int) -> bool:
        return self.written + current_bytes >= self.session_bytes


def _size(nbytes: float) -> str:
    return f"{nbytes / 1024**3:g} GiB" if nbytes >= 1024**3 else f"{nbytes / 1024**2:g} MiB"

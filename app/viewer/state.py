"""The app model's vocabulary: its limits, :class:`ViewerError`, the controller wrapper
that records each call, the plots' ring buffer, and the records it hands out (a
:class:`Snapshot` per frame, the previous run's :class:`Ghost`, a :class:`HistoryStep`
per control step). No behaviour of the app is here (:mod:`.model`)."""

from __future__ import annotations

import math
import re
import time
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from fuzzynav.world.scenario import Disturbance

SPEED_RANGE = (0.1, 10.0)
NOISE_RANGE_M = (0.0, 0.3)
MAX_UPLOAD_BYTES = 512 * 1024
PLOT_WINDOW_S = 30.0
SAFE_DISTANCE_M = 0.25
# A scenario without a disturbance of its own gets the paper's sin(2t) (amplitude 1)
# for as long as the disturbance switch is on.
DEFAULT_DISTURBANCE = Disturbance(
    amplitude=1.0, angular_frequency_rad_s=2.0, start_s=0.0, stop_s=math.inf
)
NEW_OBSTACLE_RADIUS_M = 0.25
UPLOADED_PREFIX = "uploaded: "
EDITED_LABEL = "paper (edited)"


class ViewerError(ValueError):
    """A user action that cannot be done; the message is shown in the page."""


def safe_display_name(name: str, default: str = "upload") -> str:
    """A browser-sent file name reduced to something safe to *show* (never to open)."""
    base = re.split(r"[\\/]", str(name or ""))[-1]
    base = re.sub(r"[^A-Za-z0-9._ -]", "_", base).strip(" .")
    return (base or default)[:60]


class _ObservedController:
    """Wraps the controller: records what it was given and what it answered.

    The simulation sees the wrapped controller's attributes (``needs_ranges``, ``fis``,
    ...) through ``__getattr__``. The recorded wall-clock time of each call is what the
    drag-latency benchmark measures against.
    """

    def __init__(self, inner, on_call=None, name: str = ""):
        self.inner = inner
        self.name = name  # what recordings call the controller
        self.on_call = on_call
        self.last_inputs = np.full(4, np.nan)
        self.last_output = np.full(2, np.nan)
        self.last_call_wall_s = 0.0

    def reset(self):
        self.inner.reset()

    def __call__(self, inputs, **kwargs):
        out = self.inner(inputs, **kwargs)
        self.last_inputs = np.array(inputs, dtype=float)
        self.last_output = np.asarray(out, dtype=float).reshape(2)
        self.last_call_wall_s = time.perf_counter()
        if self.on_call is not None:
            self.on_call(self.last_inputs, self.last_call_wall_s)
        return out

    def __getattr__(self, name):
        # Only reached for attributes this wrapper lacks (fis, needs_ranges, name, ...).
        return getattr(self.inner, name)


class _Ring:
    """Fixed-capacity ring of rows (time plus values) for the live plots."""

    def __init__(self, capacity: int, width: int):
        self.data = np.full((capacity, width), np.nan)
        self.n = 0
        self.capacity = capacity

    def append(self, row) -> None:
        self.data[self.n % self.capacity] = row
        self.n += 1

    def clear(self) -> None:
        self.n = 0

    def ordered(self) -> np.ndarray:
        if self.n <= self.capacity:
            return self.data[: self.n].copy()
        k = self.n % self.capacity
        return np.concatenate([self.data[k:], self.data[:k]])


class _Trail:
    """The run's trail, (x, y) points in a float64 array grown by doubling (16 bytes a
    point, a point every 2 cm driven; a list of tuples took 120)."""

    def __init__(self, first):
        self.data = np.empty((256, 2))
        self.data[0] = tuple(first)[:2]
        self.n = 1

    def append(self, xy) -> None:
        if self.n == len(self.data):
            self.data = np.concatenate([self.data, np.empty_like(self.data)])
        self.data[self.n] = xy
        self.n += 1

    def __len__(self) -> int:
        return self.n

    def __getitem__(self, k):
        return self.data[: self.n][k]

    def __array__(self, dtype=None, copy=None):
        return np.array(self.data[: self.n], dtype=dtype)


@dataclass
class ObstacleView:
    id: int
    xy: tuple[float, float]
    radius_m: float
    is_static: bool
    velocity: tuple[float, float]


@dataclass
class Ghost:
    """The previous run, kept on screen when the next starts: its trail, what drove it
    (scenario, controller, perception, parts) and its metrics."""

    trail: np.ndarray
    label: str
    metrics: dict


@dataclass(slots=True)
class HistoryStep:
    """A control step as the time slider shows it again."""

    time_s: float
    pose: tuple
    input_pose: tuple
    inputs: np.ndarray
    output: np.ndarray
    target: tuple
    obstacles: Mapping  # id -> (x, y) (history.ObstaclePositions)
    block: tuple | None = None  # fuzzynav: (what its blocks were fed, its crisp parts)


@dataclass
class Snapshot:
    """What the scene needs to draw one frame (copied under the lock)."""

    version: int
    run_id: int
    layout_id: int
    time_s: float
    playing: bool
    speed: float
    outcome: str | None
    pose: tuple[float, float, float]
    footprint_m: tuple[float, float]
    target: tuple[float, float]
    tolerance_m: float
    obstacles: list[ObstacleView]
    beams: list[tuple[tuple[float, float], float]]  # (origin, direction) per sensor
    ranges_m: np.ndarray
    beam_width_rad: float
    max_range_m: float
    inputs: np.ndarray
    voltages_v: np.ndarray
    nearest_clearance_m: float
    scenario_label: str
    controller_label: str
    perception: str
    geometry: str
    disturbance_on: bool
    noise_std_m: float
    message: str
    message_level: str
    layout_edited: bool = False
    metrics: dict | None = None
    # A controller that shows its memory (fuzzynav): remembered echoes (world frame, as
    # the robot places them) and the bearing it steers to (world frame, rad).
    memory_xy: np.ndarray | None = None
    steer_heading_rad: float = math.nan
    # fuzzynav's parts switched off (assets/rules/fuzzynav_parts.toml), and whether the
    # controller driving has such parts at all.
    parts_off: tuple[str, ...] = ()
    has_parts: bool = False
    # Ideal perception senses obstacles whose centre bears within this angle, centred
    # on the heading (the scenario's robot.field_of_view_deg; 2 pi: all around).
    field_of_view_rad: float = 2.0 * math.pi
    ghost: Ghost | None = None
    ghost_id: int = 0
    run_label: str = ""
    # The disturbance switched on (in words, "" when off), and whether it was added to
    # the inputs the controller was last given (inside its time window).
    disturbance_text: str = ""
    inputs_disturbed: bool = False
    obstacle_numbers: dict = field(default_factory=dict)  # id -> the number shown
    what_if: np.ndarray | None = None  # the inputs tried in what-if mode, or None
    input_pose: tuple | None = None  # the pose the inputs were read at
    history: bool = False  # showing a recorded step (the time slider), not the live world
    history_span: tuple = (0.0, 0.0)  # the recorded times of this run

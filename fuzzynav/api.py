"""fuzzynav's Python interface: what a notebook or a script calls.

The command line is a layer over the same functions (``fuzzynav run`` builds its
simulation with :func:`fuzzynav.app.runs.build_simulation`, as :func:`simulate` does),
so a run made here and the same run made from the shell give the same numbers.

Everything is reached from the package itself, imported on first use so that
``fuzzynav --version`` stays fast::

    >>> import fuzzynav
    >>> run = fuzzynav.simulate("s1")
    >>> run.outcome
    'reached'
    >>> run.trace["x_m"][-1]  # doctest: +SKIP
    9.86...

Functions
---------
simulate        one run of a scenario; a :class:`Run`
sweep           seeded random layouts, or your scenarios; one row (a dict) per run
summarize       what ``fuzzynav sweep`` prints of a sweep's rows (and returns it)
evaluate        a population of controllers on many layouts, batched (candidates x layouts)
serve           the viewer, in this process
tune            a controller's design numbers against a cost of your own (CMA-ES)
DesignSearch    tune's CMA-ES as ask/tell, for a loop of your own (with ``evaluate``)
load_scenario   a shipped scenario by name (``"s1"``) or a scenario TOML file
make_controller a controller by name (``"paper"``, ``"fuzzynav"``, ...) or a ``.fis`` file
register_controller  offer a controller of your own everywhere (``--controller``, sweeps, the viewer)
check_controller     check an object against the controller interface; its capabilities
read_fis        a MATLAB ``.fis`` file as a :class:`~fuzzynav.controller.fuzzy.FuzzySystem`
write_fis       a fuzzy system to a ``.fis`` file (written whole or not at all)
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import numpy as np
import numpy.typing as npt

from fuzzynav.app.experiments.search import DesignSearch, tune
from fuzzynav.controller.checker import ControllerCheckError, check_controller
from fuzzynav.controller.fis import dumps_fis
from fuzzynav.controller.fis import read_fis as _read_fis
from fuzzynav.controller.fuzzy import FuzzySystem
from fuzzynav.controller.interface import Controller, ControllerFunction
from fuzzynav.controller.registry import make_controller as _make_controller
from fuzzynav.controller.registry import register_controller
from fuzzynav.evaluation import Evaluation, evaluate
from fuzzynav.sweeps import SweepInterrupted, SweepRow, summarize, sweep
from fuzzynav.world.run_limits import OUTCOMES, Outcome
from fuzzynav.world.scenario import Scenario
from fuzzynav.world.scenario import load_scenario as _load_scenario
from fuzzynav.world.sim_log import SimulationLog
from fuzzynav.world.simulation import Simulation, SimulationResult

if TYPE_CHECKING:
    from fuzzynav.app.viewer.classroom import ClassroomServer
    from fuzzynav.app.viewer.server import ViewerServer

__all__ = [
    "Outcome",
    "SweepRow",
    "Run",
    "simulate",
    "sweep",
    "summarize",
    "SweepInterrupted",
    "evaluate",
    "Evaluation",
    "serve",
    "tune",
    "DesignSearch",
    "load_scenario",
    "make_controller",
    "register_controller",
    "check_controller",
    "ControllerCheckError",
    "read_fis",
    "write_fis",
]


class Run:
    """One finished run: what ``fuzzynav run`` prints, traces and records, as Python
    objects.

    Attributes
    ----------
    outcome : str
        ``"reached"``, ``"collided"`` or ``"timeout"``.
    metrics : dict
        The fields of ``fuzzynav run --json`` but its ``wall_time_s``: path_length_m,
        mad_m, rmse_m, min_clearance_m, time_to_target_s, ... (SI units in the names; a
        number that does not apply, e.g. the time to target of a run that never arrived,
        is None, as in sweep's rows and the JSON files: NaN only in numpy arrays).
        The same run gives the same metrics on any machine.
    timing : dict
        ``wall_time_s``: the wall-clock seconds the run took here.
    trace : dict of str to numpy.ndarray
        One array per column of ``fuzzynav run --trace`` (``time_s``, ``x_m``, ``y_m``,
        ``heading_rad``, the four controller inputs, the voltages, ...), one element per
        control step; NaN where the CSV has an empty cell (nothing sensed, or no command
        after the final state).
    result : fuzzynav.world.simulation.SimulationResult
        The simulation's own result (the full log, the scenario).
    controller : object
        The controller that drove (its ``fis`` attribute is the fuzzy system, for the
        fuzzy controllers).
    """

    def __init__(
        self,
        simulation: Simulation,
        result: SimulationResult,
        controller_label: str,
        scenario_label: str,
    ) -> None:
        self._simulation = simulation
        self.result = result
        self.controller = simulation.controller
        self._controller_label = controller_label
        self._scenario_label = scenario_label
        self._trace: dict[str, npt.NDArray[np.float64]] | None = None

    @property
    def outcome(self) -> Outcome:
        """How the run ended (one of ``world.run_limits.OUTCOMES``)."""
        outcome = self.result.outcome
        if outcome not in OUTCOMES:  # a finished run ends one of these ways
            raise RuntimeError(f"the run has not ended (outcome {outcome!r})")
        return outcome  # narrowed to Outcome by the test against OUTCOMES

    @property
    def metrics(self) -> dict[str, Any]:  # numbers, and the labels and outcome as text
        from fuzzynav.app.runs import summary

        # None for a number that does not apply, as in sweep's rows and ``run --json``;
        # the wall-clock time is no property of the run (it is in ``timing``)
        row = summary(self.result, self._controller_label, self._scenario_label)
        row.pop("wall_time_s", None)
        return row

    @property
    def timing(self) -> dict[str, float]:
        """How long the run took on this machine: ``wall_time_s``, the seconds spent in
        its steps (varies from run to run; not a metric of the run)."""
        return {"wall_time_s": float(self.result.wall_time_s)}

    @property
    def trace(self) -> dict[str, npt.NDArray[np.float64]]:
        if self._trace is None:
            # The CSV's own rows, read back: the arrays are the trace file's columns,
            # whatever columns it has, and equal to it (the cells are exact reprs).
            from fuzzynav.app.recordings.trace import TRACE_COLUMNS
            from fuzzynav.app.recordings.trace import trace_rows as untyped_trace_rows

            # app.recordings.trace is not annotated: its rows are lists of strings
            trace_rows = cast("Callable[[SimulationLog], Iterator[list[str]]]", untyped_trace_rows)
            # Streamed into the columns, a row at a time (a list of every row's
            # strings first took 1.3 GB beside 86 MB of arrays at 720,000 steps).
            n_rows = len(self.result.log)
            columns = np.empty((len(TRACE_COLUMNS), n_rows))
            k = -1
            for k, row in enumerate(trace_rows(self.result.log)):
                columns[:, k] = [float(cell) if cell != "" else math.nan for cell in row]
            if k + 1 != n_rows:  # one row per logged step: anything else is a bug
                raise RuntimeError(f"the trace has {k + 1} rows for {n_rows} logged steps")
            self._trace = dict(zip(TRACE_COLUMNS, columns))
        return self._trace

    def save_rrd(self, path: str | Path) -> Path:
        """Write the run as a rerun recording (``rerun PATH`` opens it), whole or not
        at all. Returns the path written."""
        from fuzzynav.app.recordings.record import record_simulation
        from fuzzynav.safe_files import check_output_path

        # the one output guard: never into the installed package, never over the run's
        # own scenario or rule base file
        check_output_path(path, "save_rrd: path", self._inputs())
        return record_simulation(
            self._simulation,
            self.result,
            path,
            extra_metadata={"made by": "fuzzynav.simulate (Python)"},
        )

    def figures(self, folder: str | Path, overwrite: bool = False) -> list[Path]:
        """Write the paper's figures of the run (PNG and SVG) into ``folder`` (created
        if needed), as ``fuzzynav run --figures`` does. A file of the same name already
        there is never replaced (ValueError naming it, before any figure is written)
        unless ``overwrite``. Returns the files written."""
        from fuzzynav.app.figures.run_figures import write_run_figures
        from fuzzynav.app.figures.style import check_writable_dir
        from fuzzynav.safe_files import OutputScope

        check_writable_dir(folder, option="figures: folder")  # the one output guard within
        sim = self._simulation
        params = sim.model.parameters
        remedy = "pass overwrite=True to replace it, or another folder"
        with OutputScope("figures: folder", overwrite=overwrite, remedy=remedy):
            return write_run_figures(
                self.result,
                folder,
                controller=sim.controller,
                footprint_m=(params.footprint_length_m, params.footprint_width_m),
                voltage_limit_v=sim.voltage_limit_v,
            )

    def to_dataframe(self) -> Any:  # a pandas.DataFrame (pandas is an optional extra)
        """The run as a pandas DataFrame, one row per control step: the columns of
        :attr:`trace` (``time_s``, ``x_m``, ``y_m``, ``heading_rad``, the inputs, the
        voltages...), then ``obstacle_K_x_m`` and ``obstacle_K_y_m`` for each obstacle
        ``K`` (0, 1, ... in the scenario's order): where it was at that step, a moving
        one's path over time; NaN while an obstacle is absent (before it appears, after
        it leaves). Needs pandas (``pip install "fuzzynav[pandas]"``)."""
        try:
            import pandas as pd
        except ImportError:
            raise ImportError(
                'Run.to_dataframe needs pandas: pip install "fuzzynav[pandas]"'
            ) from None
        columns: dict[str, npt.NDArray[np.float64]] = dict(self.trace)
        obstacle_xy = np.asarray(self.result.log.obstacle_xy, dtype=float)
        for k in range(obstacle_xy.shape[1]):
            columns[f"obstacle_{k}_x_m"] = obstacle_xy[:, k, 0]
            columns[f"obstacle_{k}_y_m"] = obstacle_xy[:, k, 1]
        return pd.DataFrame(columns)

    def _inputs(self) -> list[Path]:
        """The files this run read (its scenario's, a ``.fis`` or rule base file): no
        output may replace them."""
        found = []
        for source in (
            getattr(self.result.scenario, "source", None),
            getattr(self.controller, "source", None),
        ):
            if isinstance(source, str | Path) and str(source) not in ("", "<memory>"):
                found.append(Path(source))
        return found

    def __repr__(self) -> str:
        m = self.result.metrics
        return (
            f"<fuzzynav.Run {self._scenario_label} · {self._controller_label}: {self.outcome}, "
            f"path {m['path_length_m']:.2f} m, {len(self.result.log)} steps>"
        )


def _label_of_scenario(scenario: str | Path | Scenario) -> str:
    if isinstance(scenario, Scenario):
        return scenario.name
    from fuzzynav.world.scenario import resolve_scenario_path

    path = resolve_scenario_path(scenario)
    return path.stem if path.parent.name == "scenarios" and path.exists() else str(scenario)


def simulate(
    scenario: str | Path | Scenario,
    controller: str | Controller | ControllerFunction = "paper",
    perception: str = "ideal",
    geometry: str = "husky",
    seed: int | None = None,
    *,
    control_period_s: float = 0.02,
    sensor_noise_std_m: float = 0.0,
    fis: str | Path | FuzzySystem | None = None,
    field_of_view_deg: float | None = None,
    sonar_side_deg: float | None = None,
) -> Run:
    """Run one scenario to its end (target reached, collision or time out).

    Parameters
    ----------
    scenario : str, Path or Scenario
        A shipped scenario's name (``"s1"``, ``"s2"``, ``"s3"``, ``"crossing"``, ...), the
        path of a scenario TOML file, or a :class:`~fuzzynav.world.scenario.Scenario`.
    controller : str, controller object or function
        A controller's name (``"paper"``, ``"fuzzynav"``, ``"baseline"``, ``"p"``; see
        ``fuzzynav run --help``; or ``"module:factory"``), a controller object, e.g.
        from :func:`make_controller` with a membership function swapped, or one plain
        function, ``f(inputs (4,)) -> (left, right)`` or vectorised ``f(inputs (n, 4))
        -> (n, 2)`` (:mod:`fuzzynav.controller.function`).
    perception : {"ideal", "ultrasonic"}
        ``ideal``: the exact nearest obstacle; ``ultrasonic``: the three range sensors.
    geometry : {"husky", "paper"}
        ``husky``: the real 0.99 m x 0.67 m footprint; ``paper``: the paper's point robot
        (inputs centre to centre, Eqs. 7-12; ideal perception only).
    seed : int or None
        Seeds the sensor noise. None means 0, the command line's default, so that
        ``simulate("s1")`` is ``fuzzynav run s1``.
    control_period_s : float
        The controller's period in seconds (default 0.02 s).
    sensor_noise_std_m : float
        The sonars' noise standard deviation in metres (default 0).
    fis : str, Path or FuzzySystem, optional
        Drive with this fuzzy system instead (4 inputs, 2 outputs), as ``--fis``.
    field_of_view_deg : float, optional
        Ideal perception senses obstacles whose centre bears within +- half of it, in
        place of the scenario's (s1-s3: 180, the front half-plane); as ``--field-of-view``.
    sonar_side_deg : float, optional
        Mount the side sonars at +- this angle (default 45); as ``--sonar-side``.

    Returns
    -------
    Run

    Raises
    ------
    ValueError
        An unknown scenario, controller, perception or geometry, or a value out of range
        (the message names it).
    """
    from fuzzynav.app.runs import build_simulation
    from fuzzynav.controller.fis_controller import FisController

    if seed is None:
        seed = 0
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise ValueError(f"seed = {seed!r}: must be an integer >= 0")
    controller_object: object | None = None
    label = controller
    if isinstance(fis, FuzzySystem):
        controller_object, label = FisController(fis, name=fis.name), fis.name
        fis = None
    elif fis is not None:
        label = Path(fis).name
    elif not isinstance(controller, str):
        from fuzzynav.controller.function import as_controller
        from fuzzynav.world.perception import check_controller

        controller = as_controller(controller)  # a plain function is a controller too
        check_controller(controller)  # the loop's own check, before anything is built
        controller_object = controller  # any controller
        label = getattr(controller, "name", type(controller).__name__)
    sim = build_simulation(
        scenario,
        controller if isinstance(controller, str) else "paper",
        perception=perception,
        seed=int(seed),
        fis_path=fis,
        control_period_s=control_period_s,
        sensor_noise_std_m=sensor_noise_std_m,
        controller_object=controller_object,
        geometry=geometry,
        field_of_view_deg=field_of_view_deg,
        sonar_side_deg=sonar_side_deg,
    )
    result = sim.run()
    return Run(sim, result, str(label), _label_of_scenario(scenario))


def serve(
    scenario: str | Path | Scenario = "s1",
    controller: str | None = None,
    *,
    host: str = "127.0.0.1",
    port: int = 8080,
    rrd: str | Path | None = None,
    geometry: str = "husky",
    classroom: bool = False,
    lesson: str | Path | None = None,
    block: bool = True,
    open_message: bool = True,
) -> ViewerServer | ClassroomServer | None:
    """The viewer in this process (``fuzzynav serve``): it offers every registered
    controller, a controller of your own included.

    Parameters
    ----------
    scenario : str, Path or Scenario
        As :func:`simulate`.
    controller : str, optional
        The registered name it starts with (default ``paper``).
    host, port : str, int
        Where it listens (default 127.0.0.1:8080; port 0: any free port).
    rrd : str or Path, optional
        Record every run to this rerun file (``--rrd``).
    geometry : {"husky", "paper"}
        As :func:`simulate`.
    classroom : bool
        A world per browser tab (``--classroom``).
    lesson : str or Path, optional
        A lesson file (``--lesson``).
    block : bool
        Serve until Ctrl-C (default); False returns the running server, whose
        ``stop()`` ends it.
    open_message : bool
        Print the address to open.

    Returns
    -------
    object
        The running server when ``block`` is False; else None, after Ctrl-C.
    """
    from fuzzynav.app.viewer.serve import serve as serve_viewer
    from fuzzynav.safe_files import as_path

    switches = {"block": block, "classroom": classroom, "open_message": open_message}
    for name, value in switches.items():
        if not isinstance(value, bool):  # "no" is true: block="no" served for ever
            raise TypeError(f"{name} = {value!r}: must be True or False")
    if lesson is not None:
        lesson = as_path(lesson, "lesson")
    server = serve_viewer(
        scenario,
        host=host,
        port=port,
        rrd=rrd,
        controller=controller,
        open_message=open_message,
        block=block,
        geometry=geometry,
        classroom=classroom,
        lesson=lesson,
    )
    # app.viewer.serve.serve is not annotated: it returns one of these, or None
    return cast("ViewerServer | ClassroomServer | None", server)


def load_scenario(name_or_path: str | Path) -> Scenario:
    """A scenario by shipped name or by the path of a scenario TOML file, validated.

    Parameters
    ----------
    name_or_path : str or Path
        A shipped scenario's name (``"s1"``) or the path of a scenario TOML file.

    Returns
    -------
    Scenario
        Unknown keys, overlaps and out-of-range values are refused with the file, key
        and value named (:class:`~fuzzynav.world.scenario.ScenarioError`).
    """
    return _load_scenario(name_or_path)


def make_controller(
    name: str = "paper", *, fis: str | Path | None = None, geometry: str = "husky"
) -> Controller:
    """A fresh controller, by name or from a MATLAB ``.fis`` file.

    Parameters
    ----------
    name : str
        ``"paper"``, ``"fuzzynav"``, ``"baseline"`` or ``"p"``.
    fis : str or Path, optional
        A MATLAB ``.fis`` file: a fuzzy controller of it instead of ``name``.
    geometry : {"husky", "paper"}
        Which of the paper controller's rule bases: its Husky twin (``rules/paper_husky.toml``)
        or the paper's own fit (``rules/paper.toml``).

    Returns
    -------
    Controller
        Typed as the interface (:class:`fuzzynav.controller.interface.Controller`); the
        fuzzy controllers are also
        :class:`~fuzzynav.controller.interface.FuzzyController` s, whose ``.fis`` is
        their system. Give the controller to :func:`simulate`.
    """
    return _make_controller(name, fis, geometry=geometry)


def read_fis(path: str | Path) -> FuzzySystem:
    """A MATLAB Fuzzy Logic Toolbox ``.fis`` file, parsed (never evaluated).

    Parameters
    ----------
    path : str or Path
        The ``.fis`` file.

    Returns
    -------
    FuzzySystem
    """
    from fuzzynav.safe_files import as_path

    return _read_fis(as_path(path, "read_fis: path"))


def write_fis(system: FuzzySystem, path: str | Path) -> Path:
    """Write ``system`` as a MATLAB ``.fis`` file (GNU Octave reads it as the same system).

    Parameters
    ----------
    system : FuzzySystem
        The system; one that reads NONE as "sensed nothing" (``unsensed_none``) is
        refused, since a .fis cannot say it.
    path : str or Path
        Where; a path inside the installed package (its shipped rule bases) is refused
        (ValueError), as ``fuzzynav fis export`` refuses it.

    Returns
    -------
    Path
        The path written.
    """
    from fuzzynav.safe_files import check_output_path, write_text_atomically

    if not isinstance(system, FuzzySystem):
        raise TypeError(f"write_fis: system = {type(system).__name__}: not a FuzzySystem")
    check_output_path(path, "write_fis: path")  # never into the installed package
    return write_text_atomically(path, dumps_fis(system))

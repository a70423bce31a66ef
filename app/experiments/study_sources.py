"""What a study runs besides a family's layouts and a registered controller's name.

A study's jobs (:class:`~fuzzynav.app.experiments.studies.LayoutJob`) name what they
run: a family, a seed and an index; a controller's name. :func:`scenario_set_jobs`
makes jobs of any scenarios (a scenario file, a folder of them, a list of
:class:`~fuzzynav.world.scenario.Scenario`) and of any controller object, each job
carrying its scenario and controller with it, so that it runs the same on any executor
(the objects are pickled to worker processes as the jobs are).

Rows stay identified by what made them: the family of a scenario set is ``set:`` and
the digest of the scenarios' TOML, and a controller object is labelled by its name and
the digest of its pickled state, so that ``resume`` never mixes rows of another set or
of a controller with other parameters.
"""

from __future__ import annotations

import hashlib
import pickle
from collections.abc import Iterable, Mapping
from pathlib import Path

from fuzzynav.resources import shorten
from fuzzynav.world.scenario import Scenario

__all__ = ["scenario_list", "controller_label", "scenario_set_jobs", "SET_PREFIX"]

#: The family of a scenario set's rows: ``set:`` and 16 hex digits of its digest.
SET_PREFIX = "set:"
#: The most scenario files a folder may hold for one study.
MAX_SCENARIO_FILES = 10_000


def scenario_list(scenarios, footprint_m=None) -> list[Scenario]:
    """Scenarios from a file, a folder of ``*.toml`` files, a shipped name, or a list.

    Parameters
    ----------
    scenarios : str, Path, Scenario or iterable of them
        A scenario TOML file, a folder (its ``*.toml`` files in name order), a shipped
        scenario's name (``"s1"``), a :class:`Scenario`, or a list of any of these.
    footprint_m : tuple of float, optional
        The robot's footprint each file's start is checked against (default the
        Husky's).

    Returns
    -------
    list of Scenario
        Each validated as a file is (:meth:`Scenario.validate` for objects).

    Raises
    ------
    ValueError
        An empty folder or list, a file that does not load (the message names it),
        something that is not a scenario.
    """
    from fuzzynav.world.scenario import load_scenario

    kwargs = {} if footprint_m is None else {"footprint_m": footprint_m}
    if isinstance(scenarios, Scenario | str | Path):
        scenarios = [scenarios]
    if not isinstance(scenarios, Iterable) or isinstance(scenarios, bytes | Mapping):
        raise ValueError(
            f"scenarios = {shorten(repr(scenarios), 80)}: not a scenario, file, folder or "
            "shipped name, nor a list of them"
        )
    out: list[Scenario] = []
    for item in scenarios:
        if isinstance(item, Scenario):
            out.append(_validated(item, kwargs))
        elif isinstance(item, Path | str) and Path(item).is_dir():
            files = sorted(Path(item).glob("*.toml"))
            if not files:
                raise ValueError(f"{item}: a folder with no scenario (*.toml) files")
            if len(files) > MAX_SCENARIO_FILES:
                raise ValueError(f"{item}: {len(files)} files (at most {MAX_SCENARIO_FILES})")
            out += [load_scenario(f, **kwargs) for f in files]
        elif isinstance(item, Path | str):
            out.append(load_scenario(item, **kwargs))
        else:
            raise ValueError(f"scenarios: {type(item).__name__} is not a scenario, file or folder")
    if not out:
        raise ValueError("scenarios: none given")
    return out


def _validated(scenario: Scenario, kwargs: dict) -> Scenario:
    from fuzzynav.world.scenario import check_scenario

    check_scenario(scenario, **kwargs)  # a Scenario built in code is checked as a file is
    return scenario


def _digest(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()[:16]


def controller_label(controller: object) -> str:
    """A row's name for a controller object: its name and the digest of its state.

    Parameters
    ----------
    controller : object
        A controller (:mod:`controller.interface`).

    Raises
    ------
    ValueError
        The object cannot be pickled (its state cannot be named, nor sent to a
        worker): give it as a registered name or ``"module:factory"`` instead.
    """
    name = getattr(controller, "name", None)
    name = name if isinstance(name, str) and name else type(controller).__name__
    try:
        state = pickle.dumps(controller, protocol=4)
    except Exception as exc:  # noqa: BLE001 - pickling fails in many ways; all say one thing
        raise ValueError(
            f"controller {name!r}: cannot be pickled ({exc}); a study sends its controller "
            "to every run: register it (fuzzynav.register_controller) or give "
            "'module:factory'"
        ) from None
    return f"{name[:40]}@{_digest(state)}"


def scenario_set_jobs(
    scenarios: Iterable[Scenario],
    controller,
    perception: str = "ideal",
    options: dict | None = None,
) -> list:
    """One job per scenario, for ``controller`` (a name or an object).

    Parameters
    ----------
    scenarios : iterable of Scenario
        What to run (:func:`scenario_list` reads files and folders).
    controller : str or object
        A registered name or ``"module:factory"``, or a controller object (copied for
        every run).
    perception : str
        ``"ideal"`` or ``"ultrasonic"``.
    options : dict, optional
        Further options of :func:`app.runs.build_simulation`.

    Returns
    -------
    list of LayoutJob
        The jobs, in the scenarios' order.
    """
    from fuzzynav.app.experiments.studies import LayoutJob

    scenarios = list(scenarios)
    family = SET_PREFIX + _digest("\0".join(s.to_toml() for s in scenarios).encode())
    obj = None if isinstance(controller, str) else controller
    label = controller if obj is None else controller_label(obj)
    opts = tuple(sorted((options or {}).items()))
    return [
        LayoutJob(family, 0, i, label, perception, (), opts, scenario=s, controller_object=obj)
        for i, s in enumerate(scenarios)
    ]

"""``fuzzynav fis export PATH``: a controller's fuzzy rule base as MATLAB ``.fis`` files.

A paper controller is one fuzzy system: one file, inputs in the order d_t, d_o, phi_t,
phi_o, outputs left then right, the paper's labels (VS S M L VL; near medium far; VN N Z
P VP); the shipped paper rule bases read Table 1's NONE as the text has it, which a
``.fis`` cannot say, so exporting them is refused with a sentence (exit 2) and their TOML
files are the rule base. ``fuzzynav run s1 --fis PATH`` drives the robot with a ``.fis``
of your own. fuzzynav and the baseline are two blocks each (goal seeking and avoidance) joined by
crisp code: PATH is then a directory, given one ``<controller>_<block>.fis`` per block
(fuzzynav's crisp parameters, which no ``.fis`` holds, are in its shipped
``fuzzynav_params.toml``). Without PATH: ``paper.fis``, or ``<controller>_fis/``, in the
current folder.
"""

from __future__ import annotations

from pathlib import Path

from fuzzynav.app.args import add_force_option
from fuzzynav.controller.fis import dumps_fis, read_fis
from fuzzynav.safe_files import check_output_path


def export_fis(
    path: str | Path,
    controller: str = "paper",
    geometry: str = "husky",
    *,
    replace: bool = True,
    force: bool = False,
) -> list[Path]:
    """Write ``controller``'s fuzzy systems under ``path`` (MATLAB .fis); returns the files.

    One system (``paper``): ``path`` is the file, ending in ``.fis``. Several blocks
    (``fuzzynav``, ``baseline``): ``path`` is a directory, made if its parent exists.
    ``replace=False`` (a default name, no ``--force``): an existing file is refused,
    before anything is written. The files in a directory are named by the command: an
    existing one is refused unless ``force``.
    """
    from fuzzynav.controller.interface import RuleBlocksController
    from fuzzynav.controller.registry import controller_names, make_controller

    exportable = controller_names(fis_export=True)
    if controller not in exportable:
        raise ValueError(f"controller = {controller!r}: choose one of {', '.join(exportable)}")
    path = Path(path)
    ctrl = make_controller(controller, geometry=geometry)
    if not isinstance(ctrl, RuleBlocksController):
        if path.suffix.lower() != ".fis":
            raise ValueError(f"{path}: the file name must end in .fis")
        if not path.parent.exists():
            raise ValueError(f"{path}: directory {path.parent} does not exist")
        if ctrl.fis.unsensed_none:  # (after the output guard, as the writer would)
            check_output_path(path, "fis export", replace=replace, folder=True)
            raise ValueError(_unwritable_none(path, ctrl))
        _write(ctrl.fis, path, replace)
        return [path]
    systems = ctrl.rule_blocks()
    if path.suffix.lower() == ".fis":
        raise ValueError(
            f"{path}: {controller} is {len(systems)} fuzzy blocks "
            f"({', '.join(systems)}), one .fis each: give a directory"
        )
    if path.exists() and not path.is_dir():
        raise ValueError(f"{path}: not a directory")
    if not path.parent.exists():
        raise ValueError(f"{path}: directory {path.parent} does not exist")
    files = {path / f"{controller}_{name}.fis": system for name, system in systems.items()}
    for file in files:  # every file checked before the folder is made or one is written
        check_output_path(file, "fis export", replace=force, folder=True)
    try:
        path.mkdir(exist_ok=True)
    except OSError as exc:
        raise ValueError(f"{path}: cannot create the directory ({exc.strerror or exc})") from None
    for file, system in files.items():
        _write(system, file, force)
    return list(files)


def _write(system, path: Path, replace: bool = True) -> None:
    """Write one .fis whole or not at all (:mod:`fuzzynav.safe_files`): a full disk or a
    read-only folder leaves any old file as it was, and says so (ValueError). Through
    the one output guard: never over a shipped file, nor (``replace=False``) over an
    existing one."""
    from fuzzynav.safe_files import write_text_atomically

    # (folder=True: not probed here; the write itself says why it failed)
    check_output_path(path, "fis export", replace=replace, folder=True)
    try:
        write_text_atomically(path, dumps_fis(system))
    except OSError as exc:
        raise ValueError(f"{path}: not written ({exc.strerror or exc})") from None


def _unwritable_none(path: Path, ctrl) -> str:
    """Why ``ctrl``'s rule base has no .fis form: its rules read NONE as the text does."""
    from fuzzynav.resources import escape_controls

    inputs = ", ".join(ctrl.fis.unsensed_none)
    return (
        f"{path}: not written: {ctrl.fis.name}'s rules read NONE for {inputs} as 'sensed "
        "nothing' (the paper's text), which a .fis cannot say (MATLAB reads NONE as 'takes "
        "no part', and would drive otherwise); it is shipped as the TOML rule base "
        f"rules/{escape_controls(Path(ctrl.source).name)}"
    )


def _signature(system) -> str:
    names = lambda variables: ", ".join(v.name for v in variables)  # noqa: E731
    return f"inputs {names(system.inputs)}; outputs {names(system.outputs)}"


def default_export_path(controller: str) -> Path:
    """Where ``fis export`` writes without a PATH: the current folder."""
    return Path(f"{controller}.fis") if controller == "paper" else Path(f"{controller}_fis")


def cmd_fis_export(args) -> int:
    target = args.path if args.path is not None else default_export_path(args.controller)
    # a path given is asked for; the default name never replaces a file unless --force
    replace = args.path is not None or getattr(args, "force", False)
    force = getattr(args, "force", False)
    for path in export_fis(target, args.controller, args.geometry, replace=replace, force=force):
        # Read back: what is printed is what the file holds.
        from fuzzynav.resources import escape_controls

        print(f"wrote {escape_controls(str(path))} ({_signature(read_fis(path))})")
    return 0


def add_commands(subparsers) -> None:
    from fuzzynav.controller.registry import controller_names

    fis = subparsers.add_parser("fis", help="MATLAB .fis files")
    sub = fis.add_subparsers(dest="fis_command", required=True)
    export = sub.add_parser(
        "export",
        help="write a controller's rule base as MATLAB .fis "
        "(paper: one file; fuzzynav, baseline: one per block)",
    )
    export.add_argument(
        "path",
        type=Path,
        nargs="?",
        help="output file (.fis) for paper; a directory for fuzzynav and baseline "
        "(default: paper.fis or CONTROLLER_fis/ in the current folder)",
    )
    export.add_argument(
        "--controller",
        default="paper",
        choices=controller_names(fis_export=True),
        help="whose rule base (default paper; fuzzynav and baseline have two blocks each)",
    )
    export.add_argument(
        "--geometry",
        default="husky",
        choices=("husky", "paper"),
        help="the paper controller's rule base for this geometry: tuned for the Husky's "
        "footprint (default) or fitted to Table 4 in the paper's point-robot geometry",
    )
    add_force_option(export, "the default paper.fis, or the files in a directory")
    export.set_defaults(func=cmd_fis_export)

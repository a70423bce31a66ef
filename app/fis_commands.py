"""``fuzzynav fis export PATH``: the paper controller as a MATLAB ``.fis`` file.

Inputs in the order d_t, d_o, phi_t, phi_o; outputs left then right; the paper's labels
(VS S M L VL; near medium far; VN N Z P VP). ``fuzzynav run s1 --fis PATH`` drives the
robot with such a file (or one of your own).
"""

from __future__ import annotations

from pathlib import Path

FIS_CONTROLLERS = ("paper",)


def export_fis(path: str | Path, controller: str = "paper") -> Path:
    """Write ``controller``'s fuzzy system to ``path`` (a MATLAB .fis file)."""
    from controller.registry import make_controller

    if controller not in FIS_CONTROLLERS:
        raise ValueError(f"controller = {controller!r}: only {', '.join(FIS_CONTROLLERS)} is a single "
                         f"fuzzy system that a .fis file can hold")
    path = Path(path)
    if path.suffix.lower() != ".fis":
        raise ValueError(f"{path}: the file name must end in .fis")
    if not path.parent.exists():
        raise ValueError(f"{path}: directory {path.parent} does not exist")
    make_controller(controller).fis.to_fis(path)
    return path


def cmd_fis_export(args) -> int:
    path = export_fis(args.path, args.controller)
    print(f"wrote {path} ({args.controller} controller: inputs d_t, d_o, phi_t, phi_o; outputs left, right)")
    return 0


def add_commands(subparsers) -> None:
    fis = subparsers.add_parser("fis", help="MATLAB .fis files")
    sub = fis.add_subparsers(dest="fis_command", required=True)
    export = sub.add_parser("export", help="write the paper controller as a MATLAB .fis file")
    export.add_argument("path", type=Path, help="output file (.fis)")
    export.add_argument("--controller", default="paper", choices=FIS_CONTROLLERS)
    export.set_defaults(func=cmd_fis_export)

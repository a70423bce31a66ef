"""Provenance: what made a result and how to make it again.

The package versions and the git revision a result was made with
(:func:`package_versions`), the process's command line (:func:`command_line`), and the
command that reproduces a result: a run's (:func:`reproduce_run`, the ``fuzzynav run``
command with every option that changes it), or any command's, quoted for a shell
(:func:`shell_command`) and written as the ``Reproduce with:`` line that a fitted or
tuned rule base carries in its header (:func:`reproduce_line`). Recordings, sweeps and
tuning take them from here.
"""

from __future__ import annotations

import functools
import platform
import shlex
import subprocess
import sys
from pathlib import Path

_VERSIONED = {
    "fuzzynav": None,
    "rerun-sdk": "rerun",
    "numpy": "numpy",
    "scipy": "scipy",
    "pymunk": "pymunk",
    "matplotlib": "matplotlib",
    "viser": "viser",
}


@functools.cache
def package_versions() -> dict:
    """Python, platform, the packages a run depends on, and the git revision (once per
    process: reading distribution metadata costs milliseconds a package)."""
    from importlib import metadata

    out = {"python": platform.python_version(), "platform": platform.platform()}
    for name, module in _VERSIONED.items():
        version = getattr(sys.modules.get(module), "__version__", None) if module else None
        if not isinstance(version, str):
            try:
                version = metadata.version(name)
            except metadata.PackageNotFoundError:
                version = "not installed"
        out[name] = version
    revision = git_revision()
    if revision:  # only from a checkout of this project
        out["git"] = revision
    return out


def git_revision() -> str | None:
    """The checkout's revision when fuzzynav runs from a git checkout of this project
    (an editable install); None for an installed wheel, which says its version instead
    of the revision of whatever repository it happens to sit in."""
    root = Path(__file__).resolve().parents[1]  # app/ sits in the checkout's root
    if not (
        (root / ".git").exists()
        and (root / "fuzzynav" / "__init__.py").is_file()
        and (root / "pyproject.toml").is_file()
    ):
        return None
    try:
        done = subprocess.run(
            ["git", "describe", "--always", "--dirty", "--abbrev=12"],
            cwd=root,
            capture_output=True,
            text=True,
            timeout=5,
        )
    except (OSError, subprocess.SubprocessError):
        return None
    return done.stdout.strip() if done.returncode == 0 and done.stdout.strip() else None


def command_line() -> str:
    """The process's own command line, quoted for a shell (``fuzzynav run s1 ...``)."""
    return " ".join(shlex.quote(a) for a in [Path(sys.argv[0]).name] + sys.argv[1:])


#: The options that pin a run's reproduce command to what it ran:
#: ``run`` refuses to run when the scenario, the controller's rules and parameters, or
#: fuzzynav's version differ from the recorded ones.
RULES_DIGEST_OPTION = "--rules-sha256"
VERSION_OPTION = "--fuzzynav-version"


def reproduce_run(
    scenario,
    controller,
    perception,
    seed,
    control_period_s,
    *,
    geometry: str = "husky",
    noise_std_m: float = 0.0,
    voltage_limit_v: float = 12.0,
    parameters=None,
):
    """The run's :class:`app.runs.Reproduction`: the ``fuzzynav run`` command with every
    option that changes the run, and what it cannot carry, pinned to what it ran: the
    scenario's digest (a shipped one too: ``s3.toml`` may change), the controller's
    rules' digest (:func:`app.runs.rules_digest`) and fuzzynav's version, which ``run`` checks
    before it runs (:func:`check_pins`)."""
    import dataclasses
    import shlex

    from fuzzynav.app.runs import SCENARIO_DIGEST_OPTION, reproduce, rules_digest, scenario_digest

    again = reproduce(
        scenario,
        controller,
        perception=perception,
        seed=seed,
        control_period_s=control_period_s,
        geometry=geometry,
        noise_std_m=noise_std_m,
        voltage_limit_v=voltage_limit_v,
        parameters=parameters,
    )
    argv = shlex.split(again.command)
    if SCENARIO_DIGEST_OPTION not in argv:
        argv += [SCENARIO_DIGEST_OPTION, scenario_digest(scenario)]
    digest = rules_digest(controller)
    if digest is not None:
        argv += [RULES_DIGEST_OPTION, digest]
    argv += [VERSION_OPTION, fuzzynav_version()]
    return dataclasses.replace(again, command=shlex.join(argv))


def add_pin_options(parser) -> None:
    """``run --rules-sha256 HEX --fuzzynav-version V`` (a recording's reproduce
    command gives them)."""
    parser.add_argument(
        RULES_DIGEST_OPTION,
        metavar="HEX",
        help="refuse to run unless the controller's rules and parameters have this sha256 "
        "(a recording's reproduce command gives it)",
    )
    parser.add_argument(
        VERSION_OPTION,
        metavar="VERSION",
        help="refuse to run unless this is fuzzynav's version (a recording's reproduce "
        "command gives it)",
    )


def check_pins(args, sim) -> None:
    """``run --rules-sha256 / --fuzzynav-version``: refuse (ValueError, said why) a run
    whose controller or fuzzynav differs from the one recorded."""
    from fuzzynav.app.runs import rules_digest

    want = getattr(args, "rules_sha256", None)
    if want:
        have = rules_digest(sim.controller) or "(none: its rules cannot be written out)"
        if have != want.lower():
            raise ValueError(
                f"{RULES_DIGEST_OPTION} {want}: the controller's rules or parameters are not "
                f"the ones recorded (their sha256 is {have}): the rule base changed since"
            )
    want = getattr(args, "fuzzynav_version", None)
    if want and want != fuzzynav_version():
        raise ValueError(
            f"{VERSION_OPTION} {want}: this is fuzzynav {fuzzynav_version()}, not the "
            "version the run was recorded with (install that one to repeat it)"
        )


def wrap_command(command: str, width: int = 72) -> str:
    """A shell command on several lines (`` \\`` continuations, one option and its value
    a line where the line would grow past ``width``): the same command to a shell."""
    words = shlex.split(command)
    lines, current = [], ""
    k = 0
    while k < len(words):
        piece = shlex.quote(words[k])
        if words[k].startswith("--") and k + 1 < len(words) and not words[k + 1].startswith("--"):
            value = shlex.quote(words[k + 1])
            k += 1
            if 4 + len(piece) + 1 + len(value) > width:  # (a digest: the value a line)
                pieces = [piece, value]
            else:
                pieces = [piece + " " + value]
        else:
            pieces = [piece]
        k += 1
        for piece in pieces:
            if current and len(current) + 1 + len(piece) > width:
                lines.append(current)
                current = "    " + piece
            else:
                current = f"{current} {piece}" if current else piece
    lines.append(current)
    return " \\\n".join(lines)


@functools.cache
def fuzzynav_version() -> str:
    """This fuzzynav's version (what a sweep's row fingerprint and a recording name);
    read once (the package metadata's lookup took 2-3 ms a recording)."""
    from fuzzynav import __version__

    return __version__


def shell_command(argv) -> str:
    """``argv`` (strings or numbers) as one command line, each word quoted for a shell."""
    return shlex.join(str(a) for a in argv)


#: The prefix of the line in a written file's header that says how to make it again.
REPRODUCE_PREFIX = "Reproduce with: "


def reproduce_line(command: str) -> str:
    """``Reproduce with: <command>``: the line a fitted or tuned file's header begins with."""
    return REPRODUCE_PREFIX + command

"""fuzzynav's data, read through :mod:`importlib.resources` (never written to).

``husky.toml`` (robot parameters), ``rules/`` (rule bases), ``scenarios/`` (scenario
files). This file only makes the folder a package so that it installs with fuzzynav.
"""

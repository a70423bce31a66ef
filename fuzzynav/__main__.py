"""``python -m fuzzynav``: the same as the ``fuzzynav`` command."""

from fuzzynav.app.cli import main

if __name__ == "__main__":
    raise SystemExit(main())

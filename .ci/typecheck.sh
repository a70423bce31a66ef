#!/usr/bin/env bash
# mypy over the import package as it is installed (fuzzynav.world, fuzzynav.controller,
# and the front door fuzzynav/ with --strict): the repository's folders are joined under
# one fuzzynav/ of symbolic links in a temporary folder, as setuptools' package-dir
# mapping joins them.
set -euo pipefail
PY=${PY:-.venv/bin/python}
root=$(cd "$(dirname "$0")/.." && pwd)
tree=$(mktemp -d)
trap 'rm -rf "$tree"' EXIT
mkdir "$tree/fuzzynav"
for folder in world controller app assets; do ln -s "$root/$folder" "$tree/fuzzynav/$folder"; done
for file in "$root"/fuzzynav/*.py "$root"/fuzzynav/py.typed; do ln -s "$file" "$tree/fuzzynav/"; done
cd "$tree"
status=0
# the engine and the controllers, as configured in pyproject.toml
"$root/$PY" -m mypy --config-file "$root/pyproject.toml" \
    -p fuzzynav.world -p fuzzynav.controller || status=1
# the front door, strict (issue 40 item 3): what a user's script imports is fully typed
"$root/$PY" -m mypy --config-file "$root/pyproject.toml" --strict \
    -m fuzzynav -m fuzzynav.api -m fuzzynav.sweeps -m fuzzynav.gym \
    -m fuzzynav.safe_files -m fuzzynav.resources || status=1
exit "$status"

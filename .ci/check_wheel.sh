#!/usr/bin/env bash
# Build the wheel, install it into a fresh venv outside the checkout and use it from an
# empty folder as a new user would: --version, run s1 --json, fis export (the baseline's
# blocks; the paper's refused), serve (HTTP 200),
# then `pip install world` (an unrelated package of that name) and all of it again.
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PY:-.venv/bin/python}
work=$(mktemp -d)
trap 'kill "${server:-}" 2>/dev/null || true; rm -rf "$work"' EXIT

"$PY" -m build --wheel --outdir "$work/dist" . >"$work/build.log" 2>&1 || { cat "$work/build.log"; exit 1; }
wheel=$(ls "$work"/dist/fuzzynav-*.whl)
echo "wheel: $(basename "$wheel")"

# Nothing but the fuzzynav package and its dist-info, and the data inside the package.
"$PY" - "$wheel" <<'PYEOF'
import sys, zipfile
names = zipfile.ZipFile(sys.argv[1]).namelist()
tops = {n.split("/")[0] for n in names}
bad = {t for t in tops if t != "fuzzynav" and not (t.startswith("fuzzynav-") and t.endswith(".dist-info"))}
assert not bad, f"the wheel installs more than fuzzynav: {sorted(bad)}"
for needed in ("fuzzynav/assets/husky.toml", "fuzzynav/assets/rules/paper.toml",
               "fuzzynav/assets/scenarios/s1.toml",
               "fuzzynav/assets/paper/results.toml", "fuzzynav/app/cli.py",
               "fuzzynav/world/husky.py", "fuzzynav/controller/fuzzy.py", "fuzzynav/__main__.py",
               "fuzzynav/api.py", "fuzzynav/py.typed"):
    assert needed in names, f"the wheel lacks {needed}"
assert any(n.endswith(".dist-info/licenses/LICENSE") for n in names), "no LICENSE in the wheel"
print(f"wheel contents: {len(names)} files, top level {sorted(tops)}")
PYEOF

python3 -m venv "$work/venv"
"$work/venv/bin/pip" install --quiet --upgrade pip
"$work/venv/bin/pip" install --quiet "$wheel"
mkdir "$work/empty"
cd "$work/empty"

# Type checkers see the installed package (py.typed, the lazy exports declared for them):
# a user's script type-checks, and a wrong use of the API is caught (issue 40).
"$work/venv/bin/pip" install --quiet "mypy>=1.10"
cat >typed_ok.py <<'PYEOF'
import fuzzynav

run = fuzzynav.simulate("s1", controller="paper")
outcome: str = run.outcome
controller = fuzzynav.make_controller("paper")
scenario = fuzzynav.load_scenario("s2")
print(outcome, scenario, controller)
PYEOF
cat >typed_wrong.py <<'PYEOF'
import fuzzynav

wrong: int = fuzzynav.simulate("s1").outcome
PYEOF
"$work/venv/bin/mypy" --no-incremental typed_ok.py
if "$work/venv/bin/mypy" --no-incremental typed_wrong.py >mypy_wrong.txt 2>&1; then
    echo "mypy saw no types in the installed package (a wrong use passed)"; cat mypy_wrong.txt; exit 1
fi
grep -q "Incompatible types in assignment" mypy_wrong.txt || { cat mypy_wrong.txt; exit 1; }
echo "mypy: the installed package is typed (a wrong use is caught)"
rm -f typed_ok.py typed_wrong.py mypy_wrong.txt

use_it() {
    local fz="$work/venv/bin/fuzzynav"
    "$fz" --version
    "$work/venv/bin/python" -m fuzzynav --version >/dev/null
    "$fz" run s1 --json >run.json
    "$work/venv/bin/python" - <<'PYEOF'
import json
row = json.load(open("run.json"))
assert row["reached"] and not row["collided"], row
print(f"run s1: reached in {row['time_to_target_s']:.1f} s, path {row['path_length_m']:.2f} m")
PYEOF
    "$fz" run s1 --geometry paper --json >/dev/null
    # The Python interface, as the README shows it.
    "$work/venv/bin/python" -c "import fuzzynav; r = fuzzynav.simulate('s1'); print(r.outcome, r.trace['x_m'][-1])"
    # An installed wheel names its version and no git revision (it is no checkout).
    "$work/venv/bin/python" -c "
from fuzzynav.app.provenance import package_versions
import fuzzynav
v = package_versions()
assert v['fuzzynav'] == fuzzynav.__version__ and 'git' not in v, v
"
    # the paper's rule bases read the text's NONE, which a .fis cannot say: refused, exit 2
    if "$fz" fis export 2>fis.err; then echo "fis export of the paper controller passed"; exit 1; fi
    grep -q "a .fis cannot say" fis.err || { cat fis.err; exit 1; }
    "$fz" fis export blocks --controller baseline
    test -s blocks/baseline_goal.fis
    "$fz" run s1 --controller p --rrd s1.rrd >/dev/null 2>&1
    test -s s1.rrd
    port=$("$work/venv/bin/python" -c "import socket; s=socket.socket(); s.bind(('127.0.0.1', 0)); print(s.getsockname()[1])")
    "$fz" serve --port "$port" >serve.log 2>&1 &
    server=$!
    for _ in $(seq 1 120); do
        code=$(curl -s -o /dev/null -w '%{http_code}' "http://127.0.0.1:$port/" || true)
        [ "$code" = 200 ] && break
        sleep 0.5
    done
    kill "$server"; wait "$server" 2>/dev/null || true
    [ "$code" = 200 ] || { echo "serve: no HTTP 200 (got $code)"; cat serve.log; exit 1; }
    echo "serve: HTTP 200"
    # Nothing was written into the installation.
    if find "$work/venv/lib" -path '*site-packages/fuzzynav*' -newer "$wheel" -type f \
        ! -name '*.pyc' | grep -q .; then
        echo "something wrote into the installed package:"; exit 1
    fi
    rm -rf run.json fis.err blocks s1.rrd serve.log
}

use_it
"$work/venv/bin/pip" install --quiet world
echo "installed the unrelated package 'world'; again:"
use_it
echo "check_wheel: ok"

# Sourced by scripts/demo and scripts/test: create .venv (Python >= 3.11) and
# install the tool with its test extra; reinstall only when pyproject.toml changes.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
VENV="$ROOT/.venv"
PY=""
for cand in python3.13 python3.12 python3.11 python3; do
    if command -v "$cand" >/dev/null 2>&1 && "$cand" -c 'import sys; sys.exit(sys.version_info < (3, 11))' 2>/dev/null; then
        PY="$cand"; break
    fi
done
if [ -z "$PY" ]; then
    echo "error: Python 3.11 or newer is required (install python3.11)" >&2
    exit 2
fi
if [ ! -x "$VENV/bin/python" ]; then
    if ! "$PY" -m venv "$VENV" >/dev/null 2>&1; then
        rm -rf "$VENV"
        echo "error: '$PY -m venv' failed; on Debian install the venv module: apt install python3-venv" >&2
        exit 2
    fi
fi
STAMP="$VENV/.installed-$(sha256sum "$ROOT/pyproject.toml" | cut -c1-16)"
if [ ! -f "$STAMP" ]; then
    echo "installing guideway and its dependencies into $VENV (log: $VENV/install.log) ..." >&2
    "$VENV/bin/python" -m pip install --quiet --upgrade pip >"$VENV/install.log" 2>&1 || true
    if ! "$VENV/bin/python" -m pip install --quiet -e "$ROOT[test]" >>"$VENV/install.log" 2>&1; then
        tail -n 20 "$VENV/install.log" >&2
        echo "error: installing the tool failed (full log: $VENV/install.log); check the network access to the package index" >&2
        exit 2
    fi
    rm -f "$VENV"/.installed-*
    touch "$STAMP"
fi

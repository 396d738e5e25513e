#!/usr/bin/env bash
# The Python client's tests as the ctest python/ClientTests runs them (CMakeLists.txt here):
# a venv in WORK_DIR that sees Debian's python3-zmq, -protobuf, -numpy and -pytest
# (--system-site-packages), the package pip-installed into it offline from a copy of its
# sources (so the checkout stays clean), then pytest on client/python/tests against real
# sceneloc-server processes.
#
# Usage: run_tests.sh WORK_DIR [PYTEST_ARGS...]
# Environment: SCENELOC_SERVER_BIN, SCENELOC_BIN, SCENELOC_TEST_MAPS, SCENELOC_QUERY_JPEG
#   (the paths tests/conftest.py needs); PYTHON, the interpreter the venv is made from
#   (default /usr/bin/python3); PROTOC, the protoc that compiles the proto (default: PATH's).
set -euo pipefail
if (($# < 1)); then
  echo "usage: $0 WORK_DIR [PYTEST_ARGS...]" >&2
  exit 2
fi
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
checkout=$(cd "$here/../.." && pwd)
mkdir -p "$1"
work=$(cd "$1" && pwd)
shift
python=${PYTHON:-/usr/bin/python3}

# The package's sources, in the checkout's layout (setup.py reads ../../proto/sceneloc.proto).
stage=$work/stage
rm -rf "$stage"
mkdir -p "$stage/client/python" "$stage/proto"
cp -R "$here/pyproject.toml" "$here/setup.py" "$here/README.md" "$here/src" "$stage/client/python/"
cp "$checkout/proto/sceneloc.proto" "$stage/proto/"
find "$stage" \( -name __pycache__ -o -name '*.egg-info' -o -name sceneloc_pb2.py \) -prune \
  -exec rm -rf {} +

venv=$work/venv
[[ -x $venv/bin/python ]] || "$python" -m venv --system-site-packages "$venv"
"$venv/bin/python" -m pip install --quiet --disable-pip-version-check --no-cache-dir \
  --no-index --no-build-isolation --no-deps --force-reinstall "$stage/client/python"

# Writing no bytecode or cache into the checkout. (Its src/ layout keeps the sources from
# shadowing the installed package, whatever the current folder.)
cd "$here"
PYTHONDONTWRITEBYTECODE=1 exec "$venv/bin/python" -m pytest -p no:cacheprovider tests "$@"

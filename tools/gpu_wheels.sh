#!/usr/bin/env bash
# Wheels that the GPU machine's image lacks and a GPU benchmark of discover needs (the config's
# schema validation: jsonschema and what it imports), downloaded here into .whl/ (ignored by git)
# at the lock's versions for that machine's Python 3.12. A device run carries .whl and starts with:
#   python3 -m pip install -q --no-index --no-deps --no-compile --target /tmp/site .whl/*.whl && export PYTHONPATH=/tmp/site:$PWD/src
set -euo pipefail
cd "$(dirname "$0")/.."
grep -qx '/.whl/' .git/info/exclude 2>/dev/null || echo '/.whl/' >> .git/info/exclude
mkdir -p .whl
for name in jsonschema jsonschema-specifications referencing rpds-py; do
  version=$(grep -i -E "^${name}==" requirements.lock | cut -d= -f3)
  python3 -m pip download --quiet --no-deps --only-binary=:all: --python-version 3.12 --implementation cp \
    --platform manylinux_2_28_x86_64 --platform manylinux_2_17_x86_64 --platform manylinux2014_x86_64 \
    -d .whl "${name}==${version}"
done
ls .whl

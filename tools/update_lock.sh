#!/usr/bin/env bash
# Regenerate constraints.txt, the lock: every dependency of the project and of all its extras
# (test and docs included), transitive ones too, pinned to the version installed in the current
# environment. pip-compile (pip-tools) resolves pyproject.toml with what `pip freeze` lists as
# constraints, through pip's own configuration (the same indexes and find-links pip installs
# from; the CPU build of torch included), so the lock holds exactly the installed versions of
# exactly the packages the project needs.
#
#   tools/update_lock.sh                 # pip-compile from this environment (pip install pip-tools)
#   LOCK_PIP_COMPILE=/path/to/pip-compile tools/update_lock.sh    # a pip-compile installed elsewhere
#
# Update the lock and the reference results together: CONTRIBUTING.md says how.
set -euo pipefail
cd "$(dirname "$0")/.."
pip_compile=${LOCK_PIP_COMPILE:-}
if [ -z "$pip_compile" ]; then
  if ! python -c "import piptools" 2>/dev/null; then
    echo "error: pip-compile not found: pip install pip-tools, or set LOCK_PIP_COMPILE to a pip-compile" >&2
    exit 1
  fi
  pip_compile="python -m piptools compile"
fi
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
python -m pip freeze --all --exclude-editable | grep -v -i '^roman[-_]sim\b' > "$tmp/installed.txt"
# shellcheck disable=SC2086
CUSTOM_COMPILE_COMMAND=tools/update_lock.sh $pip_compile --quiet --all-extras --strip-extras --allow-unsafe --no-emit-index-url --no-emit-find-links \
  --constraint "$tmp/installed.txt" \
  --output-file "$tmp/constraints.txt" pyproject.toml
# The annotations name the temporary freeze among each pin's sources: drop those lines.
grep -v -F -e "-c $tmp/installed.txt" "$tmp/constraints.txt" > constraints.txt
echo "constraints.txt: $(grep -c '==' constraints.txt) pins"

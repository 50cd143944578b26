# Sourced by the CLI tests first: strict mode, a scratch directory ($work) removed on exit, and fail(), which
# says why a check failed. A test that must stop processes too sets its own EXIT trap after sourcing.
set -euo pipefail
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

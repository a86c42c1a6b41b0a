#!/usr/bin/env bash
# memcheck.sh SUPPRESSIONS PROGRAM ARGS...: PROGRAM under valgrind's memcheck; any error
# (uninitialised values used in a branch or address, invalid reads or writes, a definite leak)
# outside the suppressed third-party code fails the test with valgrind's report.
# Exit 77 (ctest: skipped) when valgrind is not installed.
set -euo pipefail
supp=$1
shift
if ! command -v valgrind >/dev/null 2>&1; then
  echo "SKIPPED: valgrind is not installed (Debian package valgrind, which make test installs)"
  exit 77
fi
exec valgrind --quiet --error-exitcode=99 --track-origins=yes --leak-check=full \
  --show-leak-kinds=definite --errors-for-leak-kinds=definite --suppressions="$supp" "$@"

#!/usr/bin/env bash
# Every C++ source and header of the package is formatted as .clang-format says (clang-format 14,
# Debian 12's; scripts/install_deps.sh --tests installs it). Lists each file that differs and the
# command that fixes it. Another clang-format major version may format differently: it runs only
# with 14 and prints SKIPPED otherwise, as without clang-format (NE_REQUIRE_FORMAT=1 fails then).
# Usage: test_format.sh SOURCE_DIR
set -uo pipefail
# The repository's real folder: a workspace's package folder may hold links into it (not to the
# dot files).
src="$(dirname "$(readlink -f "$1/CMakeLists.txt")")"
skip() {
  echo "format: SKIPPED ($1)"
  [ "${NE_REQUIRE_FORMAT:-0}" = 1 ] && { echo "0 passed, 1 failed"; exit 1; }
  exit 0
}
command -v clang-format > /dev/null 2>&1 || skip "clang-format not installed; Debian package clang-format"
version=$(clang-format --version | sed -n 's/.*version \([0-9]*\)\..*/\1/p')
[ "$version" = 14 ] || skip "clang-format $version; the style is checked with 14"
cd "$src" || exit 1
[ -f .clang-format ] || { echo "no .clang-format in $src"; echo "0 passed, 1 failed"; exit 1; }
files=$(git ls-files '*.cpp' '*.hpp' '*.h' 2>/dev/null || find src include test -name '*.cpp' -o -name '*.hpp' -o -name '*.h')
bad=0
for f in $files; do
  if ! clang-format --style=file --dry-run --Werror "$f" > /dev/null 2>&1; then
    echo "not formatted: $f"
    bad=$((bad + 1))
  fi
done
count=$(echo "$files" | wc -w)
if [ "$bad" -gt 0 ]; then
  echo "$bad of $count files differ from .clang-format: clang-format -i --style=file FILE"
  echo "0 passed, 1 failed"
  exit 1
fi
echo "$count files formatted as .clang-format says"
echo "1 passed, 0 failed"

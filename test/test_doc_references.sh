#!/usr/bin/env bash
# Every reference in the repository to a document or file must point inside the repository:
#  1. no file names a folder outside it (../shared, a workplace spec or seed file), nor one of the
#     internal specification files by name (the maths and formats specifications) except as a
#     path into docs/;
#  2. every relative link in a Markdown file ([text](path), ![alt](path)) names a file that exists;
#  3. every repo path written in any tracked file (docs/..., config/..., launch/..., scripts/...,
#     test/..., msg/..., srv/..., include/..., src/...) names a file or folder that exists.
# Usage: test_doc_references.sh REPO_ROOT     Prints "N passed, M failed".
set -uo pipefail
# The repository's real folder: a workspace's package folder may hold links into it.
ROOT="$(dirname "$(readlink -f "$1/CMakeLists.txt")")"
cd "$ROOT" || exit 2
if git rev-parse --is-inside-work-tree > /dev/null 2>&1; then
  mapfile -t FILES < <(git ls-files | grep -vE '\.(png|bag)$')
else
  mapfile -t FILES < <(find . -type f -not -path './.git/*' -not -path './.ws/*' -not -name '*.png' | sed 's|^\./||')
fi
passed=0 failed=0
fail() { echo "FAIL: $*"; failed=$((failed + 1)); }

# 1. Outside references. This test file itself spells the patterns, so it is left out.
self="test/test_doc_references.sh"
outside=$(grep -nE '\.\./shared|/shared/(spec|seeds)|(^|[^A-Za-z_/.-])(rseio|aoe|stability|formats)\.md' "${FILES[@]}" 2>/dev/null \
  | grep -v "^$self:" | grep -vE '(^|[^A-Za-z_])docs/(rseio|aoe|stability|formats)\.md|\]\((\./)?(stability|formats)\.md' \
  | grep -vE '^docs/[^:]*:.*\((\./)?(stability|formats)\.md' | grep -vE '^docs/[^:]*:[0-9]+:.*`(stability|formats)\.md`' || true)
# Inside docs/, sibling links such as (stability.md#...) are in the repo; check they exist in part 2.
outside=$(printf '%s\n' "$outside" | grep -vE '^docs/' | grep -v '^$' || true)
outside_docs=$(grep -nE '\.\./shared|/shared/(spec|seeds)' docs/*.md 2>/dev/null || true)
if [ -n "$outside$outside_docs" ]; then
  fail "references to documents outside the repository:"
  printf '%s\n%s\n' "$outside" "$outside_docs" | grep -v '^$' | head -40
else
  passed=$((passed + 1))
fi
# The compatibility check may name the Eigen headers of the workplace (a header folder, not a
# document): only test/compat/ may, and only that folder.

# 2. Markdown links.
bad=0
for f in "${FILES[@]}"; do
  case "$f" in *.md|*.rst) ;; *) continue ;; esac
  dir=$(dirname "$f")
  while IFS= read -r target; do
    t="${target%%#*}"
    t="${t%% *}"
    [ -z "$t" ] && continue
    case "$t" in http://*|https://*|mailto:*) continue ;; esac
    if [ ! -e "$dir/$t" ]; then
      echo "  $f: link to '$target' but $dir/$t does not exist"
      bad=1
    fi
  done < <(grep -oE '\]\([^)]+\)' "$f" | sed -E 's/^\]\((.*)\)$/\1/')
done
if [ "$bad" -eq 0 ]; then passed=$((passed + 1)); else fail "broken Markdown links (above)"; fi

# 3. Repo paths in any tracked file (not #include lines: those are compiler paths).
if printf '%s\n' "${FILES[@]}" | python3 -c '
import os, re, sys
pat = re.compile(r"(?<![A-Za-z0-9_./-])((?:docs|config|launch|scripts|test|msg|srv|include/networked_estimation|src/(?:core|nodelets|tools|nodes))/[A-Za-z0-9_./-]*[A-Za-z0-9_])")
bad = 0
for f in sys.stdin.read().split("\n"):
    if not f or f == "CMakeLists.txt" or not os.path.isfile(f):
        continue
    try:
        lines = open(f, encoding="utf-8").read().split("\n")
    except UnicodeDecodeError:
        continue
    for no, line in enumerate(lines, 1):
        if re.match(r"\s*#\s*include", line):
            continue
        for m in pat.finditer(line):
            p = m.group(1).rstrip("/.")
            if line[m.end(1):m.end(1) + 1] in ("*", "<", "$", "{"):
                continue  # a pattern (test/test_*.cpp), not a path
            # relative to the repository, to the folder of the file, or to the public header / core
            # source folders (tables that list the files of a concern)
            bases = ["", os.path.dirname(f), "include/networked_estimation", "src/core"]
            if any(os.path.exists(os.path.join(b, p)) for b in bases):
                continue
            if any(os.path.exists(os.path.join(b, p) + ext) for b in bases for ext in (".hpp", ".cpp")):
                continue  # "config/yaml_reader.{hpp,cpp}"
            print("  %s:%d: %r does not exist in the repository" % (f, no, p))
            bad = 1
sys.exit(bad)
'; then passed=$((passed + 1)); else fail "paths that do not exist (above)"; fi

echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]

#!/usr/bin/env bash
# Noetic compatibility check: recompiles every translation unit of the package (core, nodelets,
# tools, tests; taken from the build's compile_commands.json, with the same flags; a unity batch as
# each of its source files alone) against the
# headers of Eigen 3.3.7, the Eigen of ROS Noetic's platform, and checks the sources for library
# features that GCC 9's libstdc++ (Noetic's compiler) lacks.
#
# Usage: check_eigen33.sh BUILD_DIR SOURCE_DIR
# The Eigen 3.3.7 headers are looked up in $NE_COMPAT_EIGEN, else in shared/compat/eigen-3.3.7
# beside the repository's folder (where the project's CI provides them). When neither exists, the
# Eigen part is SKIPPED and says so; with NE_REQUIRE_COMPAT=1 a skip is a failure.
set -euo pipefail
build="$1"
# The repository's real folder: a workspace's package folder may hold links into it.
src="$(dirname "$(readlink -f "$2/CMakeLists.txt")")"
fail=0

# 1. Library features newer than GCC 9 (Noetic) and google benchmark 1.5.0.
#    Floating-point std::to_chars/from_chars arrived in libstdc++ 11; benchmark::Shutdown in 1.5.5.
pattern='std::(to_chars|from_chars)|benchmark::Shutdown|Eigen::(all|seq|seqN|last|lastN|placeholders)\b'
if hits=$(cd "$src" && grep -rnE "$pattern" --include='*.cpp' --include='*.hpp' --include='*.h' src include test); then
  echo "compat: FAIL: features missing from GCC 9 / Eigen 3.3 / benchmark 1.5.0:"
  echo "$hits"
  fail=1
else
  echo "compat: no std::to_chars/from_chars, Eigen::all/seq/placeholders or benchmark::Shutdown in the sources"
fi

# 2. Every translation unit against Eigen 3.3.7.
eigen="${NE_COMPAT_EIGEN:-}"
if [ -z "$eigen" ]; then
  eigen="$(dirname "$src")/shared/compat/eigen-3.3.7"
fi
if [ ! -f "$eigen/Eigen/Core" ]; then
  echo "compat: SKIPPED the Eigen 3.3.7 check: no Eigen 3.3.7 headers found (set NE_COMPAT_EIGEN to their folder)"
  if [ "${NE_REQUIRE_COMPAT:-0}" = 1 ]; then echo "compat: FAIL: NE_REQUIRE_COMPAT=1 but the check was skipped"; exit 1; fi
  exit "$fail"
fi
db="$build/compile_commands.json"
[ -f "$db" ] || { echo "compat: FAIL: $db not found (configure with CMAKE_EXPORT_COMPILE_COMMANDS)"; exit 1; }

work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
# One shell command per translation unit: the build's own command with the compat headers first on
# the include path (the first -I wins over the system Eigen), no code generation, no warnings
# (Eigen 3.3's own warnings under a newer GCC are not ours), plus a probe proving which Eigen was used.
python3 - "$db" "$eigen" "$work" <<'PY'
import json, shlex, sys, os
db, eigen, work = sys.argv[1:4]
entries = json.load(open(db))
probe = os.path.join(work, "probe.cpp")
with open(probe, "w") as f:
    f.write('#include <Eigen/Core>\n'
            'static_assert(EIGEN_WORLD_VERSION == 3 && EIGEN_MAJOR_VERSION == 3 && EIGEN_MINOR_VERSION == 7,'
            ' "the compatibility check must compile against Eigen 3.3.7");\n')
# A unity batch (CMake's UNITY_BUILD: Unity/unity_N_cxx.cxx, one #include per source) is checked
# as its sources, each alone: every file must also compile by itself.
expanded = []
for e in entries:
    if "/Unity/unity_" not in e["file"]:
        expanded.append(e)
        continue
    args = e["arguments"] if "arguments" in e else shlex.split(e["command"])
    for line in open(e["file"]):
        line = line.strip()
        if line.startswith('#include "') and line.endswith('"'):
            source = line[len('#include "'):-1]
            expanded.append({"directory": e["directory"], "file": source,
                             "arguments": [source if a == e["file"] else a for a in args]})
entries = expanded
seen = set()
with open(os.path.join(work, "commands.txt"), "w") as out:
    for i, e in enumerate(entries):
        args = e["arguments"] if "arguments" in e else shlex.split(e["command"])
        if e["file"] in seen:
            continue
        seen.add(e["file"])
        # drop the output file: compile to nothing
        clean, skip = [], False
        for a in args:
            if skip:
                skip = False
                continue
            if a == "-o":
                skip = True
                continue
            clean.append(a)
        cmd = [clean[0], "-I" + eigen, "-fsyntax-only", "-w"] + clean[1:]
        out.write(json.dumps({"dir": e["directory"], "file": e["file"], "cmd": cmd}) + "\n")
        if i == 0:
            pcmd = [a for a in cmd if a != "-c" and a != e["file"]] + ["-c", probe]
            out.write(json.dumps({"dir": e["directory"], "file": probe, "cmd": pcmd}) + "\n")
PY
total=$(wc -l < "$work/commands.txt")
echo "compat: compiling $((total - 1)) translation units against $(basename "$eigen") (+1 version probe), ${NE_JOBS:-2} at a time"
export work
run_one() {
  python3 -c '
import json, subprocess, sys
e = json.loads(sys.argv[1])
r = subprocess.run(e["cmd"], cwd=e["dir"], capture_output=True, text=True)
if r.returncode != 0:
    print("compat: FAIL: " + e["file"])
    print("\n".join(r.stderr.splitlines()[:40]))
    sys.exit(1)
' "$1"
}
export -f run_one
if ! tr '\n' '\0' < "$work/commands.txt" | xargs -0 -n1 -P"${NE_JOBS:-2}" bash -c 'run_one "$0"'; then
  fail=1
fi
if [ "$fail" -eq 0 ]; then
  echo "compat: OK: every translation unit compiles against Eigen 3.3.7"
fi
exit "$fail"

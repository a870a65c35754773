# Shared helpers of the shell tests (sourced; WORK must be set to the test's scratch directory).
#   check NAME COMMAND...   passes when the command succeeds
#   run_rc VAR COMMAND...   runs a command (stdout to $WORK/out.txt, stderr to $WORK/err.txt) and
#                           stores its exit code in VAR without tripping set -e
#   differ A B              the files differ
#   no_files DIR            DIR is absent or holds no file (no output, no temporary file)
# The caller prints "$passed passed, $failed failed" and exits non-zero when failed > 0.
passed=0
failed=0
pass() { passed=$((passed + 1)); echo "ok   $1"; }
fail() { failed=$((failed + 1)); echo "FAIL $1"; }
check() {
  local name=$1
  shift
  if "$@"; then pass "$name"; else fail "$name"; fi
}
run_rc() {
  local __var=$1
  shift
  local __rc=0
  "$@" >"$WORK/out.txt" 2>"$WORK/err.txt" || __rc=$?
  printf -v "$__var" '%s' "$__rc"
}
differ() { ! cmp -s "$1" "$2"; }
no_files() { [ ! -e "$1" ] || [ -z "$(find "$1" -type f)" ]; }

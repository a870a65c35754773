#!/usr/bin/env bash
# Runs a test command and writes its outcome as a JUnit XML file, so that catkin's run_tests and
# catkin_test_results see the shell tests like the GoogleTest and rostest ones.
# Usage: xunit.sh RESULT_XML TEST_NAME COMMAND [ARGS...]
# Exits with the command's status; the command's output is shown as it runs.
set -uo pipefail
result="$1" name="$2"
shift 2
mkdir -p "$(dirname "$result")"
log="$(mktemp)"
start=$(date +%s.%N)
"$@" 2>&1 | tee "$log"
rc=${PIPESTATUS[0]}
elapsed=$(awk -v s="$start" -v e="$(date +%s.%N)" 'BEGIN { printf "%.3f", e - s }')
escape() { sed -e 's/&/\&amp;/g' -e 's/</\&lt;/g' -e 's/>/\&gt;/g' -e 's/"/\&quot;/g' | tr -d '\000-\010\013\014\016-\037'; }
{
  echo '<?xml version="1.0" encoding="UTF-8"?>'
  echo "<testsuite name=\"$name\" tests=\"1\" failures=\"$([ "$rc" -eq 0 ] && echo 0 || echo 1)\" errors=\"0\" time=\"$elapsed\">"
  echo "  <testcase classname=\"networked_estimation.$name\" name=\"$name\" time=\"$elapsed\">"
  if [ "$rc" -ne 0 ]; then
    echo "    <failure message=\"exit status $rc\">"
    tail -n 200 "$log" | escape
    echo "    </failure>"
  fi
  echo "    <system-out>"
  tail -n 200 "$log" | escape
  echo "    </system-out>"
  echo "  </testcase>"
  echo "</testsuite>"
} > "$result"
rm -f "$log"
exit "$rc"

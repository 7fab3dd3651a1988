#!/usr/bin/env bash
# Coverage-guided fuzzing of liff's readers (fuzz/fuzz_readers.py, atheris).
#
# Runs every reader listed by fuzz/readers.py for an equal share of FUZZ_SECONDS
# (default 60), starting from the seeds in fuzz/corpus/<reader>/; inputs that reach
# new code go to build/fuzz/corpus/<reader>/ (not into the repository; copy a useful
# one into fuzz/corpus/ by hand). A finding stops the run with a non-zero exit and
# leaves the input in build/fuzz/crash-* (or oom-*, timeout-*); replay it with
#   .venv/bin/python fuzz/fuzz_readers.py READER build/fuzz/crash-...
#
# Needs .venv (made by .ci/setup.sh); installs atheris into it if missing.
#   FUZZ_SECONDS=600 bash .ci/fuzz.sh     fuzz longer
#   FUZZ_SEED=7 bash .ci/fuzz.sh          another random seed (default 1, so CI runs repeat)
#   FUZZ_READERS="pfm" bash .ci/fuzz.sh   only these readers
set -euo pipefail
cd "$(dirname "$0")/.."
py="$PWD/.venv/bin/python"
[ -x "$py" ] || { echo "fuzz: no .venv; run 'bash .ci/setup.sh test' first" >&2; exit 2; }
"$py" -c "import atheris" 2>/dev/null ||
  "$py" -m pip install -q --disable-pip-version-check "atheris>=2.3"

seconds=${FUZZ_SECONDS:-60}
# (--list prints one name a line; other lines, e.g. an editable install's rebuild, are not names)
read -r -a names <<<"${FUZZ_READERS:-$("$py" fuzz/fuzz_readers.py --list | grep -E '^[A-Za-z0-9_-]+$' | tr '\n' ' ')}"
share=$(( seconds / ${#names[@]} ))
[ "$share" -ge 1 ] || share=1
out="$PWD/build/fuzz"
mkdir -p "$out/tmp"
for name in "${names[@]}"; do
  mkdir -p "$out/corpus/$name"
  echo "fuzz: $name for ${share} s"
  # -timeout: one input may take at most 30 s; -rss_limit_mb: libFuzzer's memory cap
  # (the target also caps its address space, see limit_memory).
  rc=0
  (cd "$out" && TMPDIR="$out/tmp" "$py" "$OLDPWD/fuzz/fuzz_readers.py" "$name" \
     -max_total_time="$share" -seed="${FUZZ_SEED:-1}" -timeout=30 -rss_limit_mb=3072 -print_final_stats=1 \
     "corpus/$name" "$OLDPWD/fuzz/corpus/$name") >"$out/$name.log" 2>&1 || rc=$?
  grep -vE '^#[0-9]+[[:space:]]+(NEW|REDUCE|pulse)|^libpng (error|warning)|^(INFO|WARNING): |^"|^######' \
    "$out/$name.log" | grep -v '^$' || true
  if [ "$rc" -ne 0 ]; then
    echo "fuzz: $name: finding (exit $rc); the input is in $out (crash-*, oom-* or timeout-*)" >&2
    exit 1
  fi
done
echo "fuzz: no new findings in ${seconds} s"

#!/usr/bin/env bash
# A fuzzing campaign: run each TARGET (default: all, most fragile first) for RUNS executions
# (default 10000000) with -rss_limit_mb=1024 -timeout=5, one target at a time. Start two of
# these at once on a 2-core machine, not more.
#
#   fuzz/campaign.sh [TARGET...] [RUNS]
#   fuzz/campaign.sh --report        # executions, coverage and crashes so far, per target
#   MAX_TIME=600 fuzz/campaign.sh ... # also stop each target after 600 s
#
# The corpus grows in fuzz/corpus/<target>/ (uncommitted; the committed seeds in
# fuzz/seeds/<target>/ are read too), so a later campaign continues where this one stopped.
# Each run logs to fuzz/logs/<target>-<UTC time>.log and appends one line to
# fuzz/logs/summary.tsv: time, target, requested runs, executions, cov, ft, exit status
# (0 clean; otherwise the crash, OOM or timeout input is in fuzz/artifacts/<target>/).
set -uo pipefail
source "$(dirname "$0")/targets.sh"
cd "$FUZZ_DIR"
mkdir -p logs corpus artifacts

if [ "${1:-}" = "--report" ]; then
  [ -f logs/summary.tsv ] || { echo "no campaign yet"; exit 0; }
  printf "%-12s %14s %7s %7s %s\n" target executions cov ft "failed runs"
  awk -F'\t' '{ ex[$2] += $4; cov[$2] = $5; ft[$2] = $6; if ($7 != 0) bad[$2]++; seen[$2] = 1 }
    END { for (t in seen) printf "%-12s %14d %7s %7s %d\n", t, ex[t], cov[t], ft[t], bad[t] }' \
    logs/summary.tsv | sort
  exit 0
fi

runs=10000000
targets=()
for a in "$@"; do
  if [[ "$a" =~ ^[0-9]+$ ]]; then runs="$a"; else targets+=("$a"); fi
done
[ ${#targets[@]} -gt 0 ] || targets=("${FUZZ_TARGETS[@]}")

cargo +nightly fuzz build "${FUZZ_BUILD_FLAGS[@]}" || exit 1
for t in "${targets[@]}"; do
  if fuzz_is_fast "$t"; then
    cargo +nightly fuzz build "${FUZZ_BUILD_FLAGS[@]}" --no-trace-compares \
      --target-dir target/fast "$t" || exit 1
  fi
done
scratch="$(fuzz_scratch)"
trap 'rm -rf "$scratch"' EXIT
export OCTOQUANT_FUZZ_TMP="$scratch"

status=0
for t in "${targets[@]}"; do
  mkdir -p "corpus/$t" "artifacts/$t"
  dict="$(fuzz_dict "$t")"
  opts=("${FUZZ_LIMITS[@]}" "-runs=$runs" "-artifact_prefix=artifacts/$t/")
  [ -n "$dict" ] && opts+=("-dict=dict/$dict.dict")
  [ -n "${MAX_TIME:-}" ] && opts+=("-max_total_time=$MAX_TIME")
  log="logs/$t-$(date -u +%Y%m%dT%H%M%SZ).log"
  echo "$(date -u +%H:%M:%S) $t: $runs runs, log $log"
  bin="$FUZZ_BIN_DIR/$t"
  fuzz_is_fast "$t" && bin="$FUZZ_FAST_DIR/$t"
  "$bin" "${opts[@]}" "corpus/$t" "seeds/$t" >"$log" 2>&1
  rc=$?
  # Final stats when the run ended normally, else the last status line.
  execs="$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)"
  [ -n "$execs" ] || execs="$(grep -o '^#[0-9][0-9]*' "$log" | tail -1 | tr -d '#')"
  cov="$(grep -o 'cov: [0-9]*' "$log" | tail -1 | cut -d' ' -f2)"
  ft="$(grep -o 'ft: [0-9]*' "$log" | tail -1 | cut -d' ' -f2)"
  printf '%s\t%s\t%s\t%s\t%s\t%s\t%s\n' "$(date -u +%FT%TZ)" "$t" "$runs" "${execs:-0}" \
    "${cov:-?}" "${ft:-?}" "$rc" >>logs/summary.tsv
  echo "$(date -u +%H:%M:%S) $t: exit $rc, ${execs:-0} executions, cov ${cov:-?} ft ${ft:-?}"
  [ $rc -eq 0 ] || status=1
done
exit $status

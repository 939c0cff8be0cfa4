#!/usr/bin/env bash
# CI smoke run: build every fuzz target, regenerate the committed seeds, then run each target
# for SECONDS (default 15) on them with the campaign's limits. Fails on any crash, OOM or
# timeout (the input is left in fuzz/artifacts/<target>/). Needs a nightly toolchain and
# cargo-fuzz.
set -euo pipefail
source "$(dirname "$0")/targets.sh"
cd "$FUZZ_DIR"
secs="${1:-15}"

start=$(date +%s)
cargo +nightly fuzz build "${FUZZ_BUILD_FLAGS[@]}"
echo "fuzz: targets built in $(($(date +%s) - start)) s"
cargo +nightly run -q -p octoquant-fuzz-seeds -- seeds

scratch="$(fuzz_scratch)"
trap 'rm -rf "$scratch"' EXIT
export OCTOQUANT_FUZZ_TMP="$scratch"
# Two targets at a time (the CI machine has 2 cores).
smoke_one() {
  local t="$1" dict opts
  # New inputs go to a throw-away corpus; the committed seeds are only read.
  mkdir -p "$scratch/corpus-$t" "artifacts/$t"
  dict="$(fuzz_dict "$t")"
  opts=("${FUZZ_LIMITS[@]}" "-max_total_time=$secs" "-artifact_prefix=artifacts/$t/")
  [ -n "$dict" ] && opts+=("-dict=dict/$dict.dict")
  if "$FUZZ_BIN_DIR/$t" "${opts[@]}" "$scratch/corpus-$t" "seeds/$t" >"$scratch/$t.log" 2>&1; then
    echo "fuzz: $t ok ($(sed -n 's/^Done \([0-9]*\) runs.*/\1/p' "$scratch/$t.log") executions)"
  else
    tail -40 "$scratch/$t.log"
    echo "fuzz: $t FAILED, input in fuzz/artifacts/$t/"
    touch "$scratch/failed-$t"
  fi
}
for t in "${FUZZ_TARGETS[@]}"; do
  while [ "$(jobs -rp | wc -l)" -ge 2 ]; do sleep 1; done
  smoke_one "$t" &
done
wait
echo "fuzz: smoke runs took $(($(date +%s) - start)) s"
failed="$(cd "$scratch" && ls failed-* 2>/dev/null | sed 's/^failed-//' | tr '\n' ' ' || true)"
if [ -n "$failed" ]; then
  echo "fuzz: failing targets: $failed"
  exit 1
fi

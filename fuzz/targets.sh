# Sourced by the fuzz scripts: the build flags, where the binaries land, and each target's
# dictionary. Every script builds and runs with the same flags so nothing rebuilds between
# them.
#
# No sanitizer: octoquant-octree and octoquant-formats forbid unsafe code, so AddressSanitizer
# would find nothing the Rust checks do not, at half the speed. Debug assertions stay on so
# integer overflow panics (a release build would wrap silently).
FUZZ_BUILD_FLAGS=(--sanitizer none --debug-assertions)
FUZZ_DIR="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
FUZZ_TRIPLE="$(rustc +nightly -vV | sed -n 's/^host: //p')"
FUZZ_BIN_DIR="$FUZZ_DIR/target/$FUZZ_TRIPLE/release"

# The parsers most likely to break first: the campaign order.
FUZZ_TARGETS=(bt ot pcd ply mcap source mcap_cloud mcap_tf lzf tum_png vtk graph text frames
  carmen tum_assoc octree_ops checkpoint color_ot count_frames binvox tile_lists tile_index rows
  distance_map stamped_ops frame_pairs color_scans color_point_clouds color_passes scan_sets)

# The dictionary of a target (empty: none).
fuzz_dict() {
  case "$1" in
    bt | ot | color_ot) echo octree ;;
    mcap_cloud | mcap_tf) echo ros_msg ;;
    count_frames) echo mcap ;;
    tum_png) echo png ;;
    tum_assoc) echo tum ;;
    source) echo compression ;;
    tile_lists | tile_index) echo tiles ;;
    octree_ops | distance_map | stamped_ops | frame_pairs | color_scans | color_point_clouds | color_passes | rows | scan_sets) echo "" ;;
    *) echo "$1" ;;
  esac
}

# The libFuzzer options every run uses.
FUZZ_LIMITS=(-rss_limit_mb=1024 -timeout=5 -max_len=8192 -print_final_stats=1)

# A per-run scratch directory on a RAM disk for the targets that read files.
fuzz_scratch() {
  local base=/dev/shm
  [ -d "$base" ] && [ -w "$base" ] || base="${TMPDIR:-/tmp}"
  mktemp -d "$base/octoquant-fuzz.XXXXXX"
}

# Targets whose campaign binary is built without comparison tracing
# (`--no-trace-compares`, in target/fast/), the slowest per input: profiles of `octree_ops`
# and `source` spent 65% and 50% of their time in the __sanitizer_cov_trace_cmp hooks (the
# whole-tree checks after every step; the decompressors' inner loops). `octree_ops` decodes
# its input with `arbitrary`, so comparison hints buy it little; `source` had reached its
# coverage plateau with them (cov 817 over its last 5 million executions). Edge coverage
# still guides both.
FUZZ_FAST_TARGETS=(octree_ops source)
FUZZ_FAST_DIR="$FUZZ_DIR/target/fast/$FUZZ_TRIPLE/release"

# Whether a target is in FUZZ_FAST_TARGETS.
fuzz_is_fast() {
  local t
  for t in "${FUZZ_FAST_TARGETS[@]}"; do [ "$t" = "$1" ] && return 0; done
  return 1
}

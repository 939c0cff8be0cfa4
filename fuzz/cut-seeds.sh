#!/usr/bin/env bash
# Cut extra campaign seeds from the real sample data into fuzz/corpus/<target>/ (uncommitted,
# gitignored: those files and pieces of them are never committed). Takes heads of files,
# single frames and the first lines of logs, small enough for -max_len=8192.
#
#   OCTOQUANT_DATA=/path/to/shared/data fuzz/cut-seeds.sh
set -euo pipefail
cd "$(dirname "$0")"
data="${OCTOQUANT_DATA:?set OCTOQUANT_DATA to the shared sample data directory}"
head_bytes=8192

put() { # put TARGET NAME: stdin into corpus/TARGET/NAME
  mkdir -p "corpus/$1"
  head -c "$head_bytes" >"corpus/$1/$2"
}
have() { [ -f "$data/$1" ]; }

ref="octomap_reference"
for f in "$data/$ref"/expected/*.bt "$data/$ref"/geb079.bt; do
  [ -f "$f" ] && put bt "cut-$(basename "$f")" <"$f"
done
for f in "$data/$ref"/expected/*.ot; do
  [ -f "$f" ] && put ot "cut-$(basename "$f")" <"$f"
done
have "$ref/spherical_scan.graph" && put graph cut-spherical_scan.graph <"$data/$ref/spherical_scan.graph"
# .frames: the first frame of each file, cut to 300 points, as a valid one-frame file
for f in "$data/$ref"/derived/*.frames; do
  [ -f "$f" ] || continue
  python3 - "$f" <<'PY' | put frames "cut-$(basename "$f")"
import struct, sys
d = open(sys.argv[1], "rb").read()
magic, version, _count = d[:8], d[8:12], d[12:16]
ox, oy, oz, n = struct.unpack_from("<fffI", d, 16)
n2 = min(n, 300)
sys.stdout.buffer.write(magic + version + struct.pack("<I", 1) + struct.pack("<fffI", ox, oy, oz, n2)
                        + d[32:32 + 12 * n2])
PY
done
for f in "$data/$ref"/derived/tiny.txt; do
  [ -f "$f" ] && head -n 60 "$f" | put text "cut-$(basename "$f")"
done
have lidar3d/octomap_scan_dat/scan.dat.bz2 &&
  { bzip2 -dc "$data/lidar3d/octomap_scan_dat/scan.dat.bz2" | head -n 200 | put text cut-scan.dat || true; }

pcd_file="$data/pcd/pcl_table_scene_mug_stereo_textured/table_scene_mug_stereo_textured.pcd"
[ -f "$pcd_file" ] && put pcd cut-table_scene_head.pcd <"$pcd_file"

vtk_dir="$data/lidar3d/norlab_icp_mapper_example"
n=0
for f in "$vtk_dir"/scans/*.vtk; do
  [ -f "$f" ] || continue
  # the header and the first 100 points, with the POINTS count to match
  python3 - "$f" <<'PY' | put vtk "cut-$(basename "$f")"
import sys
lines = open(sys.argv[1], encoding="latin-1").read().split("\n")
out, nums = [], []
for i, line in enumerate(lines):
    if line.startswith("POINTS"):
        kind = line.split()[2] if len(line.split()) > 2 else "float"
        for rest in lines[i + 1:]:
            nums += rest.split()
            if len(nums) >= 300:
                break
        out.append(f"POINTS 100 {kind}")
        out += [" ".join(nums[k:k + 3]) for k in range(0, 300, 3)]
        break
    out.append(line)
sys.stdout.write("\n".join(out) + "\n")
PY
  n=$((n + 1)); [ $n -lt 2 ] || break
done
[ -f "$vtk_dir/trajectory.csv" ] && head -n 4 "$vtk_dir/trajectory.csv" | put vtk cut-trajectory.csv

for f in "$data"/laser2d/radish_clf/*.clf.bz2; do
  [ -f "$f" ] && { bzip2 -dc "$f" | head -n 12 | put carmen "cut-$(basename "$f" .bz2)" || true; }
done
for f in "$data"/laser2d/ple_corrected_carmen/*.log.gz; do
  [ -f "$f" ] && { gzip -dc "$f" | head -n 12 | put carmen "cut-$(basename "$f" .gz)" || true; }
done
# the gz/bz2 wrappers: first byte 0 = gzip, 1 = bzip2, then the head of a compressed file
for f in "$data"/laser2d/*/*.gz "$data"/laser2d/*/*.bz2 "$data"/lidar3d/*/*.bz2; do
  [ -f "$f" ] || continue
  case "$f" in *.gz) b='\x00' ;; *) b='\x01' ;; esac
  { printf "$b"; head -c 4000 "$f"; } | put source "cut-$(basename "$f")"
done

tum_dir="$data/rgbd/tum_fr2_pioneer_slam2_subset"
[ -f "$tum_dir/my_association.txt" ] && head -n 6 "$tum_dir/my_association.txt" | put tum_assoc cut-association.txt
# depth PNGs are ~140 KB: only their head (header chunks and the start of the image data)
for f in "$tum_dir"/depth/*.png; do
  [ -f "$f" ] && { put tum_png "cut-$(basename "$f")" <"$f"; break; }
done

have mcap/pointcloudset_ouster_os1/test.mcap &&
  put mcap cut-ouster-head.mcap <"$data/mcap/pointcloudset_ouster_os1/test.mcap"

for t in corpus/*; do echo "$t: $(ls "$t" | wc -l) files"; done

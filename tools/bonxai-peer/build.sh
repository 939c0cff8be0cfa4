#!/bin/sh
# Build the Bonxai peer program from the source snapshot in ../shared/peers/bonxai (never copied
# into this repository; see that folder's README for its origin and licence).
# usage: sh tools/bonxai-peer/build.sh [OUTDIR] [BONXAI_DIR]
#   default OUTDIR target/bonxai-peer, default BONXAI_DIR ../shared/peers/bonxai
# needs: g++ libeigen3-dev
set -e
here=$(cd "$(dirname "$0")" && pwd)
out=${1:-$here/../../target/bonxai-peer}
src=${2:-$here/../../../shared/peers/bonxai}
if [ ! -f "$src/bonxai_map/src/probabilistic_map.cpp" ]; then
  echo "bonxai-peer: no Bonxai source at $src" >&2
  exit 1
fi
if [ ! -d /usr/include/eigen3 ]; then
  echo "bonxai-peer: Eigen is missing; apt-get install libeigen3-dev" >&2
  exit 1
fi
mkdir -p "$out"
# -O3 -DNDEBUG as Bonxai's own release build
g++ -std=c++17 -O3 -DNDEBUG -I /usr/include/eigen3 \
    -I "$src/bonxai_core/include" -I "$src/bonxai_map/include" \
    "$here/bonxai_peer.cpp" "$src/bonxai_map/src/probabilistic_map.cpp" \
    -o "$out/bonxai-peer.tmp"
mv "$out/bonxai-peer.tmp" "$out/bonxai-peer"
echo "built $out/bonxai-peer from $src"

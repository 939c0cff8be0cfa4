#!/bin/sh
# Build the project's C++ reference program against Debian's liboctomap-dev.
# usage: sh tools/octoquant-ref/build.sh [OUTDIR]   (default: target/octoquant-ref)
# needs: g++ pkg-config liboctomap-dev
set -e
here=$(cd "$(dirname "$0")" && pwd)
out=${1:-$here/../../target/octoquant-ref}
mkdir -p "$out"
if ! pkg-config --exists octomap; then
  echo "octoquant-ref: pkg-config cannot find octomap; apt-get install liboctomap-dev g++ pkg-config" >&2
  exit 1
fi
# -O2 with asserts on, as Debian builds liboctomap itself.
g++ -std=c++17 -O2 -Wall -Wno-deprecated-declarations \
    "$here/octoquant_ref.cpp" -o "$out/octoquant-ref.tmp" $(pkg-config --cflags --libs octomap)
mv "$out/octoquant-ref.tmp" "$out/octoquant-ref"
echo "built $out/octoquant-ref against liboctomap $(pkg-config --modversion octomap)"

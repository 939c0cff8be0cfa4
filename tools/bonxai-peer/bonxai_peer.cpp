// bonxai-peer: inserts octoquant `.frames` into Bonxai's ProbabilisticMap, for side-by-side
// benchmarks (`octoquant bench --peer bonxai=PROGRAM`). Bonxai is not part of octoquant: this
// program is built from a source snapshot outside the repository (see build.sh).
//
//   bonxai-peer RES FRAMES [MAX_RANGE]
//
// Inserts every frame with ProbabilisticMap::insertPointCloud (OctoMap's default sensor
// model, Bonxai's integer rays), MAX_RANGE <= 0 or absent meaning none, and prints
//   frame I POINTS SECONDS      per frame (wall time of the insertion alone)
//   memory BYTES                the grid's own memory use at the end
//   voxels OCCUPIED FREE        voxel counts at the end
//
// frames file (little-endian): "OCTFRAME", u32 version (1 or 2), u32 count, per frame f32
// origin[3], u32 n, [version 2: u32 flags, f64 stamp if flags & 1], n x f32[3], [n x u8 rgb
// if flags & 2], [u32 w, u32 h, 13 x f64, n x u32 pixels if flags & 4]; only the origin and
// points are used (octoquant's formats/src/frames.rs defines the layout).

#include <bonxai_map/probabilistic_map.hpp>

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

[[noreturn]] static void die(const std::string& msg) {
  std::cerr << "bonxai-peer: " << msg << std::endl;
  std::exit(2);
}

template <typename T>
static T get(std::istream& in, const std::string& path, const char* what) {
  T v;
  in.read(reinterpret_cast<char*>(&v), sizeof v);
  if (!in) die(path + ": truncated at " + what);
  return v;
}

struct Frame {
  Eigen::Vector3d origin;
  std::vector<Eigen::Vector3d> points;
};

static std::vector<Frame> read_frames(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) die("cannot open " + path);
  char magic[8];
  in.read(magic, 8);
  if (!in || std::memcmp(magic, "OCTFRAME", 8) != 0) die(path + ": not a frames file");
  const uint32_t version = get<uint32_t>(in, path, "version");
  if (version != 1 && version != 2) die(path + ": unsupported frames version");
  const uint32_t count = get<uint32_t>(in, path, "frame count");
  std::vector<Frame> frames;
  for (uint32_t f = 0; f < count; ++f) {
    Frame fr;
    float o[3];
    for (float& v : o) v = get<float>(in, path, "origin");
    fr.origin = Eigen::Vector3d(o[0], o[1], o[2]);
    const uint32_t n = get<uint32_t>(in, path, "point count");
    const uint32_t flags = version >= 2 ? get<uint32_t>(in, path, "flags") : 0;
    if (flags & ~7u) die(path + ": unknown frame flags");
    if (flags & 1) get<double>(in, path, "stamp");
    std::vector<float> raw(static_cast<size_t>(n) * 3);
    in.read(reinterpret_cast<char*>(raw.data()), static_cast<std::streamsize>(raw.size() * 4));
    if (!in) die(path + ": truncated in frame " + std::to_string(f));
    // colours and camera: not used here
    const uint64_t extra =
        ((flags & 2) ? 3ull * n : 0) + ((flags & 4) ? 8 + 13 * 8 + 4ull * n : 0);
    if (extra) {
      in.ignore(static_cast<std::streamsize>(extra));
      if (in.gcount() != static_cast<std::streamsize>(extra)) {
        die(path + ": truncated in frame " + std::to_string(f));
      }
    }
    fr.points.reserve(n);
    for (uint32_t i = 0; i < n; ++i) {
      fr.points.emplace_back(raw[3 * i], raw[3 * i + 1], raw[3 * i + 2]);
    }
    frames.push_back(std::move(fr));
  }
  return frames;
}

int main(int argc, char** argv) {
  if (argc < 3 || argc > 4) die("usage: bonxai-peer RES FRAMES [MAX_RANGE]");
  const double res = std::strtod(argv[1], nullptr);
  if (!(res > 0)) die("resolution must be > 0");
  double max_range = argc == 4 ? std::strtod(argv[3], nullptr) : 0.0;
  if (!(max_range > 0)) max_range = 1e12;
  const std::vector<Frame> frames = read_frames(argv[2]);
  Bonxai::ProbabilisticMap map(res);
  for (size_t i = 0; i < frames.size(); ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    map.insertPointCloud(frames[i].points, frames[i].origin, max_range);
    const std::chrono::duration<double> dt = std::chrono::steady_clock::now() - t0;
    std::printf("frame %zu %zu %.9f\n", i, frames[i].points.size(), dt.count());
  }
  std::vector<Bonxai::CoordT> occupied, free_cells;
  map.getOccupiedVoxels(occupied);
  map.getFreeVoxels(free_cells);
  std::printf("memory %zu\n", map.grid().memUsage());
  std::printf("voxels %zu %zu\n", occupied.size(), free_cells.size());
  return 0;
}

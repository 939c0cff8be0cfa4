// octoquant-ref: the project's own reference program around Debian's liboctomap (1.9.7).
//
// It executes the same operations as the Rust implementation so the tests can compare the
// resulting bytes. Every mode reads and writes plain files; see README.md beside this file.
//
//   octoquant-ref script FILE|-          run a command script (one command per line)
//   octoquant-ref color-script FILE|-    the same on a ColorOcTree, with the colour commands
//   octoquant-ref stamped-script FILE|-  the same on an OcTreeStamped, with the clock commands
//   octoquant-ref rays RES IN OUT        computeRayKeys for a batch of rays
//   octoquant-ref castray TREE IN OUT    castRay on a .bt/.ot tree for a batch of rays
//   octoquant-ref keys RES IN OUT        coordToKeyChecked / coordToKey / keyToCoord
//   octoquant-ref graph2frames IN OUT    ScanGraph -> world-coordinate frames (graph2tree's transform)
//
// Script commands:
//   tree RES                          new empty OcTree
//   params PHIT PMISS PMIN PMAX PTHR  sensor model as probabilities
//   hit|miss KX KY KZ LAZY            updateNode(key, bool, lazy)
//   update KX KY KZ HEXBITS LAZY      updateNode(key, float log-odds delta given as f32 bits)
//   set KX KY KZ HEXBITS LAZY         setNodeValue(key, float, lazy)
//   delete KX KY KZ DEPTH             deleteNode(key, depth)
//   prune | expand | ml | inner       prune(), expand(), toMaxLikelihood(), updateInnerOccupancy()
//   expand_node|prune_node KX KY KZ DEPTH, create_child|delete_child KX KY KZ DEPTH I
//                                     expandNode / pruneNode / createNodeChild / deleteNodeChild
//                                     on the node at exactly DEPTH holding the key (walked down
//                                     child by child); skipped when there is no such node or
//                                     OctoMap would assert (expanding a node with children or a
//                                     voxel, creating an existing child, deleting a missing one);
//                                     delete_child deletes a leaf child only
//   log_odds KX KY KZ DEPTH HEXBITS, integrate_hit|integrate_miss|node_ml KX KY KZ DEPTH
//                                     updateNodeLogOdds (float given as f32 bits) /
//                                     integrateHit / integrateMiss / nodeToMaxLikelihood on the
//                                     node at exactly DEPTH holding the key; skipped when there
//                                     is none
//   write_ot PATH                     tree.write(PATH)
//   write_bt PATH                     tree.writeBinary(PATH)  (ML + prune, mutates)
//   write_bt_const PATH               tree.writeBinaryConst(PATH)
//   read_bt PATH | read_ot PATH       replace the tree by the file's
//   insert FRAMES [maxrange M] [discretize] [lazy] [simple] [inner] [ground GROUND]
//                                     insertPointCloud per frame (or insertPointCloudRays with
//                                     simple); "inner" calls updateInnerOccupancy at the end;
//                                     prints "frame I POINTS SECONDS" per frame. With ground,
//                                     frame I of GROUND (a frames file) holds ground points that
//                                     octomap_server inserts as free space: insertPointCloud's
//                                     steps (computeUpdate, then updateNode false on each free
//                                     key, true on each occupied one) with each ground point's
//                                     ray (cut at M as computeUpdate cuts) added to the free keys
//   print_size                        prints "size N"
//   changes_on | changes_reset        enableChangeDetection(true) / resetChangeDetection()
//   print_changes                     prints "change KX KY KZ NEW" per changed key, sorted
//   print_changes_ordered             the same in the changed-keys map's iteration order
//
// Colour commands (color-script only; "inner" is then ColorOcTree::updateInnerOccupancy, skipped
// on an empty tree where OctoMap 1.9.7 crashes, and read_ot expects a ColorOcTree):
//   color|avgcolor|intcolor KX KY KZ R G B
//                                     setNodeColor / averageNodeColor / integrateNodeColor
//   points FILE LAZY                  per point: updateNode(point, true, lazy), then
//                                     integrateNodeColor(x, y, z, r, g, b)
//   colorscan FRAMES COLORS average|integrate [MAXRANGE [GROUND]]
//                                     per frame, octomap_server's colour insertScan (GROUND: its
//                                     ground points, frame I of a frames file, whose rays go into
//                                     the free KeySet first, cut at MAXRANGE; no end key; MAXRANGE
//                                     its sensor_model/max_range, default -1:
//                                     a farther point frees its ray cut there and the cut
//                                     end's voxel, nothing else): per point in order, its ray's keys
//                                     into a free KeySet, its key into an occupied KeySet and
//                                     averageNodeColor (or integrateNodeColor) at the point;
//                                     then updateNode(false) on each free key not occupied,
//                                     updateNode(true) on each occupied key; then prune()
//
// Clock commands (stamped-script only; the program defines time() itself, so OctoMap's
// time(NULL) calls, made inside liboctomap, read this clock instead of the system's):
//   clock T                           time(NULL) returns T from now on
//   degrade THRES                     degradeOutdatedNodes(THRES)
//   print_last_update                 prints "last_update T" (getLastUpdateTime; 0 if empty)
//   print_nodes                       prints "node DEPTH KX KY KZ VALUEBITS STAMP" per node,
//                                     pre-order, children 0..7, KX KY KZ the smallest voxel key
//   insert ... stamps START STEP      frame I is inserted at time START + I * STEP
//   stamp KX KY KZ DEPTH T, touch|miss_no_time KX KY KZ DEPTH
//                                     setTimestamp(T) / updateTimestamp() /
//                                     integrateMissNoTime on the node at exactly DEPTH holding
//                                     the key; skipped when there is none
//
// Binary files are little-endian. frames: "OCTFRAME", u32 version (1 or 2), u32 count, per
// frame f32 origin[3], u32 n, [version 2: u32 flags, f64 stamp if flags & 1], n x f32[3],
// [n x u8 rgb if flags & 2], [u32 w, u32 h, 13 x f64, n x u32 pixels if flags & 4]; only
// the origin and points are used (octoquant's formats/src/frames.rs defines the layout). Coloured points (points): u32 n, n x (f32[3], u8 r g b,
// u8 padding). Frame colours (colorscan): u32 frame count, per frame u32 n, n x u8 r g b.

#include <octomap/octomap.h>
#include <octomap/OcTree.h>
#include <octomap/ColorOcTree.h>
#include <octomap/OcTreeStamped.h>

#include <algorithm>
#include <tuple>
#include <type_traits>

#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

using namespace octomap;

// The clock of stamped-script: OctoMap's OcTreeStamped reads time(NULL) inside the library;
// defining time() here interposes it (the executable's definition comes first in symbol
// lookup). Negative: the real clock.
static long long g_clock = -1;

extern "C" time_t time(time_t* out) noexcept {
  time_t now;
  if (g_clock >= 0) {
    now = static_cast<time_t>(g_clock);
  } else {
    struct timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    now = ts.tv_sec;
  }
  if (out) *out = now;
  return now;
}

// Pre-order dump of an OcTreeStamped: depth, smallest voxel key, value bits, stamp.
static void print_stamped_nodes(const OcTreeStamped& tree, const OcTreeNodeStamped* n,
                                unsigned depth, unsigned kx, unsigned ky, unsigned kz) {
  float v = n->getLogOdds();
  uint32_t bits;
  std::memcpy(&bits, &v, 4);
  std::printf("node %u %u %u %u %08x %u\n", depth, kx, ky, kz, bits, n->getTimestamp());
  if (!tree.nodeHasChildren(n)) return;
  unsigned half = 1u << (15 - depth);
  for (unsigned i = 0; i < 8; ++i) {
    if (!tree.nodeChildExists(n, i)) continue;
    print_stamped_nodes(tree, tree.getNodeChild(n, i), depth + 1, kx | ((i & 1) ? half : 0),
                        ky | ((i & 2) ? half : 0), kz | ((i & 4) ? half : 0));
  }
}

[[noreturn]] static void die(const std::string& msg) {
  std::cerr << "octoquant-ref: " << msg << std::endl;
  std::exit(2);
}

template <typename T>
static T get(std::istream& in, const char* what) {
  T v;
  in.read(reinterpret_cast<char*>(&v), sizeof(T));
  if (!in) die(std::string("truncated input reading ") + what);
  return v;
}

template <typename T>
static void put(std::ostream& out, T v) {
  out.write(reinterpret_cast<const char*>(&v), sizeof(T));
}

static float bits_to_float(const std::string& hex) {
  uint32_t b = static_cast<uint32_t>(std::stoul(hex, nullptr, 16));
  float f;
  std::memcpy(&f, &b, 4);
  return f;
}

struct Frame {
  point3d origin;
  Pointcloud cloud;
};

static std::vector<Frame> read_frames(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) die("cannot open " + path);
  char magic[8];
  in.read(magic, 8);
  if (!in || std::memcmp(magic, "OCTFRAME", 8) != 0) die(path + ": not a frames file");
  uint32_t version = get<uint32_t>(in, "version");
  if (version != 1 && version != 2) die(path + ": unsupported frames version");
  uint32_t count = get<uint32_t>(in, "frame count");
  std::vector<Frame> frames;
  for (uint32_t f = 0; f < count; ++f) {
    Frame fr;
    float o[3];
    for (float& v : o) v = get<float>(in, "origin");
    fr.origin = point3d(o[0], o[1], o[2]);
    uint32_t n = get<uint32_t>(in, "point count");
    uint32_t flags = version >= 2 ? get<uint32_t>(in, "flags") : 0;
    if (flags & ~7u) die(path + ": unknown frame flags");
    if (flags & 1) get<double>(in, "stamp");
    fr.cloud.reserve(n);
    for (uint32_t i = 0; i < n; ++i) {
      float p[3];
      for (float& v : p) v = get<float>(in, "point");
      fr.cloud.push_back(p[0], p[1], p[2]);
    }
    // colours and camera: not used here
    uint64_t extra = ((flags & 2) ? 3ull * n : 0) + ((flags & 4) ? 8 + 13 * 8 + 4ull * n : 0);
    if (extra) {
      in.ignore(static_cast<std::streamsize>(extra));
      if (in.gcount() != static_cast<std::streamsize>(extra)) die(path + ": truncated frame");
    }
    frames.push_back(std::move(fr));
  }
  return frames;
}

static OcTreeKey key_from(std::istringstream& ls) {
  unsigned kx, ky, kz;
  if (!(ls >> kx >> ky >> kz)) die("expected a key KX KY KZ");
  return OcTreeKey(kx, ky, kz);
}

static bool lazy_from(std::istringstream& ls) {
  int lazy = 0;
  ls >> lazy;
  return lazy != 0;
}

static uint8_t byte_from(std::istringstream& ls) {
  unsigned v;
  if (!(ls >> v) || v > 255) die("expected a colour channel 0..255");
  return static_cast<uint8_t>(v);
}

// Coloured points: u32 n, n x (f32 x y z, u8 r g b, u8 padding).
static void insert_colored_points(ColorOcTree& tree, const std::string& path, bool lazy) {
  std::ifstream in(path, std::ios::binary);
  if (!in) die("cannot open " + path);
  uint32_t n = get<uint32_t>(in, "point count");
  for (uint32_t i = 0; i < n; ++i) {
    float p[3];
    for (float& v : p) v = get<float>(in, "point");
    uint8_t c[4];
    for (uint8_t& v : c) v = get<uint8_t>(in, "colour");
    tree.updateNode(point3d(p[0], p[1], p[2]), true, lazy);
    tree.integrateNodeColor(p[0], p[1], p[2], c[0], c[1], c[2]);
  }
}

// The rays of ground points into free_cells, as octomap_server's insertScan inserts its
// ground points: each cut at max_range (when >= 0) as computeUpdate cuts a farther point, the
// ray's keys free, the end's voxel left alone.
template <class TREE>
static void add_ground_rays(const TREE& tree, const Frame& ground, const point3d& origin,
                            double max_range, KeySet& free_cells) {
  KeyRay ray;
  for (size_t i = 0; i < ground.cloud.size(); ++i) {
    point3d p = ground.cloud[i];
    if (!(max_range < 0.0 || (p - origin).norm() <= max_range))
      p = origin + (p - origin).normalized() * (float)max_range;
    if (tree.computeRayKeys(origin, p, ray)) free_cells.insert(ray.begin(), ray.end());
  }
}

// octomap_server's insertScan as its colour server builds it (COLOR_OCTOMAP_SERVER), without
// ground filtering: the colours merge while the key sets are collected, before the scan's
// occupancy updates; the map is pruned after each scan (compress_map). max_range < 0: none;
// else a farther point's ray is cut there and frees the cut end's voxel too (its "ray longer
// than maxrange" branch).
static void insert_colored_scans(ColorOcTree& tree, const std::string& frames_path,
                                 const std::string& colors_path, bool integrate,
                                 double max_range, const std::string& ground_path) {
  std::vector<Frame> frames = read_frames(frames_path);
  std::vector<Frame> ground;
  if (!ground_path.empty()) {
    ground = read_frames(ground_path);
    if (ground.size() != frames.size()) die(ground_path + ": frame count differs");
  }
  size_t f = 0;
  std::ifstream in(colors_path, std::ios::binary);
  if (!in) die("cannot open " + colors_path);
  uint32_t count = get<uint32_t>(in, "colour frame count");
  if (count != frames.size()) die(colors_path + ": frame count differs from the frames file");
  KeyRay ray;
  for (const Frame& fr : frames) {
    uint32_t n = get<uint32_t>(in, "colour count");
    if (n != fr.cloud.size()) die(colors_path + ": colour count differs from the point count");
    KeySet free_cells, occupied_cells;
    if (!ground.empty()) add_ground_rays(tree, ground[f], fr.origin, max_range, free_cells);
    ++f;
    for (uint32_t i = 0; i < n; ++i) {
      uint8_t c[3];
      for (uint8_t& v : c) v = get<uint8_t>(in, "colour");
      const point3d& p = fr.cloud[i];
      // PCL's filters hand octomap_server no NaN point
      if (!std::isfinite(p.x()) || !std::isfinite(p.y()) || !std::isfinite(p.z())) continue;
      if (!(max_range < 0.0 || (p - fr.origin).norm() <= max_range)) {
        point3d new_end = fr.origin + (p - fr.origin).normalized() * max_range;
        if (tree.computeRayKeys(fr.origin, new_end, ray)) {
          free_cells.insert(ray.begin(), ray.end());
          OcTreeKey end_key;
          if (tree.coordToKeyChecked(new_end, end_key)) free_cells.insert(end_key);
        }
        continue;
      }
      if (tree.computeRayKeys(fr.origin, p, ray)) free_cells.insert(ray.begin(), ray.end());
      OcTreeKey key;
      if (tree.coordToKeyChecked(p, key)) {
        occupied_cells.insert(key);
        if (integrate)
          tree.integrateNodeColor(p.x(), p.y(), p.z(), c[0], c[1], c[2]);
        else
          tree.averageNodeColor(p.x(), p.y(), p.z(), c[0], c[1], c[2]);
      }
    }
    for (KeySet::iterator it = free_cells.begin(); it != free_cells.end(); ++it)
      if (occupied_cells.find(*it) == occupied_cells.end()) tree.updateNode(*it, false);
    for (KeySet::iterator it = occupied_cells.begin(); it != occupied_cells.end(); ++it)
      tree.updateNode(*it, true);
    tree.prune();
  }
}

// The node at exactly DEPTH holding the key, walked down from the root child by child
// (search() would stop at a pruned leaf above it); NULL when there is none.
template <class TREE>
static typename TREE::NodeType* node_at_depth(TREE& tree, const OcTreeKey& key, unsigned depth) {
  typename TREE::NodeType* n = tree.getRoot();
  if (!n || depth > 16) return nullptr;
  for (unsigned d = 0; d < depth; ++d) {
    unsigned idx = computeChildIdx(key, 15 - d);
    if (!tree.nodeChildExists(n, idx)) return nullptr;
    n = tree.getNodeChild(n, idx);
  }
  return n;
}

// TREE is OcTree ("script"), ColorOcTree ("color-script") or OcTreeStamped
// ("stamped-script").
template <class TREE>
static int run_script(std::istream& in) {
  constexpr bool color = std::is_same<TREE, ColorOcTree>::value;
  constexpr bool stamped = std::is_same<TREE, OcTreeStamped>::value;
  std::unique_ptr<TREE> tree(new TREE(0.1));
  std::string line;
  size_t lineno = 0;
  while (std::getline(in, line)) {
    ++lineno;
    std::istringstream ls(line);
    std::string cmd;
    if (!(ls >> cmd) || cmd[0] == '#') continue;
    if (cmd == "tree") {
      std::string res;
      ls >> res;
      tree.reset(new TREE(std::strtod(res.c_str(), nullptr)));
    } else if (cmd == "params") {
      double hit, miss, cmin, cmax, thr;
      if (!(ls >> hit >> miss >> cmin >> cmax >> thr)) die("params needs 5 probabilities");
      tree->setProbHit(hit);
      tree->setProbMiss(miss);
      tree->setClampingThresMin(cmin);
      tree->setClampingThresMax(cmax);
      tree->setOccupancyThres(thr);
    } else if (cmd == "hit" || cmd == "miss") {
      OcTreeKey k = key_from(ls);
      tree->updateNode(k, cmd == "hit", lazy_from(ls));
    } else if (cmd == "update" || cmd == "set") {
      OcTreeKey k = key_from(ls);
      std::string hex;
      ls >> hex;
      float v = bits_to_float(hex);
      bool lazy = lazy_from(ls);
      if (cmd == "update")
        tree->updateNode(k, v, lazy);
      else
        tree->setNodeValue(k, v, lazy);
    } else if (cmd == "delete") {
      OcTreeKey k = key_from(ls);
      unsigned depth = 0;
      ls >> depth;
      tree->deleteNode(k, depth);
    } else if (cmd == "expand_node" || cmd == "prune_node" || cmd == "create_child" ||
               cmd == "delete_child") {
      // node surgery on the node at exactly DEPTH holding the key; a call OctoMap would
      // assert on or that has nothing to act on is skipped (the Rust side skips it too)
      OcTreeKey k = key_from(ls);
      unsigned depth = 0, idx = 0;
      if (!(ls >> depth)) die(cmd + " needs KX KY KZ DEPTH");
      if (cmd == "create_child" || cmd == "delete_child") {
        if (!(ls >> idx) || idx > 7) die(cmd + " needs a child index 0..7");
      }
      auto* n = node_at_depth(*tree, k, depth);
      if (!n) continue;
      if (cmd == "expand_node") {
        if (depth < 16 && !tree->nodeHasChildren(n)) tree->expandNode(n);
      } else if (cmd == "prune_node") {
        if (tree->nodeHasChildren(n)) tree->pruneNode(n);
      } else if (cmd == "create_child") {
        if (depth < 16 && !tree->nodeChildExists(n, idx)) tree->createNodeChild(n, idx);
      } else if (tree->nodeChildExists(n, idx) &&
                 !tree->nodeHasChildren(tree->getNodeChild(n, idx))) {
        // a leaf child only: OctoMap's deleteNodeChild takes one node off size() whatever
        // the subtree, so a deeper subtree would leave its size (in the .ot header) wrong
        tree->deleteNodeChild(n, idx);
      }
    } else if (cmd == "log_odds" || cmd == "integrate_hit" || cmd == "integrate_miss" ||
               cmd == "node_ml") {
      OcTreeKey k = key_from(ls);
      unsigned depth = 0;
      if (!(ls >> depth)) die(cmd + " needs KX KY KZ DEPTH");
      float v = 0.0f;
      if (cmd == "log_odds") {
        std::string hex;
        if (!(ls >> hex)) die("log_odds needs KX KY KZ DEPTH HEXBITS");
        v = bits_to_float(hex);
      }
      auto* n = node_at_depth(*tree, k, depth);
      if (!n) continue;
      if (cmd == "log_odds")
        tree->updateNodeLogOdds(n, v);
      else if (cmd == "integrate_hit")
        tree->integrateHit(n);
      else if (cmd == "integrate_miss")
        tree->integrateMiss(n);
      else
        tree->nodeToMaxLikelihood(n);
    } else if (cmd == "prune") {
      tree->prune();
    } else if (cmd == "expand") {
      tree->expand();
    } else if (cmd == "ml") {
      tree->toMaxLikelihood();
    } else if (cmd == "inner") {
      // ColorOcTree::updateInnerOccupancy of 1.9.7 dereferences a null root (segfault);
      // an empty tree has no inner node to update, so skip it there
      if (!color || tree->getRoot() != nullptr) tree->updateInnerOccupancy();
    } else if (cmd == "write_ot") {
      std::string p;
      ls >> p;
      if (!tree->write(p)) die("write_ot failed: " + p);
    } else if (cmd == "write_bt") {
      std::string p;
      ls >> p;
      if (!tree->writeBinary(p)) die("write_bt failed: " + p);
    } else if (cmd == "write_bt_const") {
      std::string p;
      ls >> p;
      if (!tree->writeBinaryConst(p)) die("write_bt_const failed: " + p);
    } else if (cmd == "read_bt") {
      std::string p;
      ls >> p;
      tree.reset(new TREE(0.1));
      if (!tree->readBinary(p)) die("read_bt failed: " + p);
    } else if (cmd == "read_ot") {
      std::string p;
      ls >> p;
      AbstractOcTree* t = AbstractOcTree::read(p);
      TREE* ot = dynamic_cast<TREE*>(t);
      if (!ot) die("read_ot failed: " + p);
      tree.reset(ot);
    } else if (cmd == "insert") {
      std::string p, opt;
      ls >> p;
      double maxrange = -1.0;
      bool discretize = false, lazy = false, simple = false, inner = false;
      long long stamp_start = -1, stamp_step = 0;
      std::string ground_path;
      while (ls >> opt) {
        if (opt == "maxrange") ls >> maxrange;
        else if (opt == "ground") ls >> ground_path;
        else if (opt == "stamps") ls >> stamp_start >> stamp_step;
        else if (opt == "discretize") discretize = true;
        else if (opt == "lazy") lazy = true;
        else if (opt == "simple") simple = true;
        else if (opt == "inner") inner = true;
        else die("unknown insert option " + opt);
      }
      std::vector<Frame> frames = read_frames(p);
      std::vector<Frame> ground;
      if (!ground_path.empty()) {
        if (simple || discretize) die("insert: ground only with the default insertion");
        ground = read_frames(ground_path);
        if (ground.size() != frames.size()) die(ground_path + ": frame count differs");
      }
      for (size_t i = 0; i < frames.size(); ++i) {
        if (stamp_start >= 0) g_clock = stamp_start + static_cast<long long>(i) * stamp_step;
        auto t0 = std::chrono::steady_clock::now();
        if (!ground.empty()) {
          KeySet free_cells, occupied_cells;
          tree->computeUpdate(frames[i].cloud, frames[i].origin, free_cells, occupied_cells,
                              maxrange);
          add_ground_rays(*tree, ground[i], frames[i].origin, maxrange, free_cells);
          for (KeySet::iterator it = free_cells.begin(); it != free_cells.end(); ++it)
            if (occupied_cells.find(*it) == occupied_cells.end()) tree->updateNode(*it, false, lazy);
          for (KeySet::iterator it = occupied_cells.begin(); it != occupied_cells.end(); ++it)
            tree->updateNode(*it, true, lazy);
        } else if (simple)
          tree->insertPointCloudRays(frames[i].cloud, frames[i].origin, maxrange, lazy);
        else
          tree->insertPointCloud(frames[i].cloud, frames[i].origin, maxrange, lazy, discretize);
        auto t1 = std::chrono::steady_clock::now();
        std::printf("frame %zu %zu %.9f\n", i, frames[i].cloud.size(),
                    std::chrono::duration<double>(t1 - t0).count());
      }
      if (inner) {
        auto t0 = std::chrono::steady_clock::now();
        tree->updateInnerOccupancy();
        auto t1 = std::chrono::steady_clock::now();
        std::printf("inner %.9f\n", std::chrono::duration<double>(t1 - t0).count());
      }
    } else if (cmd == "changes_on") {
      tree->enableChangeDetection(true);
    } else if (cmd == "changes_reset") {
      tree->resetChangeDetection();
    } else if (cmd == "print_changes") {
      std::vector<std::tuple<unsigned, unsigned, unsigned, int>> v;
      for (KeyBoolMap::const_iterator it = tree->changedKeysBegin(); it != tree->changedKeysEnd(); ++it)
        v.emplace_back(it->first[0], it->first[1], it->first[2], it->second ? 1 : 0);
      std::sort(v.begin(), v.end());
      for (auto& t : v)
        std::printf("change %u %u %u %d\n", std::get<0>(t), std::get<1>(t), std::get<2>(t), std::get<3>(t));
    } else if (cmd == "print_changes_ordered") {
      for (KeyBoolMap::const_iterator it = tree->changedKeysBegin(); it != tree->changedKeysEnd(); ++it)
        std::printf("change %u %u %u %d\n", unsigned(it->first[0]), unsigned(it->first[1]),
                    unsigned(it->first[2]), it->second ? 1 : 0);
    } else if (cmd == "print_size") {
      std::printf("size %zu\n", tree->size());
    } else if (color && (cmd == "color" || cmd == "avgcolor" || cmd == "intcolor")) {
      if constexpr (color) {
        OcTreeKey k = key_from(ls);
        uint8_t r = byte_from(ls), g = byte_from(ls), b = byte_from(ls);
        if (cmd == "color")
          tree->setNodeColor(k, r, g, b);
        else if (cmd == "avgcolor")
          tree->averageNodeColor(k, r, g, b);
        else
          tree->integrateNodeColor(k, r, g, b);
      }
    } else if (color && cmd == "points") {
      if constexpr (color) {
        std::string p;
        ls >> p;
        insert_colored_points(*tree, p, lazy_from(ls));
      }
    } else if (color && cmd == "colorscan") {
      if constexpr (color) {
        std::string frames, colors, merge;
        if (!(ls >> frames >> colors >> merge) || (merge != "average" && merge != "integrate"))
          die("colorscan needs FRAMES COLORS average|integrate [MAXRANGE]");
        double max_range = -1.0;
        std::string ground;
        if (!(ls >> max_range)) max_range = -1.0;
        else ls >> ground;
        insert_colored_scans(*tree, frames, colors, merge == "integrate", max_range, ground);
      }
    } else if (stamped && cmd == "clock") {
      if (!(ls >> g_clock) || g_clock < 0) die("clock needs a time >= 0");
    } else if (stamped && cmd == "degrade") {
      if constexpr (stamped) {
        unsigned thres = 0;
        if (!(ls >> thres)) die("degrade needs a threshold");
        tree->degradeOutdatedNodes(thres);
      }
    } else if (stamped && (cmd == "stamp" || cmd == "touch" || cmd == "miss_no_time")) {
      if constexpr (stamped) {
        OcTreeKey k = key_from(ls);
        unsigned depth = 0, t = 0;
        if (!(ls >> depth)) die(cmd + " needs KX KY KZ DEPTH");
        if (cmd == "stamp" && !(ls >> t)) die("stamp needs KX KY KZ DEPTH T");
        auto* n = node_at_depth(*tree, k, depth);
        if (!n) continue;
        if (cmd == "stamp")
          n->setTimestamp(t);
        else if (cmd == "touch")
          n->updateTimestamp();
        else
          tree->integrateMissNoTime(n);
      }
    } else if (stamped && cmd == "print_last_update") {
      if constexpr (stamped) {
        std::printf("last_update %u\n", tree->getRoot() ? tree->getLastUpdateTime() : 0u);
      }
    } else if (stamped && cmd == "print_nodes") {
      if constexpr (stamped) {
        if (tree->getRoot()) print_stamped_nodes(*tree, tree->getRoot(), 0, 0, 0, 0);
      }
    } else {
      die("line " + std::to_string(lineno) + ": unknown command " + cmd);
    }
  }
  std::fflush(stdout);
  return 0;
}

// rays: IN = u32 n, n x f32[6] (origin, end). OUT per ray: u8 ok, u32 count, count x u16[3].
static int run_rays(double res, const std::string& inpath, const std::string& outpath) {
  OcTree tree(res);
  std::ifstream in(inpath, std::ios::binary);
  if (!in) die("cannot open " + inpath);
  std::ofstream out(outpath, std::ios::binary);
  uint32_t n = get<uint32_t>(in, "ray count");
  KeyRay ray;
  for (uint32_t i = 0; i < n; ++i) {
    float v[6];
    for (float& x : v) x = get<float>(in, "ray");
    bool ok = tree.computeRayKeys(point3d(v[0], v[1], v[2]), point3d(v[3], v[4], v[5]), ray);
    put<uint8_t>(out, ok ? 1 : 0);
    put<uint32_t>(out, ok ? static_cast<uint32_t>(ray.size()) : 0);
    if (ok)
      for (const OcTreeKey& k : ray)
        for (int a = 0; a < 3; ++a) put<uint16_t>(out, k[a]);
  }
  return out ? 0 : 2;
}

// castray: IN = u32 n, per ray f32[3] origin, f32[3] direction, u8 ignore_unknown, f64 max_range.
// OUT per ray: u8 result, f32[3] end.
static int run_castray(const std::string& treepath, const std::string& inpath,
                       const std::string& outpath) {
  std::unique_ptr<OcTree> tree;
  if (treepath.size() > 3 && treepath.substr(treepath.size() - 3) == ".ot") {
    tree.reset(dynamic_cast<OcTree*>(AbstractOcTree::read(treepath)));
  } else {
    tree.reset(new OcTree(0.1));
    if (!tree->readBinary(treepath)) tree.reset();
  }
  if (!tree) die("cannot read tree " + treepath);
  std::ifstream in(inpath, std::ios::binary);
  if (!in) die("cannot open " + inpath);
  std::ofstream out(outpath, std::ios::binary);
  uint32_t n = get<uint32_t>(in, "ray count");
  for (uint32_t i = 0; i < n; ++i) {
    float o[3], d[3];
    for (float& x : o) x = get<float>(in, "origin");
    for (float& x : d) x = get<float>(in, "direction");
    uint8_t ignore = get<uint8_t>(in, "ignore_unknown");
    double maxr = get<double>(in, "max_range");
    point3d end;
    bool hit = tree->castRay(point3d(o[0], o[1], o[2]), point3d(d[0], d[1], d[2]), end,
                             ignore != 0, maxr);
    put<uint8_t>(out, hit ? 1 : 0);
    for (int a = 0; a < 3; ++a) put<float>(out, end(a));
  }
  return out ? 0 : 2;
}

// keys: IN = u32 n, n x f64. OUT per value: u8 checked_ok, u16 checked, u16 unchecked, f64 centre.
static int run_keys(double res, const std::string& inpath, const std::string& outpath) {
  OcTree tree(res);
  std::ifstream in(inpath, std::ios::binary);
  if (!in) die("cannot open " + inpath);
  std::ofstream out(outpath, std::ios::binary);
  uint32_t n = get<uint32_t>(in, "count");
  for (uint32_t i = 0; i < n; ++i) {
    double c = get<double>(in, "coordinate");
    key_type k = 0;
    bool ok = tree.coordToKeyChecked(c, k);
    key_type u = tree.coordToKey(c);
    put<uint8_t>(out, ok ? 1 : 0);
    put<uint16_t>(out, ok ? k : 0);
    put<uint16_t>(out, u);
    put<double>(out, tree.keyToCoord(u));
  }
  return out ? 0 : 2;
}

// graph2frames: a ScanGraph transformed to world coordinates exactly as graph2tree does.
static int run_graph2frames(const std::string& inpath, const std::string& outpath) {
  ScanGraph graph;
  if (!graph.readBinary(inpath)) die("cannot read graph " + inpath);
  std::ofstream out(outpath, std::ios::binary);
  out.write("OCTFRAME", 8);
  put<uint32_t>(out, 1);
  put<uint32_t>(out, static_cast<uint32_t>(graph.size()));
  for (ScanGraph::iterator it = graph.begin(); it != graph.end(); ++it) {
    (*it)->scan->transform((*it)->pose);
    point3d o = (*it)->pose.trans();
    for (int a = 0; a < 3; ++a) put<float>(out, o(a));
    put<uint32_t>(out, static_cast<uint32_t>((*it)->scan->size()));
    for (size_t i = 0; i < (*it)->scan->size(); ++i) {
      const point3d& p = (*(*it)->scan)[i];
      for (int a = 0; a < 3; ++a) put<float>(out, p(a));
    }
  }
  return out ? 0 : 2;
}

int main(int argc, char** argv) {
  if (argc < 2) die("usage: octoquant-ref script|color-script|stamped-script|rays|castray|keys|graph2frames ...");
  std::string mode = argv[1];
  if ((mode == "script" || mode == "color-script" || mode == "stamped-script") && argc == 3) {
    auto run = mode == "script"         ? run_script<OcTree>
               : mode == "color-script" ? run_script<ColorOcTree>
                                        : run_script<OcTreeStamped>;
    if (std::string(argv[2]) == "-") return run(std::cin);
    std::ifstream in(argv[2]);
    if (!in) die(std::string("cannot open ") + argv[2]);
    return run(in);
  }
  if (mode == "rays" && argc == 5) return run_rays(std::strtod(argv[2], nullptr), argv[3], argv[4]);
  if (mode == "castray" && argc == 5) return run_castray(argv[2], argv[3], argv[4]);
  if (mode == "keys" && argc == 5) return run_keys(std::strtod(argv[2], nullptr), argv[3], argv[4]);
  if (mode == "graph2frames" && argc == 4) return run_graph2frames(argv[2], argv[3]);
  die("bad arguments; see the comment at the top of octoquant_ref.cpp");
}

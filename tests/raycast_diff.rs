//! Differential tests of `octoquant-raycast` against the real OctoMap 1.9.7: ray keys
//! (`computeRayKeys`), `castRay` and whole-scan insertion (`insertPointCloud`,
//! `insertPointCloudRays`), through the project's reference program `tools/octoquant-ref`,
//! and against the graph2tree outputs stored in `$OCTOQUANT_DATA/octomap_reference/expected`.

use crate::common;
use nalgebra::Point3;
use octoquant_octree::{io, InnerNodes, Key, KeyConverter, OcTree, OccupancyParams};
use octoquant_raycast::{
    cast_ray_f32, compute_ray_keys_f32, insert_point_cloud_rays_f32,
    insert_point_cloud_reusing_f32, ApplyOptions, CastOptions, CastStop, InsertOptions, KeyRay,
    ScanUpdate,
};
use std::path::{Path, PathBuf};
use std::process::Command;

// ---------------------------------------------------------------------------------------------
// helpers

/// SplitMix64: a small fixed-seed generator, so every run tests the same rays.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }
    fn below(&mut self, n: u64) -> u64 {
        self.next() % n
    }
    fn coin(&mut self, p: f64) -> bool {
        self.unit() < p
    }
    fn unit_vec(&mut self) -> [f64; 3] {
        loop {
            let v = [
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
            ];
            let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            if n > 0.05 && n <= 1.0 {
                return [v[0] / n, v[1] / n, v[2] / n];
            }
        }
    }
}

fn p32(v: [f64; 3]) -> Point3<f32> {
    Point3::new(v[0] as f32, v[1] as f32, v[2] as f32)
}

struct Frame {
    origin: Point3<f32>,
    points: Vec<Point3<f32>>,
}

/// Reads the reference program's `.frames` layout: "OCTFRAME", u32 version 1, u32 count, per
/// frame f32 origin[3], u32 n, n x f32[3] (little-endian).
fn read_frames(path: &Path) -> Vec<Frame> {
    let b = std::fs::read(path).unwrap_or_else(|e| panic!("read {}: {e}", path.display()));
    assert_eq!(&b[..8], b"OCTFRAME", "{}", path.display());
    let u32_at = |o: usize| u32::from_le_bytes(b[o..o + 4].try_into().unwrap());
    let f32_at = |o: usize| f32::from_le_bytes(b[o..o + 4].try_into().unwrap());
    assert_eq!(u32_at(8), 1);
    let count = u32_at(12) as usize;
    let mut off = 16;
    let mut frames = Vec::with_capacity(count);
    for _ in 0..count {
        let origin = Point3::new(f32_at(off), f32_at(off + 4), f32_at(off + 8));
        let n = u32_at(off + 12) as usize;
        off += 16;
        let points = (0..n)
            .map(|i| {
                let o = off + 12 * i;
                Point3::new(f32_at(o), f32_at(o + 4), f32_at(o + 8))
            })
            .collect();
        off += 12 * n;
        frames.push(Frame { origin, points });
    }
    assert_eq!(off, b.len(), "trailing bytes in {}", path.display());
    frames
}

fn run_ref(program: &Path, args: &[&str]) {
    let out = Command::new(program)
        .args(args)
        .output()
        .expect("run the reference program");
    assert!(
        out.status.success(),
        "octoquant-ref {args:?} failed ({}): {}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
            .lines()
            .rev()
            .take(5)
            .collect::<Vec<_>>()
            .join("\n")
    );
}

/// A little-endian reader over a reference output file.
struct Reader<'a> {
    b: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    fn take<const N: usize>(&mut self) -> [u8; N] {
        let v: [u8; N] = self.b[self.at..self.at + N]
            .try_into()
            .expect("reference output truncated");
        self.at += N;
        v
    }
    fn u8(&mut self) -> u8 {
        self.take::<1>()[0]
    }
    fn u16(&mut self) -> u16 {
        u16::from_le_bytes(self.take())
    }
    fn u32(&mut self) -> u32 {
        u32::from_le_bytes(self.take())
    }
    fn f32(&mut self) -> f32 {
        f32::from_le_bytes(self.take())
    }
}

/// The resolution as text that `strtod` turns back into the very same double.
fn res_arg(res: f64) -> String {
    format!("{res:?}")
}

// ---------------------------------------------------------------------------------------------
// computeRayKeys

/// What a batch of rays exercised, so a test cannot pass on an empty or trivial batch.
#[derive(Default, Debug)]
struct RayTally {
    rays: usize,
    failed: usize,
    empty_ok: usize,
    long: usize,
    keys: usize,
}

/// Run `rays` through OctoMap and through `compute_ray_keys_f32`; every ok flag and key list must
/// match. Returns what was covered.
fn compare_rays(
    program: &Path,
    dir: &Path,
    res: f64,
    rays: &[(Point3<f32>, Point3<f32>)],
    label: &str,
) -> RayTally {
    let conv = KeyConverter::new(res).unwrap();
    let input = dir.join(format!("{label}.in"));
    let output = dir.join(format!("{label}.out"));
    let mut buf = Vec::with_capacity(4 + rays.len() * 24);
    buf.extend_from_slice(&(rays.len() as u32).to_le_bytes());
    for (o, e) in rays {
        for v in [o.x, o.y, o.z, e.x, e.y, e.z] {
            buf.extend_from_slice(&v.to_le_bytes());
        }
    }
    std::fs::write(&input, &buf).unwrap();
    drop(buf);
    run_ref(
        program,
        &[
            "rays",
            &res_arg(res),
            input.to_str().unwrap(),
            output.to_str().unwrap(),
        ],
    );
    let bytes = std::fs::read(&output).unwrap();
    let _ = std::fs::remove_file(&output);
    let _ = std::fs::remove_file(&input);
    let mut r = Reader { b: &bytes, at: 0 };
    let mut ray = KeyRay::new();
    let mut tally = RayTally::default();
    let mut mismatches = Vec::new();
    let mut theirs: Vec<Key> = Vec::new();
    for (i, (o, e)) in rays.iter().enumerate() {
        let ok = r.u8() == 1;
        let n = r.u32() as usize;
        theirs.clear();
        for _ in 0..n {
            theirs.push(Key::new(r.u16(), r.u16(), r.u16()));
        }
        let mine = compute_ray_keys_f32(&conv, o, e, &mut ray);
        tally.rays += 1;
        tally.keys += n;
        if !ok {
            tally.failed += 1;
        } else if n == 0 {
            tally.empty_ok += 1;
        }
        if n >= 1000 {
            tally.long += 1;
        }
        if mine != ok || ray.keys() != &theirs[..] {
            if mismatches.len() < 5 {
                let first_diff = ray
                    .keys()
                    .iter()
                    .zip(&theirs)
                    .position(|(a, b)| a != b)
                    .unwrap_or(ray.len().min(theirs.len()));
                mismatches.push(format!(
                    "ray {i}: {:?} -> {:?} (bits {:08x?} -> {:08x?}): ours ok={mine} n={}, \
                     octomap ok={ok} n={n}, first difference at {first_diff}: ours {:?} octomap {:?}",
                    o,
                    e,
                    [o.x.to_bits(), o.y.to_bits(), o.z.to_bits()],
                    [e.x.to_bits(), e.y.to_bits(), e.z.to_bits()],
                    ray.len(),
                    ray.keys().get(first_diff),
                    theirs.get(first_diff),
                ));
            } else {
                mismatches.push(String::new());
            }
        }
    }
    assert_eq!(r.at, bytes.len(), "{label}: trailing reference output");
    assert!(
        mismatches.is_empty(),
        "{label} (res {res}): {} of {} rays differ from OctoMap:\n{}",
        mismatches.len(),
        rays.len(),
        mismatches
            .iter()
            .filter(|m| !m.is_empty())
            .cloned()
            .collect::<Vec<_>>()
            .join("\n")
    );
    tally
}

/// A point on the voxel grid: `k·res` (a voxel boundary), computed in f64 then rounded to f32
/// as a user's coordinates would be.
fn on_grid(rng: &mut Rng, res: f64, span: i64) -> f64 {
    (rng.below(2 * span as u64) as i64 - span) as f64 * res
}

/// The ray mix: random, axis-aligned, boundary and corner, diagonal, very short, long and
/// out-of-map rays, in proportions chosen to keep the average ray around 20 voxels.
fn generate_rays(rng: &mut Rng, res: f64, n: usize) -> Vec<(Point3<f32>, Point3<f32>)> {
    let half_map = 32768.0 * res;
    let mut rays = Vec::with_capacity(n);
    while rays.len() < n {
        let kind = rng.below(100);
        let centre = [
            rng.range(-60.0, 60.0) * res,
            rng.range(-60.0, 60.0) * res,
            rng.range(-60.0, 60.0) * res,
        ];
        let ray = match kind {
            // random direction, up to 40 voxels
            0..=29 => {
                let d = rng.unit_vec();
                let l = rng.range(0.0, 40.0) * res;
                (
                    centre,
                    [
                        centre[0] + d[0] * l,
                        centre[1] + d[1] * l,
                        centre[2] + d[2] * l,
                    ],
                )
            }
            // along one axis, or in an axis plane
            30..=39 => {
                let mut e = centre;
                let axes = rng.below(3) as usize;
                e[axes] += rng.range(-30.0, 30.0) * res;
                if rng.coin(0.4) {
                    let other = (axes + 1 + rng.below(2) as usize) % 3;
                    e[other] += rng.range(-30.0, 30.0) * res;
                }
                (centre, e)
            }
            // both ends exactly on voxel boundaries / corners
            40..=54 => {
                let o = [
                    on_grid(rng, res, 50),
                    on_grid(rng, res, 50),
                    on_grid(rng, res, 50),
                ];
                let mut e = [
                    on_grid(rng, res, 50),
                    on_grid(rng, res, 50),
                    on_grid(rng, res, 50),
                ];
                if rng.coin(0.3) {
                    // mix: one end free, one coordinate shared
                    let a = rng.below(3) as usize;
                    e[a] = o[a];
                }
                (o, e)
            }
            // exact diagonals from boundaries or centres: every tie-break
            55..=64 => {
                let o = [
                    on_grid(rng, res, 40),
                    on_grid(rng, res, 40),
                    on_grid(rng, res, 40),
                ];
                let shift = if rng.coin(0.5) { 0.5 * res } else { 0.0 };
                let o = [o[0] + shift, o[1] + shift, o[2] + shift];
                let k = (rng.below(30) + 1) as f64 * res;
                let s = [
                    if rng.coin(0.5) { k } else { -k },
                    if rng.coin(0.5) { k } else { -k },
                    if rng.coin(0.7) {
                        if rng.coin(0.5) {
                            k
                        } else {
                            -k
                        }
                    } else {
                        0.0
                    },
                ];
                (o, [o[0] + s[0], o[1] + s[1], o[2] + s[2]])
            }
            // very short: same voxel or a neighbour
            65..=79 => {
                let e = [
                    centre[0] + rng.range(-0.9, 0.9) * res,
                    centre[1] + rng.range(-0.9, 0.9) * res,
                    centre[2] + rng.range(-0.9, 0.9) * res,
                ];
                (centre, e)
            }
            // voxel centre to voxel centre (what discretize casts)
            80..=87 => {
                let o = [
                    on_grid(rng, res, 60) + 0.5 * res,
                    on_grid(rng, res, 60) + 0.5 * res,
                    on_grid(rng, res, 60) + 0.5 * res,
                ];
                let e = [
                    on_grid(rng, res, 60) + 0.5 * res,
                    on_grid(rng, res, 60) + 0.5 * res,
                    on_grid(rng, res, 60) + 0.5 * res,
                ];
                (o, e)
            }
            // long: hundreds to thousands of voxels, far from the origin too
            88..=94 => {
                let far = if rng.coin(0.5) { 0.9 * half_map } else { 0.0 };
                let base = [
                    rng.range(-far, far),
                    rng.range(-far, far),
                    rng.range(-far, far),
                ];
                let d = rng.unit_vec();
                let l = if rng.coin(0.1) {
                    rng.range(3000.0, 9000.0)
                } else {
                    rng.range(100.0, 1500.0)
                } * res;
                let e = [base[0] + d[0] * l, base[1] + d[1] * l, base[2] + d[2] * l];
                (base, e)
            }
            // an end outside the map, or right at its edge
            _ => {
                let a = rng.below(3) as usize;
                let mut o = centre;
                let mut e = centre;
                let edge = if rng.coin(0.5) { half_map } else { -half_map };
                // one end within 3 voxels of the edge (either side), the other inside near it
                let near = edge + rng.range(-3.0, 3.0) * res;
                let inside = edge - edge.signum() * rng.range(0.0, 20.0) * res;
                if rng.coin(0.5) {
                    (e[a], o[a]) = (near, inside);
                } else {
                    (o[a], e[a]) = (near, inside);
                }
                (o, e)
            }
        };
        let (o, e) = (p32(ray.0), p32(ray.1));
        // OctoMap's KeyRay asserts below 100 000 keys; stay well inside
        let conv_keys = (0..3)
            .map(|i| ((e[i] - o[i]) as f64 / res).abs())
            .sum::<f64>();
        if conv_keys < 90_000.0 {
            rays.push((o, e));
        }
    }
    rays
}

fn ray_batches(res: f64, seed: u64, batches: usize, per_batch: usize) {
    let Some(program) = common::reference_program() else {
        return;
    };
    let dir = common::scratch(&format!("raycast_rays_{seed}"));
    let mut rng = Rng(seed);
    let mut total = RayTally::default();
    for b in 0..batches {
        let rays = generate_rays(&mut rng, res, per_batch);
        let t = compare_rays(&program, &dir, res, &rays, &format!("batch{b}"));
        total.rays += t.rays;
        total.failed += t.failed;
        total.empty_ok += t.empty_ok;
        total.long += t.long;
        total.keys += t.keys;
    }
    eprintln!("res {res}: {total:?}");
    assert_eq!(total.rays, batches * per_batch);
    // the mix really covered every class of ray
    assert!(total.failed > total.rays / 100, "{total:?}");
    assert!(total.empty_ok > total.rays / 100, "{total:?}");
    assert!(total.long > 0, "{total:?}");
    assert!(total.keys > 10 * total.rays, "{total:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn ray_keys_match_octomap_res_0_05() {
    ray_batches(0.05, 1, 2, 200_000);
}

#[test]
fn ray_keys_match_octomap_res_0_1() {
    ray_batches(0.1, 2, 2, 200_000);
}

#[test]
fn ray_keys_match_octomap_res_0_2() {
    ray_batches(0.2, 3, 2, 200_000);
}

#[test]
fn ray_keys_match_octomap_res_0_01f() {
    // test_pruning's `float res = 0.01f`, widened: 0.009999999776482582
    ray_batches(0.01f32 as f64, 4, 2, 200_000);
}

#[test]
fn ray_keys_match_octomap_odd_resolutions() {
    ray_batches(0.0731, 5, 1, 200_000);
    ray_batches(1.0 / 3.0, 6, 1, 200_000);
    ray_batches(0.25, 7, 1, 200_000);
}

/// The rays the scans themselves cast: sensor origin to every real endpoint, and to every
/// endpoint's voxel centre (discretize), at the three resolutions of the expected files.
#[test]
fn ray_keys_match_octomap_on_real_scans() {
    let Some(program) = common::reference_program() else {
        return;
    };
    let (Some(sph), Some(scan)) = (
        common::data_file("octomap_reference/derived/sph.frames"),
        common::data_file("octomap_reference/derived/scan.frames"),
    ) else {
        return;
    };
    let dir = common::scratch("raycast_rays_real");
    let mut n = 0;
    for path in [sph, scan] {
        let frames = read_frames(&path);
        for res in [0.05, 0.1, 0.2] {
            let conv = KeyConverter::new(res).unwrap();
            let mut rays = Vec::new();
            for f in &frames {
                for p in &f.points {
                    rays.push((f.origin, *p));
                    let k = conv.point_to_key_unchecked(&p.cast::<f64>());
                    rays.push((f.origin, conv.key_to_point_f32(&k)));
                }
            }
            n += compare_rays(&program, &dir, res, &rays, "real").rays;
        }
    }
    assert_eq!(n, 2 * 3 * (10201 + 88206));
    let _ = std::fs::remove_dir_all(&dir);
}

// ---------------------------------------------------------------------------------------------
// insertion

/// One insertion case: input frames, resolution and OctoMap options.
#[derive(Clone)]
struct Case {
    input: &'static str,
    res: f64,
    max_range: Option<f64>,
    discretize: bool,
    lazy: bool,
    simple: bool,
    /// (p_hit, p_miss, clamp_min, clamp_max, threshold), as the reference's `params` command.
    params: Option<[f64; 5]>,
    /// graph2tree `-compressML`: toMaxLikelihood + prune after every frame.
    compress_ml: bool,
}

impl Case {
    fn new(input: &'static str, res: f64) -> Self {
        Case {
            input,
            res,
            max_range: None,
            discretize: false,
            lazy: false,
            simple: false,
            params: None,
            compress_ml: false,
        }
    }
    fn m(mut self, m: f64) -> Self {
        self.max_range = Some(m);
        self
    }
    fn disc(mut self) -> Self {
        self.discretize = true;
        self
    }
    fn lazy(mut self) -> Self {
        self.lazy = true;
        self
    }
    fn simple(mut self) -> Self {
        self.simple = true;
        self
    }
    fn name(&self) -> String {
        let mut s = format!("{}_r{}", self.input.trim_end_matches(".frames"), self.res);
        if let Some(m) = self.max_range {
            s += &format!("_m{m}");
        }
        for (on, tag) in [
            (self.discretize, "_disc"),
            (self.lazy, "_lazy"),
            (self.simple, "_simple"),
            (self.params.is_some(), "_params"),
            (self.compress_ml, "_cml"),
        ] {
            if on {
                s += tag;
            }
        }
        s
    }

    /// Build the tree with octoquant.
    fn build(&self, frames: &[Frame]) -> OcTree {
        let mut tree = match self.params {
            Some([hit, miss, cmin, cmax, thr]) => OcTree::with_params(
                self.res,
                OccupancyParams::from_probabilities(hit, miss, cmin, cmax, thr).unwrap(),
            )
            .unwrap(),
            None => OcTree::new(self.res).unwrap(),
        };
        let opts = InsertOptions {
            max_range: self.max_range,
            discretize: self.discretize,
            lazy: self.lazy,
        };
        let mut buffers = ScanUpdate::new();
        for f in frames {
            if self.simple {
                let apply = ApplyOptions { lazy: self.lazy };
                insert_point_cloud_rays_f32(&mut tree, &f.points, &f.origin, &apply);
            } else {
                insert_point_cloud_reusing_f32(
                    &mut tree,
                    &f.points,
                    &f.origin,
                    &opts,
                    &mut buffers,
                );
            }
            if self.compress_ml {
                tree.to_max_likelihood();
                tree.prune();
            }
        }
        if self.lazy {
            tree.update_inner_occupancy();
        }
        tree
    }

    /// The reference program's script for the same case, writing `.ot` then `.bt`.
    fn script(&self, frames: &Path, ot: &Path, bt: &Path) -> String {
        assert!(!self.compress_ml, "the reference script has no compressML");
        let mut s = format!("tree {}\n", res_arg(self.res));
        if let Some([hit, miss, cmin, cmax, thr]) = self.params {
            s += &format!("params {hit:?} {miss:?} {cmin:?} {cmax:?} {thr:?}\n");
        }
        s += &format!("insert {}", frames.display());
        if let Some(m) = self.max_range {
            s += &format!(" maxrange {m:?}");
        }
        for (on, w) in [
            (self.discretize, " discretize"),
            (self.lazy, " lazy inner"),
            (self.simple, " simple"),
        ] {
            if on {
                s += w;
            }
        }
        s += &format!("\nwrite_ot {}\nwrite_bt {}\n", ot.display(), bt.display());
        s
    }
}

fn frames_path(input: &str) -> Option<PathBuf> {
    common::data_file(&format!("octomap_reference/derived/{input}"))
}

/// Insert with both implementations and require byte-identical `.ot` and `.bt` files.
fn compare_insert(cases: &[Case]) {
    let Some(program) = common::reference_program() else {
        return;
    };
    let dir = common::scratch(&format!("raycast_insert_{}", cases[0].name()));
    let mut failures = Vec::new();
    for case in cases {
        let Some(path) = frames_path(case.input) else {
            return;
        };
        let frames = read_frames(&path);
        let name = case.name();
        let (ref_ot, ref_bt) = (
            dir.join(format!("{name}.ot")),
            dir.join(format!("{name}.bt")),
        );
        let script = dir.join(format!("{name}.script"));
        std::fs::write(&script, case.script(&path, &ref_ot, &ref_bt)).unwrap();
        let t0 = std::time::Instant::now();
        run_ref(&program, &["script", script.to_str().unwrap()]);
        let t_ref = t0.elapsed();

        let t0 = std::time::Instant::now();
        let mut tree = case.build(&frames);
        let t_ours = t0.elapsed();
        octoquant_octree::validate::assert_well_formed(&tree, InnerNodes::from_lazy(case.lazy));
        // guard against comparing two trivial outputs
        assert!(tree.size() > 100, "{name}: only {} nodes", tree.size());
        let mut ot = Vec::new();
        io::write_ot(&tree, &mut ot).unwrap();
        let mut bt = Vec::new();
        io::write_bt(&mut tree, &mut bt).unwrap();
        let want_ot = std::fs::read(&ref_ot).unwrap();
        let want_bt = std::fs::read(&ref_bt).unwrap();
        eprintln!(
            "{name}: ot {} B, bt {} B; reference run {:.3} s (incl. I/O), octoquant insert {:.3} s",
            want_ot.len(),
            want_bt.len(),
            t_ref.as_secs_f64(),
            t_ours.as_secs_f64()
        );
        if ot != want_ot {
            failures.push(format!(
                "{name}: .ot differs ({} vs {} B)",
                ot.len(),
                want_ot.len()
            ));
        }
        if bt != want_bt {
            failures.push(format!(
                "{name}: .bt differs ({} vs {} B)",
                bt.len(),
                want_bt.len()
            ));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn insert_matches_octomap_sph() {
    let mut cases = Vec::new();
    for res in [0.05, 0.1, 0.2] {
        cases.push(Case::new("sph.frames", res));
        cases.push(Case::new("sph.frames", res).m(3.0));
        cases.push(Case::new("sph.frames", res).disc());
        cases.push(Case::new("sph.frames", res).disc().m(3.0));
        cases.push(Case::new("sph.frames", res).lazy());
        cases.push(Case::new("sph.frames", res).simple());
    }
    // a range that cuts some of the points and keeps the others
    cases.push(Case::new("sph.frames", 0.1).m(3.8));
    compare_insert(&cases);
}

#[test]
fn insert_matches_octomap_scan() {
    compare_insert(&[
        Case::new("scan.frames", 0.1),
        Case::new("scan.frames", 0.1).disc(),
        Case::new("scan.frames", 0.1).m(10.0),
        Case::new("scan.frames", 0.2),
        Case::new("scan.frames", 0.2).m(5.0).disc().lazy(),
        Case::new("scan.frames", 0.2).simple(),
        Case::new("scan.frames", 0.05).m(4.0),
        Case {
            params: Some([0.8, 0.45, 0.2, 0.9, 0.5]),
            ..Case::new("scan.frames", 0.2)
        },
    ]);
}

#[test]
fn insert_matches_octomap_synth_0_2() {
    compare_insert(&[
        Case::new("synth.frames", 0.2).m(8.0),
        Case::new("synth.frames", 0.2).m(8.0).lazy(),
        Case::new("synth.frames", 0.2).simple(),
        Case::new("synth.frames", 0.2).disc(),
        Case::new("synth.frames", 0.05).m(2.0).disc(),
    ]);
}

#[test]
fn insert_matches_octomap_synth_0_1() {
    // the biggest case: ~6 s in OctoMap
    compare_insert(&[Case::new("synth.frames", 0.1)]);
}

/// The graph2tree outputs stored with the data (see expected/summary.tsv): same bytes without
/// running any C++.
#[test]
fn insert_matches_graph2tree_expected_files() {
    let Some(dir) = common::data_dir() else {
        return;
    };
    let expected = dir.join("octomap_reference/expected");
    let cases: Vec<(&str, Case)> = vec![
        ("sph_r01", Case::new("sph.frames", 0.1)),
        ("sph_r005", Case::new("sph.frames", 0.05)),
        ("sph_r005_disc", Case::new("sph.frames", 0.05).disc()),
        ("sph_r005_m3", Case::new("sph.frames", 0.05).m(3.0)),
        ("sph_r005_simple", Case::new("sph.frames", 0.05).simple()),
        ("scan_r01", Case::new("scan.frames", 0.1)),
        ("scan_r01_disc", Case::new("scan.frames", 0.1).disc()),
        ("scan_r01_m10", Case::new("scan.frames", 0.1).m(10.0)),
        (
            "scan_r02_clamp",
            Case {
                // -clamping 0.2 0.9 -sensor 0.45 0.8 (miss first)
                params: Some([0.8, 0.45, 0.2, 0.9, 0.5]),
                ..Case::new("scan.frames", 0.2)
            },
        ),
        ("synth_r02_m8", Case::new("synth.frames", 0.2).m(8.0)),
        (
            "synth_r02_m8_cml",
            Case {
                compress_ml: true,
                ..Case::new("synth.frames", 0.2).m(8.0)
            },
        ),
        // graph2tree passes -m to insertPointCloudRays, which ignores it
        (
            "synth_r02_simple",
            Case::new("synth.frames", 0.2).m(8.0).simple(),
        ),
        (
            "synth_r01_disc_m6",
            Case::new("synth.frames", 0.1).m(6.0).disc(),
        ),
    ];
    let mut failures = Vec::new();
    let mut checked = 0;
    for (file, case) in &cases {
        let Some(path) = frames_path(case.input) else {
            return;
        };
        let frames = read_frames(&path);
        let mut tree = case.build(&frames);
        if *file == "sph_r01" {
            // graph2tree also writes the full tree (.bt.ot) and the ML tree (.bt_ml.ot)
            let mut ot = Vec::new();
            io::write_ot(&tree, &mut ot).unwrap();
            if ot != std::fs::read(expected.join("sph_r01.ot")).unwrap() {
                failures.push("sph_r01.ot".to_string());
            }
            checked += 1;
        }
        let mut bt = Vec::new();
        io::write_bt(&mut tree, &mut bt).unwrap();
        if *file == "sph_r01" {
            let mut ot = Vec::new();
            io::write_ot(&tree, &mut ot).unwrap();
            if ot != std::fs::read(expected.join("sph_r01_ml.ot")).unwrap() {
                failures.push("sph_r01_ml.ot".to_string());
            }
            checked += 1;
        }
        let want = std::fs::read(expected.join(format!("{file}.bt"))).unwrap();
        if bt != want {
            failures.push(format!("{file}.bt ({} vs {} B)", bt.len(), want.len()));
        }
        checked += 1;
    }
    assert!(failures.is_empty(), "differ from graph2tree: {failures:?}");
    assert_eq!(checked, cases.len() + 2);
}

// ---------------------------------------------------------------------------------------------
// castRay

/// Cast `rays` with OctoMap on the tree file and with `cast_ray_f32` on `tree`; the return value
/// and the end point must match bit for bit. Returns counts per stop reason.
fn compare_casts(
    program: &Path,
    dir: &Path,
    tree_file: &Path,
    tree: &OcTree,
    rays: &[(Point3<f32>, Point3<f32>, bool, f64)],
    label: &str,
) -> std::collections::HashMap<CastStop, usize> {
    let input = dir.join(format!("{label}.cast.in"));
    let output = dir.join(format!("{label}.cast.out"));
    let mut buf = Vec::new();
    buf.extend_from_slice(&(rays.len() as u32).to_le_bytes());
    for (o, d, ignore, m) in rays {
        for v in [o.x, o.y, o.z, d.x, d.y, d.z] {
            buf.extend_from_slice(&v.to_le_bytes());
        }
        buf.push(*ignore as u8);
        buf.extend_from_slice(&m.to_le_bytes());
    }
    std::fs::write(&input, &buf).unwrap();
    run_ref(
        program,
        &[
            "castray",
            tree_file.to_str().unwrap(),
            input.to_str().unwrap(),
            output.to_str().unwrap(),
        ],
    );
    let bytes = std::fs::read(&output).unwrap();
    let mut r = Reader { b: &bytes, at: 0 };
    let mut stops = std::collections::HashMap::new();
    let mut mismatches = Vec::new();
    for (i, (o, d, ignore, m)) in rays.iter().enumerate() {
        let hit = r.u8() == 1;
        let end = [r.f32(), r.f32(), r.f32()];
        // OctoMap's `maxRange`: a limit only when positive
        let options = CastOptions {
            ignore_unknown: *ignore,
            max_range: (*m > 0.0).then_some(*m),
        };
        let mine = cast_ray_f32(tree, o, d, &options);
        *stops.entry(mine.stop).or_insert(0) += 1;
        // OctoMap leaves `end` untouched (the reference's zero-initialised point) when it
        // returns before walking
        let my_end = mine.end_f32().unwrap_or(Point3::origin());
        let same_end = [my_end.x, my_end.y, my_end.z]
            .iter()
            .zip(&end)
            .all(|(a, b)| a.to_bits() == b.to_bits());
        if mine.hit != hit || !same_end {
            mismatches.push(format!(
                "cast {i}: origin {o:?} dir {d:?} ignore_unknown {ignore} max_range {m}: \
                 ours {mine:?}, octomap hit={hit} end={end:?}"
            ));
        }
    }
    assert_eq!(r.at, bytes.len());
    assert!(
        mismatches.is_empty(),
        "{label}: {} of {} casts differ:\n{}",
        mismatches.len(),
        rays.len(),
        mismatches
            .iter()
            .take(5)
            .cloned()
            .collect::<Vec<_>>()
            .join("\n")
    );
    stops
}

fn cast_rays_for(
    rng: &mut Rng,
    n: usize,
    lo: [f64; 3],
    hi: [f64; 3],
    sensor: Point3<f32>,
    res: f64,
) -> Vec<(Point3<f32>, Point3<f32>, bool, f64)> {
    let mut rays = Vec::with_capacity(n);
    for i in 0..n {
        let origin = match rng.below(4) {
            0 => sensor,
            1 => p32([
                (rng.range(lo[0], hi[0]) / res).floor() * res,
                (rng.range(lo[1], hi[1]) / res).floor() * res,
                (rng.range(lo[2], hi[2]) / res).floor() * res,
            ]),
            _ => p32([
                rng.range(lo[0], hi[0]),
                rng.range(lo[1], hi[1]),
                rng.range(lo[2], hi[2]),
            ]),
        };
        let dir = match rng.below(20) {
            0 => {
                let mut d = [0.0; 3];
                d[rng.below(3) as usize] = if rng.coin(0.5) { 1.0 } else { -2.5 };
                p32(d)
            }
            1 => p32([1.0, if rng.coin(0.5) { 1.0 } else { -1.0 }, 0.0]),
            2 => p32([-1.0, 1.0, if rng.coin(0.5) { 1.0 } else { -1.0 }]),
            3 if i % 7 == 0 => p32([0.0, 0.0, 0.0]),
            4 if i % 5 == 0 => Point3::new(1e-30, 2e-30, 0.0),
            _ => {
                let v = rng.unit_vec();
                let s = rng.range(0.1, 10.0);
                p32([v[0] * s, v[1] * s, v[2] * s])
            }
        };
        // all four flag combinations: ignore_unknown x max range on/off (0 means off too).
        // Ignoring unknown space without a range walks to the map boundary unless it hits
        // something, tens of thousands of voxels: keep that combination rare.
        let (ignore, max_range) = match rng.below(40) {
            0 => (true, -1.0),
            1 => (true, 0.0),
            2..=11 => (false, -1.0),
            12..=14 => (false, 0.0),
            15..=24 => (false, rng.range(0.0, 12.0)),
            25..=29 => (true, rng.range(0.0, 2.0)),
            _ => (true, rng.range(0.0, 12.0)),
        };
        rays.push((origin, dir, ignore, max_range));
    }
    rays
}

/// castRay on two real trees, each in its full (.ot) and its maximum-likelihood (.bt) form.
#[test]
fn cast_ray_matches_octomap() {
    let Some(program) = common::reference_program() else {
        return;
    };
    let dir = common::scratch("raycast_cast");
    let mut rng = Rng(77);
    let mut all = std::collections::HashMap::new();
    // (input, resolution, max range used to build the tree, origin box, number of casts)
    type Setup = (&'static str, f64, Option<f64>, ([f64; 3], [f64; 3]), usize);
    let setups: [Setup; 2] = [
        (
            "synth.frames",
            0.2,
            Some(8.0),
            ([-9.0, -9.0, 0.2], [9.0, 9.0, 3.8]),
            60_000,
        ),
        (
            "sph.frames",
            0.1,
            None,
            ([0.0, -2.0, -2.5], [5.0, 2.0, 1.5]),
            40_000,
        ),
    ];
    for (input, res, m, (lo, hi), n) in setups {
        let Some(path) = frames_path(input) else {
            return;
        };
        let case = Case {
            max_range: m,
            ..Case::new(input, res)
        };
        let frames = read_frames(&path);
        let (ot, bt) = (dir.join("tree.ot"), dir.join("tree.bt"));
        let script = dir.join("cast.script");
        std::fs::write(&script, case.script(&path, &ot, &bt)).unwrap();
        run_ref(&program, &["script", script.to_str().unwrap()]);
        let full = case.build(&frames);
        let ml = io::read_bt(&std::fs::read(&bt).unwrap()[..]).unwrap();
        let rays = cast_rays_for(&mut rng, n, lo, hi, frames[0].origin, res);
        for (file, tree) in [(&ot, &full), (&bt, &ml)] {
            let label = format!(
                "{}_{}",
                case.name(),
                file.extension().unwrap().to_str().unwrap()
            );
            let stops = compare_casts(&program, &dir, file, tree, &rays, &label);
            eprintln!("{label}: {stops:?}");
            for (k, v) in stops {
                *all.entry(k).or_insert(0) += v;
            }
        }
    }
    // every way a cast can end was exercised (the map boundary only with ignore_unknown)
    for stop in [
        CastStop::Occupied,
        CastStop::Unknown,
        CastStop::MaxRange,
        CastStop::MapBoundary,
        CastStop::BadDirection,
    ] {
        assert!(
            all.get(&stop).copied().unwrap_or(0) > 0,
            "{stop:?} never happened: {all:?}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// castRay from outside the map, into the map edge, and from the edge outwards.
#[test]
fn cast_ray_matches_octomap_at_the_map_edge() {
    let Some(program) = common::reference_program() else {
        return;
    };
    let dir = common::scratch("raycast_cast_edge");
    let res = 0.5;
    let mut tree = OcTree::new(res).unwrap();
    let edge = (32768.0 * res) as f32;
    // a few free and occupied voxels near the +x edge
    let pts: Vec<Point3<f32>> = (0..50)
        .map(|i| Point3::new(edge - 1.0, -5.0 + i as f32 * 0.2, 0.3))
        .collect();
    insert_point_cloud_reusing_f32(
        &mut tree,
        &pts,
        &Point3::new(edge - 20.0, 0.0, 0.3),
        &InsertOptions::default(),
        &mut ScanUpdate::new(),
    );
    let file = dir.join("edge.ot");
    io::write_ot(&tree, std::fs::File::create(&file).unwrap()).unwrap();
    let mut rng = Rng(5);
    let mut rays = Vec::new();
    for i in 0..4000 {
        let o = p32([
            edge as f64 - rng.range(-2.0, 25.0),
            rng.range(-6.0, 6.0),
            rng.range(-1.0, 1.0),
        ]);
        let v = rng.unit_vec();
        let towards_edge = i % 3 != 0;
        let d = p32([
            v[0].abs() * if towards_edge { 1.0 } else { -1.0 },
            v[1],
            v[2],
        ]);
        let max_range = if i % 4 < 2 && towards_edge {
            -1.0
        } else {
            30.0
        };
        rays.push((o, d, i % 2 == 0, max_range));
    }
    let stops = compare_casts(&program, &dir, &file, &tree, &rays, "edge");
    assert!(
        stops.get(&CastStop::MapBoundary).copied().unwrap_or(0) > 0,
        "{stops:?}"
    );
    assert!(
        stops.get(&CastStop::OriginOutsideMap).copied().unwrap_or(0) > 0,
        "{stops:?}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

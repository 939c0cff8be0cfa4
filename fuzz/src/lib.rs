//! Helpers shared by the fuzz targets.
//!
//! Most readers of `octoquant-formats` take a path (the format and the `.gz`/`.bz2` wrapper
//! come from the name), so the targets that fuzz them write each input to a file and call the
//! real entry point on it: no test-only API, and the same code path the CLI runs. The files
//! live in a per-process directory on a RAM disk: `$OCTOQUANT_FUZZ_TMP` if set, else
//! `/dev/shm` when it exists, else the system temporary directory.
#![deny(missing_docs)]

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

fn scratch_dir() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let base = std::env::var_os("OCTOQUANT_FUZZ_TMP")
            .map(PathBuf::from)
            .unwrap_or_else(|| {
                let shm = Path::new("/dev/shm");
                if shm.is_dir() {
                    shm.to_path_buf()
                } else {
                    std::env::temp_dir()
                }
            });
        let dir = base.join(format!("octoquant-fuzz-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("cannot create the fuzz scratch directory");
        dir
    })
}

/// Write `data` to a scratch file called `name` (whose extension selects the format) and
/// run `f` on its path. The file is overwritten by the next input with the same name.
pub fn with_file<T>(name: &str, data: &[u8], f: impl FnOnce(&Path) -> T) -> T {
    let path = scratch_dir().join(name);
    std::fs::write(&path, data).expect("cannot write the fuzz scratch file");
    f(&path)
}

/// A scratch directory called `name`, created if needed (its files stay from the previous
/// input until the target overwrites them), for the targets whose reader takes a directory.
pub fn scratch_subdir(name: &str) -> PathBuf {
    let dir = scratch_dir().join(name);
    std::fs::create_dir_all(&dir).expect("cannot create a fuzz scratch directory");
    dir
}

/// Keys and updates for the structure-aware targets (`octree_ops`, `stamped_ops`), decoded by
/// `arbitrary`.
pub mod ops {
    use arbitrary::Arbitrary;
    use octoquant_octree::{Key, Update};

    /// A voxel key: mostly inside a small block around the map's centre (so siblings meet,
    /// collapse and share ancestors), sometimes anywhere.
    #[derive(Arbitrary, Debug, Clone, Copy)]
    pub enum FuzzKey {
        /// Inside the block: each coordinate taken modulo the block's side.
        Near(u8, u8, u8),
        /// Anywhere in the map.
        Far(u16, u16, u16),
    }

    impl FuzzKey {
        /// The key, near ones in the block of `side`³ voxels centred on the map's centre
        /// (`side` at most 256).
        pub fn key_in(self, side: u16) -> Key {
            match self {
                FuzzKey::Near(x, y, z) => {
                    let c = |v: u8| 0x8000 - side / 2 + u16::from(v) % side;
                    Key::new(c(x), c(y), c(z))
                }
                FuzzKey::Far(x, y, z) => Key::new(x, y, z),
            }
        }
    }

    /// An occupancy update: a hit, a miss or any log-odds (NaN and infinities included).
    #[derive(Arbitrary, Debug, Clone, Copy)]
    pub enum FuzzUpdate {
        /// `Update::Hit`.
        Hit,
        /// `Update::Miss`.
        Miss,
        /// `Update::LogOdds`.
        LogOdds(f32),
    }

    impl FuzzUpdate {
        /// The library's update.
        pub fn update(self) -> Update {
            match self {
                FuzzUpdate::Hit => Update::Hit,
                FuzzUpdate::Miss => Update::Miss,
                FuzzUpdate::LogOdds(d) => Update::LogOdds(d),
            }
        }
    }
}

/// A point (or origin) of a structure-aware frame target: near the map's centre, where rays
/// meet the tree, or any `f32`s (NaN, infinities, outside the key range).
#[derive(arbitrary::Arbitrary, Debug, Clone, Copy)]
pub enum Place {
    /// Within a few metres of the map's centre (tenths of a metre).
    Near(i8, i8, i8),
    /// Any coordinates.
    Raw(f32, f32, f32),
}

impl Place {
    /// The point this place stands for.
    pub fn point(self) -> nalgebra::Point3<f32> {
        match self {
            Place::Near(x, y, z) => {
                nalgebra::Point3::new(f32::from(x) * 0.1, f32::from(y) * 0.1, f32::from(z) * 0.1)
            }
            Place::Raw(x, y, z) => nalgebra::Point3::new(x, y, z),
        }
    }
}

/// The counts of a frame's statistics that do not depend on timing: points, non-finite,
/// outside the map, rays, free, occupied.
pub fn frame_counts(s: &octoquant::pipeline::FrameStats) -> [usize; 6] {
    [
        s.points,
        s.non_finite,
        s.outside_map,
        s.rays,
        s.free,
        s.occupied,
    ]
}

/// A rayon pool of `threads` threads, made once per thread count and kept (a target's every
/// input runs on the same pools).
pub fn pool(threads: usize) -> &'static rayon::ThreadPool {
    static POOLS: OnceLock<[rayon::ThreadPool; 3]> = OnceLock::new();
    let make = |n| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .expect("a thread pool")
    };
    let pools = POOLS.get_or_init(|| [make(1), make(2), make(3)]);
    match threads {
        1 => &pools[0],
        2 => &pools[1],
        3 => &pools[2],
        _ => panic!("the fuzz targets use pools of one to three threads"),
    }
}

/// The bytes `write` writes into memory (a tree's `.ot`, say).
pub fn written(write: impl FnOnce(&mut Vec<u8>) -> std::io::Result<()>) -> Vec<u8> {
    let mut out = Vec::new();
    write(&mut out).expect("writing into memory");
    out
}

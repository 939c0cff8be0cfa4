//! The entry point: which [`InputFormat`] a path holds ([`InputFormat::detect`]) and reading
//! it as frames ([`read_frames`] with [`ReadOptions`]).

use crate::error::{FormatError, Location};
use crate::frame::{Frame, RowFrames};
use crate::graph::GraphOptions;
use crate::pcd::PcdOptions;
use crate::tum::TumOptions;
use crate::{frames, graph, mcap, pcd, ply, source, text, tum, vtk};
use std::path::{Path, PathBuf};

/// The input formats [`read_frames`] understands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum InputFormat {
    /// OctoMap ScanGraph binary (`.graph`).
    Graph,
    /// Reference-program frames (`.frames`).
    Frames,
    /// Text: point list, OctoMap log or `origin` frames (`.txt`, `.dat`, `.log`, `.xyz`).
    Text,
    /// One legacy VTK file, origin (0, 0, 0), no pose (`.vtk`).
    Vtk,
    /// A directory of `_<sec>_<nanosec>.vtk` scans with a trajectory CSV (a `.csv`, or a
    /// directory holding `scans/` or `.vtk` files).
    VtkSequence,
    /// PCD v0.7 (`.pcd`).
    Pcd,
    /// One TUM depth PNG in the camera frame (`.png`).
    TumDepth,
    /// A TUM association file with poses (a `.txt` whose rows name two `.png`s, or a
    /// directory holding one).
    TumAssociation,
    /// `sensor_msgs/PointCloud2` messages from a ROS 1 or ROS 2 bag in MCAP (`.mcap`).
    Mcap,
    /// A PLY point cloud (`.ply`), origin (0, 0, 0).
    Ply,
}

impl InputFormat {
    /// Every format, for listing in help texts.
    pub const ALL: [InputFormat; 10] = [
        InputFormat::Graph,
        InputFormat::Frames,
        InputFormat::Text,
        InputFormat::Vtk,
        InputFormat::VtkSequence,
        InputFormat::Pcd,
        InputFormat::TumDepth,
        InputFormat::TumAssociation,
        InputFormat::Mcap,
        InputFormat::Ply,
    ];

    /// The short name used on the command line (`graph`, `frames`, `text`, `vtk`, `vtk-seq`,
    /// `pcd`, `tum-png`, `tum`, `mcap`, `ply`).
    pub fn name(self) -> &'static str {
        match self {
            InputFormat::Graph => "graph",
            InputFormat::Frames => "frames",
            InputFormat::Text => "text",
            InputFormat::Vtk => "vtk",
            InputFormat::VtkSequence => "vtk-seq",
            InputFormat::Pcd => "pcd",
            InputFormat::TumDepth => "tum-png",
            InputFormat::TumAssociation => "tum",
            InputFormat::Mcap => "mcap",
            InputFormat::Ply => "ply",
        }
    }

    /// The format with this short name (see [`InputFormat::name`]), case-insensitive.
    pub fn from_name(name: &str) -> Option<InputFormat> {
        Self::ALL
            .into_iter()
            .find(|f| f.name().eq_ignore_ascii_case(name))
    }

    /// Tell the format from the path: the extension (after any `.gz`/`.bz2`), a directory's
    /// contents, or for `.txt` whether its first data row looks like a TUM association.
    pub fn detect(path: &Path) -> Result<InputFormat, FormatError> {
        if path.is_dir() {
            return Ok(match directory_kind(path)? {
                DirKind::Vtk { .. } => InputFormat::VtkSequence,
                DirKind::Tum(_) => InputFormat::TumAssociation,
            });
        }
        let unknown = |message: String| FormatError::UnknownFormat {
            path: path.to_path_buf(),
            message,
        };
        let ext = source::logical_extension(path).ok_or_else(|| {
            unknown(format!(
                "the file name has no extension; {}",
                Self::name_it_hint()
            ))
        })?;
        Ok(match ext.as_str() {
            "graph" => InputFormat::Graph,
            "frames" => InputFormat::Frames,
            "dat" | "log" | "xyz" => InputFormat::Text,
            "txt" => {
                if tum::is_association_file(path) {
                    InputFormat::TumAssociation
                } else {
                    InputFormat::Text
                }
            }
            "vtk" => InputFormat::Vtk,
            "csv" => InputFormat::VtkSequence,
            "pcd" => InputFormat::Pcd,
            "png" => InputFormat::TumDepth,
            "mcap" => InputFormat::Mcap,
            "ply" => InputFormat::Ply,
            other => {
                return Err(unknown(format!(
                    "unknown extension .{other}; {}",
                    Self::name_it_hint()
                )))
            }
        })
    }

    /// How to name the format when it cannot be told from the file: `--format` on the
    /// command line, [`ReadOptions::format`] in the library, and the names they take.
    fn name_it_hint() -> String {
        let names: Vec<&str> = Self::ALL.iter().map(|f| f.name()).collect();
        format!(
            "name the format with --format (ReadOptions::format): one of {}",
            names.join(", ")
        )
    }
}

impl std::fmt::Display for InputFormat {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Options for [`read_frames`]; the defaults follow each format's conventions.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ReadOptions {
    /// Force a format instead of detecting it.
    pub format: Option<InputFormat>,
    /// `.graph` options (graph2tree `-g`).
    pub graph: GraphOptions,
    /// PCD options (use of VIEWPOINT).
    pub pcd: PcdOptions,
    /// TUM depth options (intrinsics, depth scale, pixel step).
    pub tum: TumOptions,
    /// The trajectory CSV of a VTK sequence, when it is not `trajectory.csv` (or the only
    /// `.csv`) in the input directory or its parent.
    pub trajectory: Option<PathBuf>,
    /// Read a VTK sequence with identity poses (sensor at the origin, points as stored, for
    /// scans already in the world frame) instead of matching its scans to a trajectory.
    pub vtk_identity_poses: bool,
    /// MCAP options (topic, fixed frame, sensor pose).
    pub mcap: mcap::McapOptions,
    /// How far compressed data (`.gz`/`.bz2`, LZF, MCAP chunks, PNG) may expand before the
    /// read fails as a decompression bomb; see [`source::DecompressionLimit`].
    pub decompression: source::DecompressionLimit,
    /// Read the points' colours where the input carries them (PCD `rgb`/`rgba`, PLY
    /// `red green blue`, a TUM association's RGB images, PointCloud2 `rgb`/`rgba`, colours
    /// stored in a version 2 `.frames` file) into
    /// [`Frame::colors`]. Off by default: a colourless read never decodes a colour.
    pub colors: bool,
}

/// Read `path` as frames in world coordinates, in the format given or detected, under
/// [`ReadOptions::decompression`]: [`frame_stream`] collected.
pub fn read_frames(path: &Path, options: &ReadOptions) -> Result<Vec<Frame>, FormatError> {
    frame_stream(path, options)?.collect()
}

/// The frames of `path` as they are read, in the format given or detected, under
/// [`ReadOptions::decompression`]: the same frames and errors as [`read_frames`], but
/// MCAP, `.frames`, VTK sequences and TUM associations are read one frame at a time (see
/// [`FrameStream`]). Errors that need no frame (unknown format, missing file, bad header)
/// come here; later ones from the stream, which ends after its first error.
pub fn frame_stream(path: &Path, options: &ReadOptions) -> Result<FrameStream, FormatError> {
    let limit = options.decompression;
    let inner = source::with_decompression_limit(limit, || frame_source(path, options))?;
    Ok(FrameStream {
        inner,
        limit,
        failed: false,
    })
}

/// How many frames `path` gives, when that can be known without reading its points (for a
/// progress bar's ETA over several inputs): the count in a `.frames` or `.graph` header, one
/// for a single scan (PCD, PLY, VTK, PNG), the scans of a VTK sequence, the rows of a TUM
/// association, the cloud count in an MCAP file's summary statistics. `None` for text logs,
/// for MCAP files without statistics, and whenever reading the count fails (the
/// read itself then reports why). A count is what the input announces: a damaged input may
/// end earlier with an error.
pub fn count_frames(path: &Path, options: &ReadOptions) -> Option<usize> {
    let format = match options.format {
        Some(f) => f,
        None => InputFormat::detect(path).ok()?,
    };
    source::with_decompression_limit(options.decompression, || match format {
        InputFormat::Frames => Some(frames::frames_file_stream(path).ok()?.size_hint().0),
        InputFormat::Graph => {
            let mut head = [0u8; 4];
            source::open(path).ok()?.read_exact(&mut head).ok()?;
            usize::try_from(u32::from_le_bytes(head)).ok()
        }
        InputFormat::Text => None,
        InputFormat::Vtk | InputFormat::Pcd | InputFormat::TumDepth | InputFormat::Ply => Some(1),
        InputFormat::VtkSequence => {
            let (scans, _) =
                vtk_sequence_inputs(path, options.trajectory.as_deref(), false).ok()?;
            Some(vtk::list_scans(&scans).ok()?.len())
        }
        InputFormat::TumAssociation => {
            let assoc = if path.is_dir() {
                match directory_kind(path).ok()? {
                    DirKind::Tum(a) => a,
                    DirKind::Vtk { .. } => return None,
                }
            } else {
                path.to_path_buf()
            };
            Some(tum::read_association(&assoc).ok()?.len())
        }
        InputFormat::Mcap => mcap::announced_clouds(path, &options.mcap),
    })
}

/// Frames read on demand from one input ([`frame_stream`]). Each call to `next` reads one
/// frame under the input's decompression limit; memory held between calls is the reader's
/// state (a file handle, the MCAP tf tree, an index of scan files), not the frames already
/// yielded (`.frames` and `.graph` files hold one frame's points at a time). Text logs and
/// single-scan formats (PCD, PLY, one VTK, one PNG) are parsed whole when the stream is made,
/// and yielded from memory.
pub struct FrameStream {
    inner: Source,
    limit: source::DecompressionLimit,
    failed: bool,
}

impl FrameStream {
    /// Pass over the next `n` frames as cheaply as the input allows, returning how many were
    /// passed (fewer at the end of the input): `.frames` and `.graph` files read only the
    /// frames' headers and seek over their points when stored uncompressed; VTK sequences and
    /// TUM associations skip their rows without opening the scan or image files; MCAP files
    /// find the skipped clouds' messages without decoding them, and pass the chunks before
    /// the first cloud kept without reading them when the file's chunk and message indexes
    /// place it (the first pass over the file, when the stream is made, still reads every
    /// chunk for the transforms); other inputs (text, single
    /// scans: parsed whole when the stream is made) drop frames already in memory. That makes
    /// frames `k..` of an input cost about what those frames cost (a distributed build's
    /// slice). An error met on the way ends the stream; an error inside a frame that is
    /// passed over unread is reported by whoever reads that frame.
    pub fn skip_frames(&mut self, n: usize) -> Result<usize, FormatError> {
        if self.failed {
            return Ok(0);
        }
        let inner = &mut self.inner;
        let r = source::with_decompression_limit(self.limit, || inner.skip_frames(n));
        self.failed = r.is_err();
        r
    }
}

impl Iterator for FrameStream {
    type Item = Result<Frame, FormatError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.failed {
            return None;
        }
        let inner = &mut self.inner;
        let r = source::with_decompression_limit(self.limit, || inner.next());
        self.failed = matches!(r, Some(Err(_)));
        r
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        if self.failed {
            (0, Some(0))
        } else {
            self.inner.size_hint()
        }
    }
}

impl std::fmt::Debug for FrameStream {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FrameStream")
            .field("limit", &self.limit)
            .finish_non_exhaustive()
    }
}

/// What a [`FrameStream`] reads from: the frames of one input, one at a time, and each
/// format's cheapest way to pass over frames.
trait FrameSource: Iterator<Item = Result<Frame, FormatError>> + Send {
    /// Pass over the next `n` frames; how many were passed (fewer at the end).
    fn skip_frames(&mut self, n: usize) -> Result<usize, FormatError>;
}

type Source = Box<dyn FrameSource>;

/// Frames already in memory: passing over them drops them.
struct Listed(std::vec::IntoIter<Frame>);

impl Iterator for Listed {
    type Item = Result<Frame, FormatError>;

    fn next(&mut self) -> Option<Self::Item> {
        self.0.next().map(Ok)
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        self.0.size_hint()
    }
}

impl FrameSource for Listed {
    fn skip_frames(&mut self, n: usize) -> Result<usize, FormatError> {
        let k = n.min(self.0.len());
        if k > 0 {
            self.0.nth(k - 1);
        }
        Ok(k)
    }
}

impl FrameSource for graph::GraphStream {
    fn skip_frames(&mut self, n: usize) -> Result<usize, FormatError> {
        graph::GraphStream::skip_frames(self, n)
    }
}

impl FrameSource for frames::FramesStream {
    fn skip_frames(&mut self, n: usize) -> Result<usize, FormatError> {
        frames::FramesStream::skip_frames(self, n)
    }
}

impl<T: Send> FrameSource for RowFrames<T> {
    fn skip_frames(&mut self, n: usize) -> Result<usize, FormatError> {
        Ok(RowFrames::skip_frames(self, n))
    }
}

/// An MCAP file's frames; passing over them finds their messages without decoding the clouds.
struct McapSource(mcap::McapFrames);

impl Iterator for McapSource {
    type Item = Result<Frame, FormatError>;

    fn next(&mut self) -> Option<Self::Item> {
        self.0.next().map(|r| r.map(|(f, _)| f))
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        self.0.size_hint()
    }
}

impl FrameSource for McapSource {
    fn skip_frames(&mut self, n: usize) -> Result<usize, FormatError> {
        self.0.skip_clouds(n)
    }
}

/// Frames already in memory, as a source.
fn all(frames: Result<Vec<Frame>, FormatError>) -> Result<Source, FormatError> {
    Ok(Box::new(Listed(frames?.into_iter())))
}

fn frame_source(path: &Path, options: &ReadOptions) -> Result<Source, FormatError> {
    let format = match options.format {
        Some(f) => f,
        None => InputFormat::detect(path)?,
    };
    match format {
        InputFormat::Graph => Ok(Box::new(graph::graph_file_stream(path, &options.graph)?)),
        InputFormat::Frames => Ok(Box::new(
            frames::frames_file_stream(path)?.with_colors(options.colors),
        )),
        InputFormat::Text => all(text::read_text(path)),
        InputFormat::Vtk => all(vtk::read_vtk(path)),
        InputFormat::VtkSequence if options.vtk_identity_poses => {
            let (scans, _) = vtk_sequence_inputs(path, None, false)?;
            all(vtk::read_vtk_sequence_identity(&scans))
        }
        InputFormat::VtkSequence => {
            let (scans, csv) = vtk_sequence_inputs(path, options.trajectory.as_deref(), true)?;
            let Some(csv) = csv else {
                return Err(FormatError::missing_pose(
                    path,
                    Location::File,
                    "no trajectory for the VTK scans",
                ));
            };
            Ok(Box::new(vtk::vtk_sequence_frames(&scans, &csv)?))
        }
        InputFormat::Pcd => all(pcd::read_pcd_with(path, &options.pcd, options.colors)),
        InputFormat::TumDepth => all(tum::read_tum_depth(path, &options.tum)),
        InputFormat::TumAssociation => {
            let assoc = if path.is_dir() {
                match directory_kind(path)? {
                    DirKind::Tum(a) => a,
                    DirKind::Vtk { .. } => {
                        return Err(FormatError::UnknownFormat {
                            path: path.to_path_buf(),
                            message: "directory holds VTK scans, not a TUM association".into(),
                        })
                    }
                }
            } else {
                path.to_path_buf()
            };
            Ok(Box::new(tum::tum_sequence_frames_with(
                &assoc,
                &options.tum,
                options.colors,
            )?))
        }
        InputFormat::Mcap => {
            let mcap = mcap::McapOptions {
                colors: options.mcap.colors || options.colors,
                ..options.mcap.clone()
            };
            Ok(Box::new(McapSource(mcap::mcap_frames(path, &mcap)?)))
        }
        InputFormat::Ply => all(ply::read_ply_frames_with(path, options.colors)),
    }
}

enum DirKind {
    /// Scans directory.
    Vtk { scans: PathBuf },
    /// Association file.
    Tum(PathBuf),
}

fn list_dir(dir: &Path) -> Result<Vec<PathBuf>, FormatError> {
    let rd = std::fs::read_dir(dir).map_err(|e| FormatError::io(dir, Location::File, e))?;
    let mut out = Vec::new();
    for entry in rd {
        out.push(
            entry
                .map_err(|e| FormatError::io(dir, Location::File, e))?
                .path(),
        );
    }
    out.sort();
    Ok(out)
}

fn has_vtk(entries: &[PathBuf]) -> bool {
    entries
        .iter()
        .any(|p| p.is_file() && source::logical_extension(p).as_deref() == Some("vtk"))
}

fn directory_kind(dir: &Path) -> Result<DirKind, FormatError> {
    let entries = list_dir(dir)?;
    let scans = dir.join("scans");
    if scans.is_dir() && has_vtk(&list_dir(&scans)?) {
        return Ok(DirKind::Vtk { scans });
    }
    if has_vtk(&entries) {
        return Ok(DirKind::Vtk {
            scans: dir.to_path_buf(),
        });
    }
    let assoc: Vec<&PathBuf> = entries
        .iter()
        .filter(|p| {
            p.is_file()
                && source::logical_extension(p).as_deref() == Some("txt")
                && tum::is_association_file(p)
        })
        .collect();
    match assoc.as_slice() {
        [one] => Ok(DirKind::Tum((*one).clone())),
        [] => Err(FormatError::UnknownFormat {
            path: dir.to_path_buf(),
            message: "directory has no .vtk scans and no TUM association .txt".into(),
        }),
        _ => Err(FormatError::UnknownFormat {
            path: dir.to_path_buf(),
            message: format!(
                "directory has {} TUM association files; name one",
                assoc.len()
            ),
        }),
    }
}

/// The trajectory CSV in `dir`: `trajectory.csv`, else the only `.csv`.
fn find_csv(dir: &Path) -> Result<Option<PathBuf>, FormatError> {
    let t = dir.join("trajectory.csv");
    if t.is_file() {
        return Ok(Some(t));
    }
    let csvs: Vec<PathBuf> = list_dir(dir)?
        .into_iter()
        .filter(|p| p.is_file() && source::logical_extension(p).as_deref() == Some("csv"))
        .collect();
    Ok(if csvs.len() == 1 {
        csvs.into_iter().next()
    } else {
        None
    })
}

/// (scans directory, trajectory CSV) for a VTK sequence given as a directory or a CSV; a
/// directory without a trajectory is an error when `need_trajectory`.
fn vtk_sequence_inputs(
    path: &Path,
    trajectory: Option<&Path>,
    need_trajectory: bool,
) -> Result<(PathBuf, Option<PathBuf>), FormatError> {
    let parent_of = |p: &Path| {
        p.parent()
            .filter(|d| !d.as_os_str().is_empty())
            .map_or_else(|| PathBuf::from("."), Path::to_path_buf)
    };
    if path.is_dir() {
        let scans = match directory_kind(path)? {
            DirKind::Vtk { scans } => scans,
            DirKind::Tum(_) => {
                return Err(FormatError::UnknownFormat {
                    path: path.to_path_buf(),
                    message: "directory holds a TUM association, not VTK scans".into(),
                })
            }
        };
        let csv = match trajectory {
            Some(t) => Some(t.to_path_buf()),
            None => match find_csv(path)? {
                Some(c) => Some(c),
                None => find_csv(&parent_of(path))?,
            },
        };
        if csv.is_none() && need_trajectory {
            return Err(FormatError::missing_pose(
                path,
                Location::File,
                "no trajectory.csv (or single .csv) found; pass the trajectory (--trajectory), or --identity-poses for scans already in the world frame",
            ));
        }
        return Ok((scans, csv));
    }
    let dir = parent_of(path);
    let scans = dir.join("scans");
    let scans = if scans.is_dir() { scans } else { dir };
    Ok((
        scans,
        Some(trajectory.map_or_else(|| path.to_path_buf(), Path::to_path_buf)),
    ))
}

//! The command line's words for the library's choices: clap value enums for insertion modes,
//! ray models, input formats and render views, each mapped onto the library enum it names.
//!
//! The library enums stay free of clap (the binary is its only user); the value names here
//! are the ones the library prints (`InsertMode::name`, `InputFormat::name`), so a mode or a
//! format is spelled the same on the command line, in text and JSON output and in the docs.
//! The tests below keep the two lists in step.

use octoquant::formats::{InputFormat, ViewpointUse};
use octoquant::grid::UnknownCells;
use octoquant::octree::SensorPreset;
use octoquant::pipeline::InsertMode;
use octoquant::render::View;
use octoquant_raycast::RayModel;

/// `--mode`: how a frame's end points become rays (see [`InsertMode`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ModeArg {
    Exact,
    Discretize,
    Quantized,
    #[value(name = "quantized+bresenham")]
    QuantizedBresenham,
    Simple,
}

impl From<ModeArg> for InsertMode {
    fn from(m: ModeArg) -> InsertMode {
        match m {
            ModeArg::Exact => InsertMode::Exact,
            ModeArg::Discretize => InsertMode::Discretize,
            ModeArg::Quantized => InsertMode::Quantized,
            ModeArg::QuantizedBresenham => InsertMode::QuantizedBresenham,
            ModeArg::Simple => InsertMode::Simple,
        }
    }
}

/// `--sensor-model`: a named sensor model (see [`SensorPreset`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum SensorModelArg {
    Octomap,
    #[value(name = "kwon-yoon-2015")]
    KwonYoon2015,
}

impl From<SensorModelArg> for SensorPreset {
    fn from(m: SensorModelArg) -> SensorPreset {
        match m {
            SensorModelArg::Octomap => SensorPreset::OctoMap,
            SensorModelArg::KwonYoon2015 => SensorPreset::KwonYoon2015,
        }
    }
}

/// `--storage` of `reduce --stream`: what a cell of the streamed store keeps (see
/// `octoquant_density::Storage`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum StorageArg {
    OneNode,
    AllMembers,
}

/// `--ray`: which voxels a free-space ray clears (see [`RayModel`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum RayArg {
    Dda,
    Bresenham,
}

impl From<RayArg> for RayModel {
    fn from(r: RayArg) -> RayModel {
        match r {
            RayArg::Dda => RayModel::Dda,
            RayArg::Bresenham => RayModel::Bresenham,
        }
    }
}

/// `--format`: the input format, instead of detecting it (see [`InputFormat`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum FormatArg {
    Graph,
    Frames,
    Text,
    Vtk,
    #[value(name = "vtk-seq")]
    VtkSequence,
    Pcd,
    #[value(name = "tum-png")]
    TumDepth,
    #[value(name = "tum")]
    TumAssociation,
    Mcap,
    Ply,
}

impl From<FormatArg> for InputFormat {
    fn from(f: FormatArg) -> InputFormat {
        match f {
            FormatArg::Graph => InputFormat::Graph,
            FormatArg::Frames => InputFormat::Frames,
            FormatArg::Text => InputFormat::Text,
            FormatArg::Vtk => InputFormat::Vtk,
            FormatArg::VtkSequence => InputFormat::VtkSequence,
            FormatArg::Pcd => InputFormat::Pcd,
            FormatArg::TumDepth => InputFormat::TumDepth,
            FormatArg::TumAssociation => InputFormat::TumAssociation,
            FormatArg::Mcap => InputFormat::Mcap,
            FormatArg::Ply => InputFormat::Ply,
        }
    }
}

/// `--view`: the viewing direction of a rendered map (see [`View`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ViewArg {
    Top,
    Front,
    Side,
}

impl From<ViewArg> for View {
    fn from(v: ViewArg) -> View {
        match v {
            ViewArg::Top => View::Top,
            ViewArg::Front => View::Front,
            ViewArg::Side => View::Side,
        }
    }
}

/// `--unknown`: what the unknown cells of a 2D grid become (see [`UnknownCells`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum UnknownArg {
    Unknown,
    Free,
}

impl From<UnknownArg> for UnknownCells {
    fn from(u: UnknownArg) -> UnknownCells {
        match u {
            UnknownArg::Unknown => UnknownCells::Unknown,
            UnknownArg::Free => UnknownCells::Free,
        }
    }
}

/// `--pcd-viewpoint`: what a PCD file's VIEWPOINT means (see [`ViewpointUse`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ViewpointArg {
    Origin,
    Apply,
    Ignore,
}

impl From<ViewpointArg> for ViewpointUse {
    fn from(v: ViewpointArg) -> ViewpointUse {
        match v {
            ViewpointArg::Origin => ViewpointUse::OriginOnly,
            ViewpointArg::Apply => ViewpointUse::Apply,
            ViewpointArg::Ignore => ViewpointUse::Ignore,
        }
    }
}

/// `--scene`: which built-in scene `simulate` scans.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum SceneArg {
    /// The small building of `demo` (`Scene::builtin`) with its scanners.
    Builtin,
    /// A seeded city (`City`) driven by a car-mounted LiDAR.
    City,
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::ValueEnum;

    /// The command-line name of a value.
    fn value_name<T: ValueEnum>(v: &T) -> String {
        v.to_possible_value().unwrap().get_name().to_string()
    }

    #[test]
    fn mode_names_are_the_library_names() {
        let modes: Vec<InsertMode> = ModeArg::value_variants()
            .iter()
            .map(|&m| m.into())
            .collect();
        for (arg, mode) in ModeArg::value_variants().iter().zip(&modes) {
            assert_eq!(value_name(arg), mode.name());
        }
        // every library mode has its word, once
        for (i, m) in modes.iter().enumerate() {
            assert!(!modes[i + 1..].contains(m), "{m:?} twice");
        }
        assert_eq!(modes.len(), 5);
    }

    #[test]
    fn format_names_are_the_library_names() {
        let formats: Vec<InputFormat> = FormatArg::value_variants()
            .iter()
            .map(|&f| f.into())
            .collect();
        assert_eq!(formats, InputFormat::ALL);
        for (arg, format) in FormatArg::value_variants().iter().zip(formats) {
            assert_eq!(value_name(arg), format.name());
        }
    }

    #[test]
    fn ray_and_view_words() {
        let rays: Vec<RayModel> = RayArg::value_variants().iter().map(|&r| r.into()).collect();
        assert_eq!(rays, [RayModel::Dda, RayModel::Bresenham]);
        let views: Vec<View> = ViewArg::value_variants()
            .iter()
            .map(|&v| v.into())
            .collect();
        assert_eq!(views, [View::Top, View::Front, View::Side]);
    }

    #[test]
    fn sensor_model_names_are_the_library_names() {
        let presets: Vec<SensorPreset> = SensorModelArg::value_variants()
            .iter()
            .map(|&m| m.into())
            .collect();
        assert_eq!(presets, SensorPreset::ALL);
        for (arg, preset) in SensorModelArg::value_variants().iter().zip(presets) {
            assert_eq!(value_name(arg), preset.name());
        }
    }
}

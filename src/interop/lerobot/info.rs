//! `meta/info.json` of a LeRobotDataset: the codebase version, the frame rate, the robot type,
//! where the data files are and the names of a feature's values (docs/interop.md §1).

use super::units::BodyUnits;
use super::LeRobotError;
use crate::json::{self, Node};
use std::path::Path;

/// The only layout keypose reads: LeRobot's `CODEBASE_VERSION` since the v3.0 release.
pub const SUPPORTED_VERSION: &str = "v3.0";
/// LeRobot's default data file template (`DEFAULT_DATA_PATH`), for an info.json without one.
pub const DEFAULT_DATA_PATH: &str = "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet";

/// What keypose needs from `meta/info.json`.
#[derive(Debug, Clone, PartialEq)]
pub struct DatasetInfo {
    /// The file read, for messages.
    pub file: String,
    /// Frames per second (above 0, at most 10 000).
    pub fps: f64,
    /// LeRobot's robot type (`so101_follower`); `None` when not given as a string.
    pub robot_type: Option<String>,
    /// The data files' path template (LeRobot's default when not given).
    pub data_path: String,
    /// Episodes in the dataset; `None` when not given.
    pub total_episodes: Option<u64>,
    /// The units of the body joints as keypose wrote them when it exported the dataset
    /// (`"keypose": {"units": "range"}`); `None` for a dataset LeRobot recorded.
    pub keypose_units: Option<BodyUnits>,
    features: serde_json::Value,
}

impl DatasetInfo {
    /// Reads `DIR/meta/info.json`, refusing any codebase version but v3.0.
    pub fn read(dir: &Path) -> Result<DatasetInfo, LeRobotError> {
        let path = dir.join("meta").join("info.json");
        let file = path.display().to_string();
        let text = json::read_text(&path)?;
        DatasetInfo::from_text(&file, &text)
    }

    /// The info.json text of `file` (named in messages).
    pub fn from_text(file: &str, text: &str) -> Result<DatasetInfo, LeRobotError> {
        let file = file.to_string();
        let value = json::parse(&file, text)?;
        let root = Node::root(&file, &value);
        let version = root.require("codebase_version", "the dataset's version")?;
        let found = version.str("a version such as \"v3.0\"")?;
        if found != SUPPORTED_VERSION {
            return Err(LeRobotError::Version {
                file: file.clone(),
                found: found.to_string(),
            });
        }
        let fps_node = root.require("fps", "frames per second")?;
        let fps = fps_node.number("frames per second")?;
        if !(fps.is_finite() && fps > 0.0 && fps <= 10_000.0) {
            return Err(fps_node
                .expected("frames per second above 0 and at most 10000")
                .into());
        }
        let robot_type = match root.get("robot_type").map(|n| n.value.clone()) {
            Some(serde_json::Value::String(s)) => Some(s),
            _ => None,
        };
        let data_path = match root.get("data_path") {
            Some(node) => node.str("a file name template")?.to_string(),
            None => DEFAULT_DATA_PATH.to_string(),
        };
        let total_episodes = match root.get("total_episodes") {
            Some(node) => Some(node.integer("a count of episodes", 0, i64::MAX)? as u64),
            None => None,
        };
        let features = root.require("features", "the dataset's features")?;
        features.object()?;
        let features = features.value.clone();
        let keypose_units = match root.get("keypose") {
            Some(node) => {
                let units = node.require("units", "the body joints' units")?;
                let name = units.str("\"degrees\" or \"range\"")?;
                Some(
                    BodyUnits::parse(name)
                        .ok_or_else(|| units.expected("\"degrees\" or \"range\""))?,
                )
            }
            None => None,
        };
        Ok(DatasetInfo {
            features,
            file: file.clone(),
            fps,
            robot_type,
            data_path,
            total_episodes,
            keypose_units,
        })
    }

    /// An info.json of 30 fps with no features, for unit tests of what only needs its name.
    #[cfg(test)]
    pub(crate) fn for_tests(file: &str) -> DatasetInfo {
        DatasetInfo {
            file: file.to_string(),
            fps: 30.0,
            robot_type: None,
            data_path: DEFAULT_DATA_PATH.to_string(),
            total_episodes: None,
            keypose_units: None,
            features: serde_json::json!({}),
        }
    }

    /// The names of `field`'s values (`features.<field>.names`), as LeRobot writes them: a list
    /// (`["shoulder_pan.pos", …]`), or in the older form an object of lists
    /// (`{"motors": ["shoulder_pan", …]}`), whose lists are the names in order.
    pub fn names(&self, field: &str) -> Result<Vec<String>, LeRobotError> {
        let root = Node::root(&self.file, &self.features);
        let Some(feature) = root.get(field) else {
            let known: Vec<&str> = self
                .features
                .as_object()
                .map(|m| m.keys().map(String::as_str).collect())
                .unwrap_or_default();
            return Err(json::InputError::at_path(
                &self.file,
                "$.features",
                format!(
                    "no feature {field:?}; the dataset has: {}",
                    known.join(", ")
                ),
            )
            .into());
        };
        let names = feature.require("names", "the names of the feature's values")?;
        let mut out = Vec::new();
        match names.value {
            serde_json::Value::Object(_) => {
                for (_, group) in names.entries()? {
                    push_names(&group, &mut out)?;
                }
            }
            _ => push_names(&names, &mut out)?,
        }
        Ok(out)
    }
}

/// The names in the list `node`.
fn push_names(node: &Node, out: &mut Vec<String>) -> Result<(), LeRobotError> {
    let items = node.items().map_err(|_| {
        node.expected("a list of value names, or an object of such lists (\"motors\": […])")
    })?;
    for item in &items {
        out.push(
            item.str("a value name such as \"shoulder_pan.pos\"")?
                .to_string(),
        );
    }
    Ok(())
}

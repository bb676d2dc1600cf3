//! Robot types as LeRobot names them, and where LeRobot keeps a robot's calibration.
//!
//! LeRobot (S6, docs/robots.md §8) registers `--robot.type` names such as `so101_follower`;
//! each type's class has a `name` that, under `HF_LEROBOT_CALIBRATION`, names the directory of
//! its calibrations (`robots/<name>/<id>.json`, leaders under `teleoperators/`). Only the names
//! that denote an arm keypose has built in resolve to it; the others are refused with a reason,
//! never aliased to a look-alike.

use super::builtin::{BuiltinRobot, BUILTINS};
use std::ffi::OsString;
use std::path::PathBuf;

/// Which side of a LeRobot teleoperation pair an arm is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LeRobotRole {
    /// Driven by a policy or a leader: LeRobot's `robots/`.
    Follower,
    /// Moved by hand: LeRobot's `teleoperators/`.
    Leader,
}

/// A LeRobot robot type that is one of keypose's built-in arms (its entry in
/// [`super::builtin::BUILTINS`] says which).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LeRobotType {
    /// LeRobot's `--robot.type` / `--teleop.type` name.
    pub name: &'static str,
    /// Follower or leader.
    pub role: LeRobotRole,
    /// Calibration directories under `HF_LEROBOT_CALIBRATION`, the current LeRobot's first.
    pub calibration_dirs: &'static [&'static str],
}

/// Every LeRobot type that is a built-in arm, with that arm.
fn types() -> impl Iterator<Item = (&'static BuiltinRobot, &'static LeRobotType)> {
    BUILTINS
        .iter()
        .flat_map(|robot| robot.lerobot.iter().map(move |t| (robot, t)))
}

/// A LeRobot type whose arm keypose has not built in.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum NotBuiltIn {
    /// LeRobot's OMX, ROBOTIS's 6-servo arm, which is not the built-in OpenMANIPULATOR-X.
    #[error(
        "{name:?} is LeRobot's OMX {role}, ROBOTIS's 6-servo OMX arm (IDs 11-16), not the \
         OpenMANIPULATOR-X that keypose's built-in \"omx\" describes (docs/robots.md §3); it is not \
         built in: describe it in a robot file (docs/formats.md, \"Robot: keypose-robot/1\") and give its \
         path, e.g. --robot ./omx_lerobot.json"
    )]
    Omx {
        /// The type name given.
        name: String,
        /// "follower" or "leader".
        role: &'static str,
    },
    /// Since the SO classes were merged (S6 d791a431f) LeRobot records a dataset's robot_type as
    /// the class name, `so_follower`, for the SO-100 and the SO-101 alike: which arm it was is
    /// not written down, and their kinematics differ.
    #[error(
        "{name:?} is LeRobot's {role} class of both the SO-100 and the SO-101, which differ in \
         their kinematics; it does not say which arm: give --robot so101 or --robot so100"
    )]
    SoClass {
        /// The type name given.
        name: String,
        /// "follower" or "leader".
        role: &'static str,
    },
}

/// The LeRobot type names that resolve to a built-in, for messages.
pub fn builtin_type_names() -> Vec<&'static str> {
    types().map(|(_, t)| t.name).collect()
}

/// The built-in a LeRobot type name stands for, and the type; None when it is no LeRobot type
/// keypose knows.
pub fn lerobot_type(
    name: &str,
) -> Option<Result<(&'static BuiltinRobot, &'static LeRobotType), NotBuiltIn>> {
    if let Some(known) = types().find(|(_, t)| t.name == name) {
        return Some(Ok(known));
    }
    let role = if name.ends_with("_leader") {
        "leader"
    } else {
        "follower"
    };
    let name_owned = name.to_string();
    match name {
        "omx_follower" | "omx_leader" => Some(Err(NotBuiltIn::Omx {
            name: name_owned,
            role,
        })),
        "so_follower" | "so_leader" => Some(Err(NotBuiltIn::SoClass {
            name: name_owned,
            role,
        })),
        _ => None,
    }
}

/// The environment variables that decide LeRobot's calibration root, in the order LeRobot
/// consults them (S6 `utils/constants.py`; `HF_HOME` from `huggingface_hub.constants`).
pub const CALIBRATION_ENV_VARS: [&str; 5] = [
    "HF_LEROBOT_CALIBRATION",
    "HF_LEROBOT_HOME",
    "HF_HOME",
    "XDG_CACHE_HOME",
    "HOME",
];

/// LeRobot's calibration root and the variable that decided it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CalibrationRoot {
    /// The directory under which LeRobot keeps calibrations.
    pub dir: PathBuf,
    /// The first of [`CALIBRATION_ENV_VARS`] that was set.
    pub decided_by: &'static str,
}

/// No variable gives the root: not even `HOME` is set.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("none of {} is set, so LeRobot's calibration directory is unknown", CALIBRATION_ENV_VARS.join(", "))]
pub struct NoCalibrationRoot;

/// LeRobot's calibration root as its Python computes it:
/// `HF_LEROBOT_CALIBRATION`, else `$HF_LEROBOT_HOME/calibration`, where `HF_LEROBOT_HOME`
/// defaults to `$HF_HOME/lerobot` and `HF_HOME` to `$XDG_CACHE_HOME/huggingface`, with
/// `XDG_CACHE_HOME` defaulting to `~/.cache`. As with Python's `os.getenv`, a variable set to
/// the empty string counts as set. A leading `~` is the home directory (`expanduser`).
pub fn calibration_root(
    env: &dyn Fn(&str) -> Option<OsString>,
) -> Result<CalibrationRoot, NoCalibrationRoot> {
    let home = env("HOME").map(PathBuf::from);
    let expand = |value: OsString| expand_user(value, home.as_ref());
    let chain: [(&'static str, &[&str]); 4] = [
        ("HF_LEROBOT_CALIBRATION", &[]),
        ("HF_LEROBOT_HOME", &["calibration"]),
        ("HF_HOME", &["lerobot", "calibration"]),
        ("XDG_CACHE_HOME", &["huggingface", "lerobot", "calibration"]),
    ];
    for (var, below) in chain {
        if let Some(value) = env(var) {
            let dir = below.iter().fold(expand(value), |dir, part| dir.join(part));
            return Ok(CalibrationRoot {
                dir,
                decided_by: var,
            });
        }
    }
    let home = home.ok_or(NoCalibrationRoot)?;
    Ok(CalibrationRoot {
        dir: home.join(".cache/huggingface/lerobot/calibration"),
        decided_by: "HOME",
    })
}

/// `~` and `~/…` become the home directory, as Python's `expanduser` does for them.
fn expand_user(value: OsString, home: Option<&PathBuf>) -> PathBuf {
    let path = PathBuf::from(value);
    match (home, path.strip_prefix("~")) {
        (Some(home), Ok(rest)) => home.join(rest),
        _ => path,
    }
}

/// An id LeRobot could not have written a calibration for, or one that would leave the
/// calibration directory.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("robot id {id:?}: expected the name given to LeRobot as --robot.id (or --teleop.id): not empty, without '/', and not \".\" or \"..\"")]
pub struct BadRobotId {
    /// The id given.
    pub id: String,
}

/// The files LeRobot would read for `id` of `lerobot`, the current LeRobot's first.
pub fn calibration_candidates(
    root: &CalibrationRoot,
    lerobot: &LeRobotType,
    id: &str,
) -> Result<Vec<PathBuf>, BadRobotId> {
    if id.is_empty() || id.contains(['/', '\0']) || id == "." || id == ".." {
        return Err(BadRobotId { id: id.to_string() });
    }
    Ok(lerobot
        .calibration_dirs
        .iter()
        .map(|dir| root.dir.join(dir).join(format!("{id}.json")))
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;

    fn root_with(vars: &[(&str, &str)]) -> Result<CalibrationRoot, NoCalibrationRoot> {
        let vars: HashMap<String, OsString> = vars
            .iter()
            .map(|(k, v)| (k.to_string(), OsString::from(v)))
            .collect();
        calibration_root(&|name| vars.get(name).cloned())
    }

    #[test]
    fn the_calibration_root_follows_lerobots_defaults() {
        let home = ("HOME", "/home/ada");
        let root = |vars: &[(&str, &str)]| root_with(vars).unwrap();
        assert_eq!(
            root(&[home]).dir,
            PathBuf::from("/home/ada/.cache/huggingface/lerobot/calibration")
        );
        assert_eq!(
            root(&[home, ("XDG_CACHE_HOME", "/x")]).dir,
            PathBuf::from("/x/huggingface/lerobot/calibration")
        );
        assert_eq!(
            root(&[home, ("XDG_CACHE_HOME", "/x"), ("HF_HOME", "~/hf")]).dir,
            PathBuf::from("/home/ada/hf/lerobot/calibration")
        );
        assert_eq!(
            root(&[home, ("HF_HOME", "/hf"), ("HF_LEROBOT_HOME", "/lr")]).dir,
            PathBuf::from("/lr/calibration")
        );
        let given = root(&[
            home,
            ("HF_LEROBOT_HOME", "/lr"),
            ("HF_LEROBOT_CALIBRATION", "/c"),
        ]);
        assert_eq!(given.dir, PathBuf::from("/c"));
        assert_eq!(given.decided_by, "HF_LEROBOT_CALIBRATION");
        assert_eq!(root_with(&[]), Err(NoCalibrationRoot));
    }

    #[test]
    fn so_calibrations_are_looked_for_where_current_lerobot_writes_them_first() {
        let root = root_with(&[("HF_LEROBOT_CALIBRATION", "/c")]).unwrap();
        let (_, leader) = lerobot_type("so101_leader").unwrap().unwrap();
        assert_eq!(
            calibration_candidates(&root, leader, "blue").unwrap(),
            [
                PathBuf::from("/c/teleoperators/so_leader/blue.json"),
                PathBuf::from("/c/teleoperators/so101_leader/blue.json"),
            ]
        );
        let koch = follower_type_of("koch").unwrap();
        assert_eq!(
            calibration_candidates(&root, koch, "k").unwrap(),
            [PathBuf::from("/c/robots/koch_follower/k.json")]
        );
        for id in ["", "..", "a/b"] {
            assert!(calibration_candidates(&root, koch, id).is_err(), "{id:?}");
        }
    }

    /// The follower type of a built-in; None for a built-in LeRobot has no driver for.
    fn follower_type_of(builtin: &str) -> Option<&'static LeRobotType> {
        super::super::builtin::find(builtin)?.follower()
    }

    #[test]
    fn only_arms_keypose_has_are_aliased() {
        assert_eq!(lerobot_type("koch_leader").unwrap().unwrap().0.name, "koch");
        assert_eq!(
            lerobot_type("so100_follower").unwrap().unwrap().0.name,
            "so100"
        );
        assert!(matches!(
            lerobot_type("omx_leader"),
            Some(Err(NotBuiltIn::Omx { .. }))
        ));
        // The merged SO class names no arm: neither is guessed.
        assert!(matches!(
            lerobot_type("so_follower"),
            Some(Err(NotBuiltIn::SoClass { .. }))
        ));
        assert_eq!(lerobot_type("so102_follower"), None);
        assert_eq!(follower_type_of("omx"), None);
    }
}

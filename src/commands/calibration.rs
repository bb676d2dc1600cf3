//! Which LeRobot calibration a command applies: a file given by path (`--calibration`), or the
//! one LeRobot keeps for an arm's id (`--robot-id`), found where LeRobot itself looks.

use super::CommandError;
use keypose::json::{InputError, Location};
use keypose::robot::lerobot_names::{
    calibration_candidates, calibration_root, CalibrationRoot, CALIBRATION_ENV_VARS,
};
use keypose::robot::{LeRobotRole, LeRobotType, Robot};
use std::path::PathBuf;

/// The calibration options every command that loads a robot takes.
#[derive(Debug, Clone, Default, clap::Args)]
pub struct CalibrationArgs {
    /// LeRobot calibration file to apply to the robot's servo mapping and limits.
    #[arg(long, value_name = "FILE", conflicts_with = "robot_id")]
    pub calibration: Option<PathBuf>,
    /// Apply the calibration LeRobot keeps for this arm (the --robot.id or --teleop.id it was
    /// calibrated with), where LeRobot keeps it: $HF_LEROBOT_CALIBRATION/robots/so_follower/NAME.json
    /// for an SO-101, robots/koch_follower/ for a Koch, leaders under teleoperators/ (README
    /// "LeRobot calibration").
    #[arg(long, value_name = "NAME")]
    pub robot_id: Option<String>,
}

/// A calibration file to apply, and how it was found.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CalibrationFile {
    pub path: PathBuf,
    /// The LeRobot type and id it was looked up by, for `--robot-id`.
    pub looked_up: Option<(&'static str, String)>,
}

impl CalibrationArgs {
    pub fn given(&self) -> bool {
        self.calibration.is_some() || self.robot_id.is_some()
    }

    /// The file to apply to `robot`, if any.
    pub fn file_for(&self, robot: &Robot) -> Result<Option<CalibrationFile>, CommandError> {
        if let Some(path) = &self.calibration {
            return Ok(Some(CalibrationFile {
                path: path.clone(),
                looked_up: None,
            }));
        }
        let Some(id) = &self.robot_id else {
            return Ok(None);
        };
        let lerobot = robot.lerobot.ok_or_else(|| {
            CommandError::Usage(format!(
                "--robot-id {id:?}: robot {} ({}) is no LeRobot robot type, so LeRobot keeps no \
                 calibration for it by id: give --calibration FILE",
                robot.name, robot.source
            ))
        })?;
        let root = calibration_root(&|var| std::env::var_os(var))
            .map_err(|e| robot_id_error(format!("{e}: give --calibration FILE")))?;
        let path = find(&root, lerobot, id)?;
        Ok(Some(CalibrationFile {
            path,
            looked_up: Some((lerobot.name, id.clone())),
        }))
    }
}

fn robot_id_error(message: String) -> CommandError {
    InputError::new("--robot-id", Location::File, message).into()
}

/// The first of LeRobot's places for `id` that holds a file.
fn find(root: &CalibrationRoot, lerobot: &LeRobotType, id: &str) -> Result<PathBuf, CommandError> {
    let candidates =
        calibration_candidates(root, lerobot, id).map_err(|e| robot_id_error(e.to_string()))?;
    if let Some(found) = candidates.iter().find(|path| path.is_file()) {
        return Ok(found.clone());
    }
    Err(robot_id_error(missing_message(
        root,
        lerobot,
        id,
        &candidates,
    )))
}

fn missing_message(
    root: &CalibrationRoot,
    lerobot: &LeRobotType,
    id: &str,
    candidates: &[PathBuf],
) -> String {
    let shown: Vec<String> = candidates.iter().map(|p| p.display().to_string()).collect();
    // The first place is the current LeRobot's; any others are where older versions wrote.
    let looked_at = match shown.split_first() {
        Some((current, [])) => current.clone(),
        Some((current, older)) => format!(
            "{current} and {} (where LeRobot before 2026-01 kept it)",
            older.join(", ")
        ),
        None => root.dir.display().to_string(),
    };
    let option = match lerobot.role {
        LeRobotRole::Follower => "robot",
        LeRobotRole::Leader => "teleop",
    };
    format!(
        "no LeRobot calibration for {} id {id:?}: looked at {looked_at}; the directory {} comes \
         from {} (LeRobot reads {} in that order, the first one set wins): calibrate with \
         `lerobot-calibrate --{option}.type={} --{option}.id={id}`, set HF_LEROBOT_CALIBRATION, or \
         give --calibration FILE",
        lerobot.name,
        root.dir.display(),
        root.decided_by,
        CALIBRATION_ENV_VARS.join(", "),
        lerobot.name,
    )
}

/// Says which calibration is applied: always when it was looked up by id (the user did not name
/// the file), under `-v` otherwise.
pub fn announce(file: &CalibrationFile, verbose: bool) {
    match &file.looked_up {
        Some((lerobot, id)) => eprintln!(
            "calibration: {} (LeRobot {lerobot} id {id:?})",
            file.path.display()
        ),
        None if verbose => eprintln!("calibration: {}", file.path.display()),
        None => {}
    }
}

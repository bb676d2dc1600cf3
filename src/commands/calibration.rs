//! Which LeRobot calibration a command applies: a file given by path (`--calibration`), or the
//! one LeRobot keeps for an arm's id (`--robot-id`), found where LeRobot itself looks.

use super::CommandError;
use keypose::json::{InputError, Location};
use keypose::robot::{
    calibration_candidates, calibration_root, CalibrationRoot, LeRobotRole, LeRobotType, Robot,
    CALIBRATION_ENV_VARS,
};
use std::path::PathBuf;

/// The calibration options every command that loads a robot takes. On a sequence of several
/// arms each value names its arm (`--calibration left=FILE --robot-id right=NAME`).
#[derive(Debug, Clone, Default, clap::Args)]
pub struct CalibrationArgs {
    /// LeRobot calibration file to apply to the robot's servo mapping and limits (ARM=FILE for
    /// an arm of a sequence of several, once per arm).
    #[arg(long, value_name = "[ARM=]FILE")]
    pub calibration: Vec<String>,
    /// Apply the calibration LeRobot keeps for this arm (the --robot.id or --teleop.id it was
    /// calibrated with), where LeRobot keeps it: $HF_LEROBOT_CALIBRATION/robots/so_follower/NAME.json
    /// for an SO-101, robots/koch_follower/ for a Koch, leaders under teleoperators/ (docs/formats.md,
    /// "LeRobot calibration"). ARM=NAME for an arm of a sequence of several.
    #[arg(long, value_name = "[ARM=]NAME")]
    pub robot_id: Vec<String>,
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
        !self.calibration.is_empty() || !self.robot_id.is_empty()
    }

    /// The options for arm `arm` of a cell whose arms are `arms`: the values given as
    /// `arm=…`. A value without a known arm's name is refused, as it would apply to no arm.
    pub fn for_arm(&self, arm: &str, arms: &[&str]) -> Result<CalibrationArgs, CommandError> {
        let pick = |values: &[String], option: &str| -> Result<Vec<String>, CommandError> {
            let mut mine = Vec::new();
            for value in values {
                match value.split_once('=') {
                    Some((name, rest)) if arms.contains(&name) => {
                        if name == arm {
                            mine.push(rest.to_string());
                        }
                    }
                    _ => {
                        return Err(CommandError::Usage(format!(
                            "{option} {value:?}: the sequence has several arms; expected ARM=VALUE with ARM one of {}",
                            arms.join(", ")
                        )))
                    }
                }
            }
            Ok(mine)
        };
        Ok(CalibrationArgs {
            calibration: pick(&self.calibration, "--calibration")?,
            robot_id: pick(&self.robot_id, "--robot-id")?,
        })
    }

    /// The file to apply to `robot`, if any.
    pub fn file_for(&self, robot: &Robot) -> Result<Option<CalibrationFile>, CommandError> {
        if self.calibration.len() + self.robot_id.len() > 1 {
            return Err(CommandError::Usage(
                "--calibration and --robot-id: expected one calibration for the arm, found several"
                    .into(),
            ));
        }
        if let Some(path) = self.calibration.first() {
            return Ok(Some(CalibrationFile {
                path: PathBuf::from(path),
                looked_up: None,
            }));
        }
        let Some(id) = self.robot_id.first() else {
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

//! `keypose torque on|off`: hold the arm where it is, or let it go limp.

use super::{BusArgs, CommandError, RobotArgs, Verdict};
use keypose::robot::Robot;

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum OnOff {
    On,
    Off,
}

#[derive(Debug, Clone, clap::Args)]
pub struct TorqueArgs {
    /// on: hold position; off: limp, the joints can be moved by hand (they will fall under
    /// gravity: support the arm).
    #[arg(value_enum)]
    pub state: OnOff,
    #[command(flatten)]
    pub robot: RobotArgs,
    #[command(flatten)]
    pub bus: BusArgs,
    /// Only these joints (comma-separated) [default: all].
    #[arg(long, value_name = "NAMES", value_delimiter = ',')]
    pub joints: Vec<String>,
}

/// `keypose torque on|off`.
pub fn run(args: &TorqueArgs) -> Result<Verdict, CommandError> {
    let robot = args.robot.load()?;
    super::announce_robot(&robot);
    let joints = super::joint_indices(&robot, &args.joints)?;
    let ids: Vec<u8> = joints.iter().map(|&j| robot.joints[j].servo.id).collect();
    let mut connection = args.bus.open(&robot)?;
    let on = args.state == OnOff::On;
    if on {
        // Torque on must hold where the arm is: set the goals to the present positions first,
        // and only where a goal may go.
        let ticks = connection.bus.read_positions(&ids)?;
        let goals = hold_goals(&robot, &joints, &ticks)?;
        connection.bus.write_goals(&goals)?;
    }
    connection.bus.set_torque(&ids, on)?;
    eprintln!(
        "torque {} on servo(s) {ids:?}",
        if on { "on" } else { "off" }
    );
    Ok(Verdict::Pass)
}

/// A goal at each joint's present tick, refused for a joint past its limits (holding it there
/// would need a goal outside them).
fn hold_goals(
    robot: &Robot,
    joints: &[usize],
    ticks: &[i64],
) -> Result<Vec<(u8, i64)>, CommandError> {
    joints
        .iter()
        .zip(ticks)
        .map(|(&j, &tick)| {
            let joint = &robot.joints[j];
            let goal = joint.hold_tick(tick).ok_or_else(|| {
                CommandError::Usage(format!(
                    "{} is at {:.2} {}, past its limits {} … {}: move it inside by hand first (nothing was sent)",
                    joint.name,
                    joint.servo.value(tick),
                    joint.kind.unit(),
                    joint.limits.min,
                    joint.limits.max
                ))
            })?;
            Ok((joint.servo.id, goal))
        })
        .collect()
}

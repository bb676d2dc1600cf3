//! `keypose pose`: where the tool is at a pose, each joint against its limits, and whether the
//! arm held there touches the floor or itself (MuJoCo's collision check, no dynamics). With
//! `--directions FILE.png`, a picture of the robot's joint directions instead.

use super::check::ReportFormat;
use super::{write_output, BusArgs, CommandError, RobotArgs, Verdict};
use glam::DVec3;
use keypose::collision::CollisionModel;
use keypose::kinematics::{
    tool_joints, Approach, Chosen, IkError, KeyOrientation, KeyTarget, Preference, Solver, COMFORT,
};
use keypose::pose::{quat_from_rpy, rpy_from_quat};
use keypose::robot::{Joint, JointKind, Robot};
use keypose::sequence::ToolApproach;
use keypose::sim::verdict::{collisions, Contact, ContactKind, Thresholds};
use keypose::sim::{self, Simulation};
use serde_json::json;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

#[derive(Debug, Clone, clap::Args)]
pub struct PoseArgs {
    /// Joint values, e.g. elbow_flex=-30: degrees (metres for a prismatic joint). Joints not
    /// given stay at the robot's home.
    #[arg(value_name = "JOINT=VALUE")]
    pub values: Vec<String>,
    #[command(flatten)]
    pub robot: RobotArgs,
    /// Report format.
    #[arg(long, value_enum, default_value_t = ReportFormat::Text)]
    pub format: ReportFormat,
    /// Another MJCF model for the collision check (its joint names must match the robot's).
    #[arg(long, value_name = "FILE")]
    pub mjcf: Option<PathBuf>,
    /// Instead of checking a pose, draw the robot's joint directions to a PNG contact sheet:
    /// the zero pose, then each joint alone at its positive step (+30°, or its upper limit if
    /// nearer; a prismatic joint at its upper limit).
    #[arg(long, value_name = "FILE.png", conflicts_with = "values")]
    pub directions: Option<PathBuf>,
    /// Instead of joint values, where the tool (the robot's tcp) should be: X,Y,Z in metres in
    /// the base frame, optionally followed by ROLL,PITCH,YAW in degrees (as this command prints
    /// them; a sequence's "rpy" takes radians). Solved as a sequence's tool key is: clear of
    /// the floor and the arm itself, a quarter of each joint's half range from its limits where
    /// it can be, then nearest the home pose (the arm's present pose with --port). Prints each
    /// joint's margin to its limits.
    #[arg(long, value_name = "X,Y,Z[,R,P,Y]", conflicts_with_all = ["values", "directions"], allow_hyphen_values = true)]
    pub tool: Option<String>,
    /// With `--tool X,Y,Z`: which way the tool points, as a sequence's "approach" says it:
    /// `down` (an error where the arm cannot point the tool straight down there) or
    /// `down-or-tilted` (down where it can, else the least tilt from down it can).
    #[arg(long, value_name = "APPROACH", requires = "tool", value_parser = parse_approach)]
    pub approach: Option<ToolApproach>,
    /// With `--tool`: the arm whose present pose the solution stays near (as a sequence's key
    /// stays near the previous one), instead of the home pose. Nothing is moved.
    #[command(flatten)]
    pub bus: BusArgs,
}

/// `--approach`: a sequence's "approach" spelling.
fn parse_approach(text: &str) -> Result<ToolApproach, String> {
    ToolApproach::parse(text).ok_or_else(|| {
        let spellings: Vec<&str> = ToolApproach::ALL.iter().map(|a| a.spelling()).collect();
        format!("expected one of: {}", spellings.join(", "))
    })
}

/// The step each joint is drawn at in the joint-directions picture, degrees.
const DIRECTION_STEP_DEG: f64 = 30.0;

/// The joint-directions camera: from the front-right (−y side) and well above, so that joints
/// turning about a horizontal axis and the pan about the vertical one both show.
const DIRECTIONS_CAMERA: sim::Camera = sim::Camera {
    azimuth: 60.0,
    elevation: -35.0,
};

/// A pose, checked: joint values in joint order and which of them were given.
struct Pose {
    values: Vec<f64>,
    given: Vec<bool>,
}

pub fn run(args: &PoseArgs) -> Result<Verdict, CommandError> {
    let robot = args.robot.load()?;
    if let Some(mjcf) = &args.mjcf {
        sim::check_mjcf_file(mjcf)?;
    }
    let model = args.mjcf.as_deref().map(sim::MjcfModel::new);
    if let Some(path) = &args.directions {
        return draw_directions(&robot, model.as_ref(), path);
    }
    let (pose, solved) = match &args.tool {
        Some(text) => {
            let seed = seed(&robot, &args.bus)?;
            solve_tool(&robot, text, args.approach, seed)?
        }
        None if args.bus.given() => {
            return Err(CommandError::Usage(
                "--port gives the pose --tool starts from: give --tool X,Y,Z too".into(),
            ))
        }
        None => (parse_pose(&robot, &args.values)?, None),
    };
    let mut simulation = Simulation::start(&robot, model.as_ref(), None)?;
    let contacts = simulation.pose_contacts(&robot, &pose.values)?;
    let thresholds = Thresholds::default();
    let touching = floor_first(collisions(&contacts, &thresholds));
    let text = match args.format {
        ReportFormat::Text => {
            let solved_text = solved
                .as_ref()
                .map(|s| solution_text(&robot, s))
                .unwrap_or_default();
            solved_text + &text_report(&robot, simulation.model(), &pose, &touching)
        }
        ReportFormat::Json => {
            let mut report = json_report(&robot, simulation.model(), &pose, &touching, &thresholds);
            if let Some(s) = &solved {
                report["solved"] = solution_json(&robot, s);
            }
            format!("{report:#}\n")
        }
    };
    write_output(None, &text)?;
    Ok(if touching.is_empty() {
        Verdict::Pass
    } else {
        Verdict::Fail
    })
}

/// The target of a tool at `position` (metres, base frame): oriented by ROLL, PITCH, YAW in
/// degrees (URDF's, as this command prints them), pointing as `approach` says, or free.
pub fn tool_target(
    position: DVec3,
    rpy_deg: Option<[f64; 3]>,
    approach: Option<ToolApproach>,
) -> KeyTarget {
    let orientation = match (rpy_deg, approach) {
        (Some([r, p, y]), _) => KeyOrientation::Full(quat_from_rpy(
            r.to_radians(),
            p.to_radians(),
            y.to_radians(),
        )),
        (None, Some(a)) => {
            KeyOrientation::Approach(Approach::down(a == ToolApproach::DownOrTilted))
        }
        (None, None) => KeyOrientation::Free,
    };
    KeyTarget {
        position,
        orientation,
    }
}

/// The joints for `target`, solved as a sequence's tool key is from `seed` (every joint,
/// robot order): clear of the floor and the arm itself, away from the limits, then near `seed`.
pub fn solve_target(robot: &Robot, target: &KeyTarget, seed: &[f64]) -> Result<Chosen, IkError> {
    let held = vec![false; robot.joints.len()];
    let collision = CollisionModel::for_robot(robot);
    let preference = Preference {
        seed,
        held: &held,
        collision: collision.as_ref(),
    };
    Solver::for_robot(robot).solve_key(robot, target, &preference)
}

/// A tool target from `--tool` and its solution.
struct Solved {
    target: KeyTarget,
    chosen: Chosen,
    closed_form: bool,
    seed: Seed,
}

/// The pose a `--tool` solution stays near.
struct Seed {
    values: Vec<f64>,
    /// "the home pose", or "the arm's present pose".
    what: &'static str,
}

/// The arm's present pose when a `--port` is given (read once, nothing written), else home.
fn seed(robot: &Robot, bus: &BusArgs) -> Result<Seed, CommandError> {
    if !bus.given() {
        return Ok(Seed {
            values: robot.home.clone(),
            what: "the home pose",
        });
    }
    let mut connection = bus.open(robot)?;
    let ids: Vec<u8> = robot.joints.iter().map(|j| j.servo.id).collect();
    let ticks = connection.bus.read_positions(&ids)?;
    let values = robot
        .joints
        .iter()
        .zip(&ticks)
        .map(|(joint, &tick)| joint.servo.value(tick))
        .collect();
    Ok(Seed {
        values,
        what: "the arm's present pose",
    })
}

/// `X,Y,Z[,ROLL,PITCH,YAW]` solved as a key from `seed`: the pose (tool joints marked given).
fn solve_tool(
    robot: &Robot,
    text: &str,
    approach: Option<ToolApproach>,
    seed: Seed,
) -> Result<(Pose, Option<Solved>), CommandError> {
    let usage = |why: String| CommandError::Usage(format!("--tool {text:?}: {why}"));
    let numbers: Vec<f64> = text
        .split(',')
        .map(|n| n.trim().parse::<f64>().ok().filter(|v| v.is_finite()))
        .collect::<Option<_>>()
        .ok_or_else(|| usage("expected numbers separated by commas".into()))?;
    let position = |x, y, z| DVec3::new(x, y, z);
    let target = match (&numbers[..], approach) {
        (&[x, y, z], approach) => tool_target(position(x, y, z), None, approach),
        (&[_, _, _, _, _, _], Some(_)) => {
            return Err(usage(
                "--approach says which way the tool points, and so do ROLL,PITCH,YAW: give one"
                    .into(),
            ))
        }
        (&[_, _, _, r, p, yaw], None) if [r, p, yaw].iter().any(|a| a.abs() > 360.0) => {
            return Err(usage(format!(
                "ROLL,PITCH,YAW are degrees (as `keypose pose` prints them), each within \
                 ±360; found {r}, {p}, {yaw}"
            )))
        }
        (&[x, y, z, r, p, yaw], None) => tool_target(position(x, y, z), Some([r, p, yaw]), None),
        _ => {
            return Err(usage(format!(
                "expected X,Y,Z (metres) or X,Y,Z,ROLL,PITCH,YAW (degrees), found {} numbers",
                numbers.len()
            )))
        }
    };
    let chosen = solve_target(robot, &target, &seed.values).map_err(|e| usage(e.to_string()))?;
    let pose = Pose {
        values: chosen.solution.values.clone(),
        given: tool_joints(robot),
    };
    let closed_form = Solver::for_robot(robot).is_closed_form();
    Ok((
        pose,
        Some(Solved {
            target,
            chosen,
            closed_form,
            seed,
        }),
    ))
}

/// The solution's header: the target, the solver, the orientation residual, the margins.
fn solution_text(robot: &Robot, solved: &Solved) -> String {
    let mut out = String::new();
    let p = solved.target.position;
    let how = if solved.closed_form {
        "closed form"
    } else {
        "damped least squares"
    };
    let _ = writeln!(
        out,
        "solved ({how}) for the tool at x {:.4}  y {:.4}  z {:.4} m, from {}",
        p.x, p.y, p.z, solved.seed.what
    );
    if let Some(r) = solved.chosen.solution.orientation_residual_deg {
        let _ = writeln!(
            out,
            "orientation off by {:.2}°, {:.2}°, {:.2}° about the tool's x, y, z",
            r.x, r.y, r.z
        );
    }
    if let (Some(tilt), KeyOrientation::Approach(a)) =
        (solved.chosen.tilt_deg, solved.target.orientation)
    {
        let _ = writeln!(out, "{}", approach_line(&a, tilt));
    }
    for (joint, value) in robot.joints.iter().zip(&solved.chosen.solution.values) {
        let margin = (value - joint.limits.min).min(joint.limits.max - value);
        let _ = writeln!(
            out,
            "  {:<20} margin {margin:>8.2} {} to the nearest limit",
            joint.name,
            joint.kind.unit()
        );
    }
    if let Some(m) = solved.chosen.margin {
        let joint = &robot.joints[m.joint];
        let _ = writeln!(
            out,
            "smallest margin: {} {:.2} {}, {:.0} % of its half range (a key keeps {:.0} % \
             where it can)",
            joint.name,
            m.value,
            joint.kind.unit(),
            m.share * 100.0,
            COMFORT * 100.0
        );
    }
    out
}

/// Which way the tool points against the approach asked.
fn approach_line(approach: &Approach, tilt: f64) -> String {
    let name = approach.name();
    if tilt < 0.05 {
        format!("pointing {name}")
    } else {
        format!("tilted {tilt:.1}° from {name}: the arm cannot point the tool {name} there")
    }
}

fn solution_json(robot: &Robot, solved: &Solved) -> serde_json::Value {
    let margins: Vec<_> = robot
        .joints
        .iter()
        .zip(&solved.chosen.solution.values)
        .map(|(j, v)| json!({ "name": j.name, "margin": (v - j.limits.min).min(j.limits.max - v) }))
        .collect();
    let smallest = solved.chosen.margin.map(|m| {
        json!({
            "name": robot.joints[m.joint].name,
            "margin": m.value,
            "share_of_half_range": m.share,
        })
    });
    json!({
        "target": solved.target.position.to_array(),
        "tilt_deg": solved.chosen.tilt_deg,
        "seed": { "from": solved.seed.what, "values": solved.seed.values },
        "smallest_margin": smallest,
        "solver": if solved.closed_form { "closed form" } else { "damped least squares" },
        "orientation_residual_deg": solved.chosen.solution.orientation_residual_deg.map(|r| r.to_array()),
        "margins": margins,
    })
}

/// The robot's home with the given `JOINT=VALUE`s applied, each inside its joint's limits.
fn parse_pose(robot: &Robot, assignments: &[String]) -> Result<Pose, CommandError> {
    let mut pose = Pose {
        values: robot.home.clone(),
        given: vec![false; robot.joints.len()],
    };
    for text in assignments {
        let (index, value) = parse_assignment(robot, text)?;
        if pose.given[index] {
            return Err(CommandError::Usage(format!(
                "{text:?}: joint {} is given twice",
                robot.joints[index].name
            )));
        }
        pose.values[index] = value;
        pose.given[index] = true;
    }
    Ok(pose)
}

/// One `JOINT=VALUE`: the joint's index and a value inside its limits.
fn parse_assignment(robot: &Robot, text: &str) -> Result<(usize, f64), CommandError> {
    let usage = |why: String| CommandError::Usage(format!("{text:?}: {why}"));
    let (name, value) = text
        .split_once('=')
        .ok_or_else(|| usage("expected JOINT=VALUE, e.g. elbow_flex=-30".into()))?;
    let index = robot.joint_index(name.trim()).ok_or_else(|| {
        usage(format!(
            "robot {} has no joint {:?}; its joints are: {}",
            robot.name,
            name.trim(),
            robot.joint_names().join(", ")
        ))
    })?;
    let joint = &robot.joints[index];
    let unit = joint.kind.unit();
    let value: f64 = value
        .trim()
        .parse()
        .ok()
        .filter(|v: &f64| v.is_finite())
        .ok_or_else(|| usage(format!("expected a number ({unit}) after '='")))?;
    if !joint.limits.contains(value) {
        return Err(usage(format!(
            "{} {value} {unit} is outside its limits {} … {} {unit}",
            joint.name, joint.limits.min, joint.limits.max
        )));
    }
    Ok((index, value))
}

/// The tool frame at `values`: position (m) and URDF roll-pitch-yaw (degrees), base frame.
pub fn tool(robot: &Robot, values: &[f64]) -> ([f64; 3], [f64; 3]) {
    let frame = robot.tcp_frame(values);
    let (roll, pitch, yaw) = rpy_from_quat(frame.r);
    (
        frame.t.to_array(),
        [roll.to_degrees(), pitch.to_degrees(), yaw.to_degrees()],
    )
}

/// What the tool frame is called in the report: the robot's `tcp`, or the last joint's frame.
fn tool_name(robot: &Robot) -> String {
    match (&robot.tcp, robot.joints.last()) {
        (Some(_), _) => "tcp".into(),
        (None, Some(last)) => format!("{} frame (the robot defines no tcp)", last.name),
        (None, None) => "base".into(),
    }
}

/// Floor contacts first, then the deepest first (a pose has no time order to keep).
fn floor_first(mut found: Vec<&Contact>) -> Vec<&Contact> {
    found.sort_by(|a, b| {
        (b.kind == ContactKind::Floor)
            .cmp(&(a.kind == ContactKind::Floor))
            .then(b.depth.total_cmp(&a.depth))
    });
    found
}

/// The body of a floor contact that is the robot's (the floor is the world body's).
fn robot_body(contact: &Contact) -> &str {
    if contact.body1 == "world" {
        &contact.body2
    } else {
        &contact.body1
    }
}

/// One collision in words, naming both bodies (the floor as "the floor").
fn describe(contact: &Contact) -> String {
    let depth = contact.depth * 1000.0;
    match contact.kind {
        ContactKind::Floor => {
            format!(
                "{} touches the floor, {depth:.1} mm deep",
                robot_body(contact)
            )
        }
        ContactKind::SelfCollision => format!(
            "{} touches {} (self-collision), {depth:.1} mm deep",
            contact.body1, contact.body2
        ),
        ContactKind::BetweenArms | ContactKind::Environment => {
            format!("{}, {depth:.1} mm deep", contact.bodies())
        }
    }
}

fn text_report(robot: &Robot, model: &str, pose: &Pose, touching: &[&Contact]) -> String {
    let mut out = String::new();
    let ([x, y, z], [roll, pitch, yaw]) = tool(robot, &pose.values);
    let _ = writeln!(
        out,
        "robot {} ({}), model {model}",
        robot.name, robot.source
    );
    let _ = writeln!(
        out,
        "tool ({}) in the base frame: x {x:.4}  y {y:.4}  z {z:.4} m; roll {roll:.1}  pitch {pitch:.1}  yaw {yaw:.1} deg",
        tool_name(robot)
    );
    // A sequence's "rpy" is in radians, as URDF and the robot files have it: the same pose
    // written as a tool key, so nobody converts by hand.
    let [r, p, w] = [roll, pitch, yaw].map(f64::to_radians);
    let _ = writeln!(
        out,
        "  as a tool key: \"tool\": {{\"xyz\": [{x:.4}, {y:.4}, {z:.4}], \"rpy\": [{r:.4}, {p:.4}, {w:.4}]}} (rpy in radians)"
    );
    let _ = writeln!(out, "  {:<20} {:>12} {:>26}", "joint", "value", "limits");
    for ((joint, value), given) in robot.joints.iter().zip(&pose.values).zip(&pose.given) {
        let _ = writeln!(out, "{}", joint_line(joint, *value, *given));
    }
    if touching.is_empty() {
        let _ = writeln!(
            out,
            "clear: nothing touches the floor or the arm itself (no contact deeper than {:.1} mm)",
            Thresholds::default().contact_depth * 1000.0
        );
    } else {
        let _ = writeln!(out, "TOUCHES: {} contact(s)", touching.len());
        for contact in touching {
            let _ = writeln!(out, "  {}", describe(contact));
        }
    }
    out
}

fn joint_line(joint: &Joint, value: f64, given: bool) -> String {
    let unit = joint.kind.unit();
    let decimals = match joint.kind {
        JointKind::Revolute => 2,
        JointKind::Prismatic => 4,
    };
    let (min, max) = (joint.limits.min, joint.limits.max);
    let origin = if given { "" } else { "  (home)" };
    format!(
        "  {:<20} {value:>9.decimals$} {unit:<3}   {min:>9.decimals$} … {max:>8.decimals$} {unit:<3}{origin}",
        joint.name
    )
}

fn json_report(
    robot: &Robot,
    model: &str,
    pose: &Pose,
    touching: &[&Contact],
    thresholds: &Thresholds,
) -> serde_json::Value {
    let (position, rpy) = tool(robot, &pose.values);
    let joints: Vec<_> = robot
        .joints
        .iter()
        .zip(&pose.values)
        .zip(&pose.given)
        .map(|((joint, value), given)| {
            json!({
                "name": joint.name,
                "value": value,
                "unit": joint.kind.unit(),
                "min": joint.limits.min,
                "max": joint.limits.max,
                "given": given,
            })
        })
        .collect();
    let contacts: Vec<_> = touching
        .iter()
        .map(|c| {
            json!({
                "kind": c.kind.name(),
                "body1": c.body1,
                "body2": c.body2,
                "depth_m": c.depth,
                "message": describe(c),
            })
        })
        .collect();
    json!({
        "robot": robot.name,
        "model": model,
        "tool": {
            "frame": tool_name(robot),
            "position_m": position,
            "rpy_deg": rpy,
            "rpy_rad": rpy.map(f64::to_radians),
        },
        "joints": joints,
        "clear": touching.is_empty(),
        "contact_depth_m": thresholds.contact_depth,
        "contacts": contacts,
    })
}

/// The joint-directions picture: the zero pose, then each joint alone at its positive step.
fn draw_directions(
    robot: &Robot,
    mjcf: Option<&sim::MjcfModel>,
    path: &Path,
) -> Result<Verdict, CommandError> {
    if !path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("png"))
    {
        return Err(CommandError::Usage(format!(
            "--directions {}: expected a .png file",
            path.display()
        )));
    }
    // An unwritable place is the user's to mend (exit 2), said before MuJoCo starts.
    let directory = match path.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => dir,
        _ => Path::new("."),
    };
    if !directory.is_dir() {
        return Err(CommandError::Usage(format!(
            "--directions {}: the directory {} does not exist",
            path.display(),
            directory.display()
        )));
    }
    let zero = vec![0.0; robot.joints.len()];
    let mut frames = vec![zero.clone()];
    let mut labels = vec!["zero pose".to_string()];
    for (index, joint) in robot.joints.iter().enumerate() {
        let step = positive_step(joint);
        let mut frame = zero.clone();
        frame[index] = step;
        frames.push(frame);
        labels.push(match joint.kind {
            JointKind::Revolute => format!("{} +{step:.0} deg", joint.name),
            JointKind::Prismatic => format!("{} +{:.0} mm", joint.name, step * 1000.0),
        });
    }
    let gl = sim::render(robot, mjcf, &frames, &labels, path, &DIRECTIONS_CAMERA)?;
    eprintln!(
        "{}: joint directions of {} ({} frames) drawn ({gl})",
        path.display(),
        robot.name,
        frames.len()
    );
    Ok(Verdict::Pass)
}

/// How far a joint is moved from zero to show its positive direction: +30° (or the upper
/// limit if nearer), a prismatic joint its whole positive travel (millimetres would not show).
fn positive_step(joint: &Joint) -> f64 {
    match joint.kind {
        JointKind::Revolute => DIRECTION_STEP_DEG.min(joint.limits.max),
        JointKind::Prismatic => joint.limits.max,
    }
}

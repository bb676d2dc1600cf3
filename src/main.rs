//! The `keypose` command line: parse arguments, run the verb, map the outcome to an exit code.
//!
//! The Python package (bindings/) compiles this file too, as a module: its `keypose` console
//! script calls [`run`] with the script's arguments, and its API reuses the verbs' loading of
//! sequences, robots and calibrations so that its errors say what the command line says.

pub(crate) mod commands;

use clap::{Parser, Subcommand};
use commands::{CommandError, Verdict};
use std::ffi::OsString;
use std::process::ExitCode;

#[derive(Debug, Parser)]
#[command(
    name = "keypose",
    version,
    about = "Teach a robot arm poses key by key and play them back smoothly",
    after_help = "Exit codes: 0 success; 1 a check or simulation verdict failed (mirror: a value \
                  was clipped to a limit); 2 bad input \
                  (files, arguments); 3 hardware or bus error; 130 interrupted."
)]
struct Cli {
    /// Say which inputs are used (the robot: built-in or file; the calibration).
    #[arg(short, long, global = true)]
    verbose: bool,
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Check the exact curve against the robot's limits, its clearance and its servos' torque.
    ///
    /// Position, velocity, acceleration (and jerk) limits on the exact polynomials, contacts
    /// with the floor, the arm itself or another arm along the whole path, and each servo's
    /// torque against its torque-speed line. Every violation is reported with its joint,
    /// keyframe segment, time and amount; exit code 1 when there is any.
    Check(commands::check::CheckArgs),
    /// Write the trajectory at a fixed rate as CSV (time,<joint>,…) or JSON.
    ///
    /// Rows are at t = t0 + k/rate from the first to the last played key time inclusive.
    Sample(commands::sample::SampleArgs),
    /// Draw position and velocity per joint against time as an SVG, with keys and limit bands.
    Plot(commands::plot::PlotArgs),
    /// Stretch key times, segment by segment, until velocity and acceleration limits hold, and
    /// write the new sequence.
    Retime(commands::retime::RetimeArgs),
    /// Mirror a sequence across each arm's own vertical plane (joints turning about axes in
    /// it, such as a pan and a wrist roll, change sign), or one arm's motion onto another
    /// (`--arms left:right`), and write it.
    ///
    /// Values the mirror puts outside the target joint's limits are clipped to the limit and
    /// reported; exit code 1 when any was (the file is written all the same).
    Mirror(commands::mirror::MirrorArgs),
    /// Play a sequence in MuJoCo and judge it: tracking, collisions, joint stops, saturation,
    /// servo speed, divergence. Exit code 1 when the verdict fails.
    Sim(commands::sim::SimArgs),
    /// Play a sequence on servos (or, with no --port, in MuJoCo): ramp from the present pose,
    /// stream at the control rate.
    ///
    /// Ctrl-C decelerates along the path and holds (torque stays on); a second Ctrl-C holds at
    /// once. A servo alarm, a failed write, repeated read failures or a lost port stop
    /// streaming at once with exit code 3. The sequence is checked against the limits at the
    /// chosen speed first, and refused (exit 1) if it breaks them.
    Play(commands::play::PlayArgs),
    /// Teach poses key by key in a terminal UI: limp the arm or jog it, capture keys, edit the
    /// list, play it, save it.
    Teach(commands::teach::TeachArgs),
    /// Teach, edit and preview in the browser, with the arm in 3D: serves a page on
    /// 127.0.0.1 and prints its URL (with an access token) as the first line.
    ///
    /// The page drives the same session as `keypose teach` (the same keys). One page controls
    /// the arm, others watch; closing the controlling page stops playback the soft way.
    /// Ctrl-C stops the arm (decelerating; twice: at once) and ends the studio. Without
    /// --port no arm is needed: the arm is drawn only and nothing is sent anywhere.
    Studio(commands::studio::StudioArgs),
    /// Record a motion made by hand (torque off), then turn it into the fewest keyframes that
    /// reproduce it within a tolerance.
    Record(commands::record::RecordArgs),
    /// Turn motion from elsewhere into a sequence: `import lerobot DIR --episode N -o SEQ.json`.
    #[command(subcommand)]
    Import(commands::import::ImportFormat),
    /// Write a sequence for elsewhere: a ROS 2 JointTrajectory, a play_motion2 motion, a C
    /// header for the stand-alone player, a LeRobot dataset.
    #[command(subcommand)]
    Export(commands::export::ExportFormat),
    /// Where the tool is at a pose (joints not given at home), each joint against its limits,
    /// and whether the arm there touches the floor or itself: exit code 1 when it does.
    ///
    /// `--directions FILE.png` draws the zero pose and each joint's positive direction instead.
    Pose(commands::pose::PoseArgs),
    /// Print the present pose (degrees; metres for prismatic joints) as JSON.
    Read(commands::read::ReadArgs),
    /// Turn torque on (hold where the arm is) or off (limp) for all or some joints.
    Torque(commands::torque::TorqueArgs),
    /// Find the servos on a port: ping every id, report ids and models as JSON.
    Scan(commands::scan::ScanArgs),
    /// List serial ports, with USB adapter details where the system gives them.
    Ports,
    /// Check this machine: serial ports, USB latency timers, the Python environment.
    Doctor,
    /// Serve emulated servos of a robot on a pseudo-terminal.
    ///
    /// Prints the device path as the first line, then serves until standard input closes or
    /// the process is terminated.
    VirtualBus(commands::virtual_bus::VirtualBusArgs),
}

fn main() -> ExitCode {
    ExitCode::from(run(std::env::args_os()))
}

/// Runs the command line `args` (the program's name first) and returns its exit code.
pub fn run(args: impl IntoIterator<Item = OsString>) -> u8 {
    let cli = match Cli::try_parse_from(args) {
        Ok(cli) => cli,
        // Help, the version and usage errors are printed as `Cli::parse` prints them, with its
        // exit codes (0, or 2 for a usage error).
        Err(error) => {
            let _ = error.print();
            return error.exit_code() as u8;
        }
    };
    commands::set_verbose(cli.verbose);
    let result: Result<Verdict, CommandError> = match &cli.command {
        Command::Check(args) => commands::check::run(args),
        Command::Sample(args) => commands::sample::run(args),
        Command::Plot(args) => commands::plot::run(args),
        Command::Retime(args) => commands::retime::run(args),
        Command::Mirror(args) => commands::mirror::run(args),
        Command::Sim(args) => commands::sim::run(args),
        Command::Play(args) => commands::play::run(args),
        Command::Teach(args) => commands::teach::run(args),
        Command::Studio(args) => commands::studio::run(args),
        Command::Record(args) => commands::record::run(args),
        Command::Import(format) => commands::import::run(format),
        Command::Export(format) => commands::export::run(format),
        Command::Pose(args) => commands::pose::run(args),
        Command::Read(args) => commands::read::run(args),
        Command::Torque(args) => commands::torque::run(args),
        Command::Scan(args) => commands::scan::run(args),
        Command::Ports => commands::ports::run(),
        Command::Doctor => commands::doctor::run(),
        Command::VirtualBus(args) => commands::virtual_bus::run(args),
    };
    let code = match result {
        Ok(verdict) => verdict.exit_code(),
        Err(error) => {
            // Messages quote file text (names, values, paths): no escape sequence reaches the
            // terminal, and no line break but those before another program's quoted output.
            // Each layer says its own part; the report joins the chain of causes.
            let text = keypose::error::Report(&error).to_string();
            let message = keypose::terminal_text::escape_message(&text);
            // A stop the user asked for is not an error: it is said plainly (exit 130 still
            // tells a script that the command did not run to its end).
            if matches!(error, CommandError::Interrupted(_)) {
                eprintln!("{message}");
            } else {
                eprintln!("error: {message}");
            }
            error.exit_code()
        }
    };
    code as u8
}

//! `keypose teach`: the key-by-key teaching session, in a terminal or driven by a key script.

mod ui;

use super::BusArgs;
use super::{CommandError, SequenceOptions, Verdict};
use keypose::robot::Robot;
use keypose::sequence::{KeyframeList, Sequence};
use keypose::teach::{self, Journal, Pending, Session, TeachState};
use std::io::{BufRead, BufReader, IsTerminal};
use std::path::{Path, PathBuf};

/// Where `w` writes when neither SEQ nor --output says.
pub const DEFAULT_OUTPUT: &str = "taught.json";

#[derive(Debug, Clone, clap::Args)]
#[command(after_help = teach::help_text())]
pub struct TeachArgs {
    #[command(flatten)]
    pub session: SessionArgs,
    /// Read the keys from this script instead of the terminal ("-": standard input), printing
    /// the status after each step to standard error. Tokens are listed below.
    #[arg(long, value_name = "FILE|-")]
    pub keys: Option<PathBuf>,
}

/// What a teaching session starts from: the list, the robot, the bus, where `w` writes. Shared
/// by `keypose teach` and `keypose studio`.
#[derive(Debug, Clone, clap::Args)]
pub struct SessionArgs {
    /// Sequence file to edit; a new list when it does not exist yet (w creates it).
    pub sequence: Option<PathBuf>,
    /// A built-in robot (so101, so100, koch, omx), a LeRobot robot type (so101_follower,
    /// so100_follower, koch_follower and their leaders) or a robot file [default: the sequence's robot, else
    /// so101].
    #[arg(long, value_name = "NAME|FILE")]
    pub robot: Option<String>,
    #[command(flatten)]
    pub calibration: super::CalibrationArgs,
    #[command(flatten)]
    pub bus: BusArgs,
    /// Where w writes [default: SEQ, else taught.json].
    #[arg(long, short, value_name = "FILE")]
    pub output: Option<PathBuf>,
    /// Recover the journal of an interrupted session without asking.
    #[arg(long)]
    pub recover: bool,
    /// A goal held this many milliseconds longer than one control period (the process did not
    /// run: a stall) stops a playback or a move to a key, braking along its path, as
    /// `keypose play --max-stall` does [default: 250; a jog plays on through 2000].
    #[arg(long, value_name = "MS", value_parser = super::play::parse_max_stall, allow_negative_numbers = true)]
    pub max_stall: Option<f64>,
    /// The servos' build the check, the timeline and Simulate judge: 5v, 7.4v, 12v (as
    /// `keypose check --robot-variant`) [default: what the robot file says, 5v for the
    /// built-ins].
    #[arg(long, value_name = "NAME")]
    pub robot_variant: Option<String>,
}

/// A session ready to teach: the arm held where it is, the list loaded, the journal offered.
pub struct Opened {
    pub state: TeachState,
    pub session: Session,
    /// Kept until the session ends: dropping it stops the emulated servos.
    pub _virtual_bus: Option<keypose::testing::PtyServer>,
}

/// What a session without `--port` does.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WithoutPort {
    /// Refuses to start (`keypose teach`: the terminal shows no arm).
    Refuse,
    /// Teaches a drawn arm: nothing is sent anywhere (`keypose studio`).
    Drawn,
}

pub fn run(args: &TeachArgs) -> Result<Verdict, CommandError> {
    let script = |_: &Robot| script_or_terminal(args);
    let (mut opened, script) = open(&args.session, WithoutPort::Refuse, script)?;
    let (state, session) = (&mut opened.state, &mut opened.session);
    let result = match script {
        Some(input) => teach::script::run(state, session, input, &mut std::io::stderr()),
        None => ui::run(state, session),
    };
    result.map_err(CommandError::Teach)?;
    Ok(Verdict::Pass)
}

/// Loads the list and the robot, opens the journal, connects and holds the arm (without a
/// port, as `without_port` says: a refusal, or a drawn arm). `before_bus` runs once the robot
/// is known and before the bus opens (what a front end needs to refuse early, such as a
/// terminal); its result comes back beside the session.
pub fn open<T>(
    args: &SessionArgs,
    without_port: WithoutPort,
    before_bus: impl FnOnce(&Robot) -> Result<T, CommandError>,
) -> Result<(Opened, T), CommandError> {
    if !args.bus.given() && without_port == WithoutPort::Refuse {
        return Err(CommandError::Usage(
            "--port is required: a serial port (see `keypose ports`), or \"virtual\" for \
             emulated servos"
                .into(),
        ));
    }
    let (output, source) = target(args);
    let (list, robot) = load(args, source.as_deref())?;
    // A session plays at the robot's own control rate: refuse one the player cannot keep now,
    // before the bus is opened, rather than at the first playback.
    super::control_rate(None, &robot)?;
    let (journal, pending) = open_journal(&output);
    let early = before_bus(&robot)?;

    let (mut session, virtual_bus) = if args.bus.given() {
        let connection = args.bus.open(&robot)?;
        (
            Session::new(connection.bus, &robot).with_max_stall(args.max_stall),
            connection.virtual_bus,
        )
    } else {
        (Session::drawn(&robot), None)
    };
    let present = session
        .read()?
        .ok_or_else(|| CommandError::Hardware("the servos gave no present pose".into()))?;
    let record = direction_record(args, &robot, source.as_deref(), list.sequence());
    let mut state = TeachState::new(robot, list, output, journal, present);
    state.set_direction_record(record);
    match pending {
        Some(pending) if args.recover => state.recover(pending),
        Some(pending) => state.offer_recovery(pending),
        None if args.recover => eprintln!("teach: no journal to recover"),
        None => {}
    }
    hold_at_start(&mut state, &mut session)?;
    let opened = Opened {
        state,
        session,
        _virtual_bus: virtual_bus,
    };
    Ok((opened, early))
}

/// Where `w` writes, and the file the list comes from: SEQ, else the file `w` writes to if it
/// exists already, so that a session never overwrites a file it has not shown.
fn target(args: &SessionArgs) -> (PathBuf, Option<PathBuf>) {
    let output = args
        .output
        .clone()
        .or_else(|| args.sequence.clone())
        .unwrap_or_else(|| PathBuf::from(DEFAULT_OUTPUT));
    let source = args
        .sequence
        .clone()
        .or_else(|| Some(output.clone()))
        .filter(|p| p.exists());
    (output, source)
}

/// The journal of `output` and the unsaved work it holds, if any. Without a cache directory
/// the session still runs, unjournaled; the screen says so.
fn open_journal(output: &Path) -> (Option<Journal>, Option<Pending>) {
    let journal = keypose::python::PyConfig::from_env()
        .ok()
        .map(|config| Journal::for_target(&config.cache_dir, output));
    let pending = match &journal {
        Some(journal) => journal.pending(output).unwrap_or_else(|e| {
            let message = e.to_string();
            eprintln!(
                "warning: the journal cannot be read, it is ignored: {}",
                keypose::terminal_text::escape_message(&message)
            );
            None
        }),
        None => None,
    };
    (journal, pending)
}

/// The `--keys` script, or `None` for the terminal UI, which needs a terminal on both ends.
fn script_or_terminal(args: &TeachArgs) -> Result<Option<Box<dyn BufRead>>, CommandError> {
    if let Some(path) = &args.keys {
        return open_script(path).map(Some);
    }
    if !(std::io::stdin().is_terminal() && std::io::stdout().is_terminal()) {
        return Err(CommandError::Usage(
            "keypose teach needs a terminal; to run it without one, give the keys with \
             --keys FILE (see --help)"
                .into(),
        ));
    }
    Ok(None)
}

/// The start's hold on every joint; a session that cannot hold the arm does not begin.
fn hold_at_start(state: &mut TeachState, session: &mut Session) -> Result<(), CommandError> {
    let start = state.start();
    for event in teach::apply(state, session, start) {
        if let teach::Event::BusError(message) = event {
            return Err(CommandError::Hardware(format!(
                "cannot hold the arm at the start: {message}"
            )));
        }
    }
    Ok(())
}

/// Where the direction check records a reversed joint: the robot file the session read, else
/// nowhere (a built-in is compiled in; a cell's arms and a LeRobot calibration are not written:
/// LeRobot's degrees take no sign from its calibration file, docs/commands.md).
fn direction_record(
    args: &SessionArgs,
    robot: &Robot,
    source: Option<&Path>,
    sequence: &Sequence,
) -> teach::DirectionRecord {
    use teach::DirectionRecord::{File, SessionOnly};
    if !robot.arms.is_empty() {
        return SessionOnly("a cell's arms are recorded in their own robot files".into());
    }
    if !args.calibration.calibration.is_empty() || !args.calibration.robot_id.is_empty() {
        return SessionOnly("the joint directions come from LeRobot's calibration".into());
    }
    let file = match &args.robot {
        Some(spec) => PathBuf::from(spec),
        None => match source.and_then(Path::parent) {
            Some(dir) => dir.join(&sequence.robot),
            None => PathBuf::from(&sequence.robot),
        },
    };
    if file.is_file() {
        File(file)
    } else {
        SessionOnly("the robot is a built-in; give --robot FILE (a copy) to record it".into())
    }
}

/// The list to edit and the robot to teach.
fn load(args: &SessionArgs, source: Option<&Path>) -> Result<(KeyframeList, Robot), CommandError> {
    let options = SequenceOptions {
        robot: args.robot.clone(),
        calibration: args.calibration.clone(),
        robot_variant: args.robot_variant.clone(),
        ..SequenceOptions::default()
    };
    if let Some(path) = source {
        let (sequence, robot) = options.load(path)?;
        return Ok((KeyframeList::new(sequence), robot));
    }
    let mut robot = super::load_robot(
        args.robot.as_deref().unwrap_or(super::DEFAULT_ROBOT),
        &args.calibration,
    )?;
    options.apply_to(&mut robot)?;
    // The file names the robot by its name, which `keypose check` and `play` resolve as a
    // built-in.
    Ok((KeyframeList::new(Sequence::new(&robot.name)), robot))
}

fn open_script(path: &Path) -> Result<Box<dyn BufRead>, CommandError> {
    if path == Path::new("-") {
        return Ok(Box::new(std::io::stdin().lock()));
    }
    // A regular file: a script is read line by line, and a device such as /dev/zero has no end
    // of line (`-` reads standard input, for a pipe).
    let file = keypose::json::open_regular(path)?;
    Ok(Box::new(BufReader::new(file)))
}

//! `keypose mirror`: the mirror image of a sequence across each arm's own vertical plane, or of
//! one arm's motion onto another (`--arms left:right`).

use super::{CommandError, SequenceInput, Verdict};
use keypose::mirror::{Mapping, Mirror};
use keypose::terminal_text::escape_controls;
use std::path::PathBuf;

#[derive(Debug, Clone, clap::Args)]
pub struct MirrorArgs {
    #[command(flatten)]
    pub input: SequenceInput,
    /// Where to write the mirrored sequence (written whole or not at all).
    #[arg(short, long, value_name = "FILE")]
    pub output: PathBuf,
    /// On a sequence of several arms: mirror arm FROM's motion onto arm TO (TO's keys are
    /// replaced, FROM's stay) [default: every arm mirrored in place].
    #[arg(long, value_name = "FROM:TO", value_parser = parse_arms)]
    pub arms: Option<(String, String)>,
}

fn parse_arms(s: &str) -> Result<(String, String), String> {
    match s.split_once(':') {
        Some((from, to)) if !from.is_empty() && !to.is_empty() => Ok((from.into(), to.into())),
        _ => Err(format!(
            "expected two arm names as FROM:TO (e.g. left:right), found {s:?}"
        )),
    }
}

pub fn run(args: &MirrorArgs) -> Result<Verdict, CommandError> {
    let (sequence, robot) = args.input.load()?;
    let mapping = match &args.arms {
        Some((from, to)) => Mapping::Onto { from, to },
        None => Mapping::InPlace,
    };
    let mirror = Mirror::new(&robot, mapping, &sequence.file)?;
    let (mut mirrored, clips) = mirror.sequence(&sequence, &robot)?;
    mirrored.file = format!("{} (mirrored)", sequence.file);
    // What the player would refuse (a reflected tool target out of reach, say) is not written.
    keypose::plan::Trajectory::build(&mirrored, &robot)?;
    for clip in &clips {
        eprintln!("{}", escape_controls(&clip.to_string()));
    }
    mirrored.save(&args.output)?;
    let what = match mapping {
        Mapping::InPlace => "mirrored".to_string(),
        Mapping::Onto { from, to } => format!("mirrored {from} onto {to}"),
    };
    let line = format!(
        "{what}: {} keys to {}{}",
        mirrored.keyframes.len(),
        args.output.display(),
        if clips.is_empty() {
            String::new()
        } else {
            format!(
                "; {} value(s) clipped to their limits: not an exact mirror image",
                clips.len()
            )
        }
    );
    eprintln!("{}", escape_controls(&line));
    Ok(if clips.is_empty() {
        Verdict::Pass
    } else {
        Verdict::Fail
    })
}

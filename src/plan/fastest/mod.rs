//! `retime --fastest`: each segment as fast as the joints' velocity and acceleration limits
//! allow along its curve, written as timing profiles (`sequence::SegmentTiming`).
//!
//! The curve stays the one the keys and interpolation define over path time; only how fast it
//! is run through changes. This is time-optimal path parameterisation as TOPP-RA does it: the
//! path is cut into a grid; at each grid point the joints' first and second derivatives along
//! the path turn the limits into bounds on the squared path speed x and the path acceleration
//! (`|q'|·√x ≤ v`, `|q'·ẍ/2 + q''·x| ≤ a`); a backward pass finds, from the end, the largest x
//! each point may have and still be brought to what the next allows, and a forward pass
//! accelerates as hard as allowed without leaving those sets. The grid's speeds are the
//! profile's, and between grid points the path accelerates evenly, exactly as the profile
//! plays it.
//!
//! The limits hold at the grid points; between them the curve's derivatives change, so the
//! profile is planned for a share of each limit (`FIRST_SHARE`) and the result checked exactly
//! (`check`): a segment still over a limit gets a smaller share and the plan is made again.
//! Keys stay where they are on the path, in order; holds stay as long and at rest; a step
//! segment and a segment along which nothing moves (a pause between equal keys) keep their
//! time; the played window starts and ends at rest. Between keys without a hold the path does
//! not stop: the profile runs through them at the speed both sides allow, and through a linear
//! corner at the speed whose velocity change the player turns within one control period.
//!
//! A robot with jerk limits gets S-curve profiles instead (`plan::scurve`): each segment from
//! rest to rest, its path acceleration changing at a bounded path jerk. It stops at every key
//! because the curves through the keys do not let it go on: a key-time cubic's second
//! derivative jumps at its keys and a linear corner's first, so passing one in motion jumps the
//! joints' acceleration (an infinite jerk). Bounds on each segment's first three derivatives
//! along the path give S-curves that keep the limits wherever they are (`scurve::candidates`);
//! each is then stretched or shrunk in time to the peaks measured along it
//! (`scurve::time_scale`), the shortest kept, and the exact check confirms it, with the same
//! rounds as above. A hold through which a joint without a key there keeps moving gets an
//! S-curve of its own (the timing's `"hold"`): the keyed joints rest in the hold with their
//! curvature along the path beside it not zero, so their acceleration `q''·u̇²` is continuous
//! only where the path speed `u̇` is zero, and the path must stop at the hold's ends as at any
//! key. The hold's path time, from rest to rest, then needs at least the time the fastest
//! S-curve along it takes; the hold keeps its seconds where they are enough, and is lengthened
//! to that time where they are not (a joint moving through a short hold cannot stop and start
//! again within it under its jerk limit: `32·q'/T²` is the least jerk a rest-to-rest move of
//! T seconds asks of a joint at slope q'), reported in [`FastestOutcome::holds`].

mod torque;

use super::load::{check_loads, LoadScope};
use super::scurve::{along_track, candidates, time_scale, AlongPath, SCurve};
use super::{add_clearance, check_limits, CheckReport, Trajectory};
use crate::curve::{Interp, Track};
use crate::json::InputError;
use crate::robot::{Limits, Robot};
use crate::sequence::{Ends, HoldTiming, SegmentTiming, Sequence, TimeProfile};
use torque::{Loads, TorqueRow};

/// The share of each limit a profile is planned for at first; the exact check says whether the
/// curve between grid points needs less.
const FIRST_SHARE: f64 = 0.995;
/// The share of each limit an S-curve is planned for at first: its bounds hold everywhere on
/// the segment, so this only covers the key times' rounding to the microsecond.
const SCURVE_SHARE: f64 = 0.999;
/// A segment over a limit is planned again for this much less than the limit over its peak.
const SHARE_BACKOFF: f64 = 0.98;
const MAX_ROUNDS: usize = 40;
/// Grid intervals per second of path time, and the fewest and most in one segment.
const INTERVALS_PER_SECOND: f64 = 200.0;
const MIN_INTERVALS: usize = 32;
const MAX_INTERVALS: usize = 1600;
/// Grid intervals between two knots of a joint's track inside a segment (a tool line's
/// samples).
const KNOT_INTERVALS: usize = 6;
/// Largest squared path speed: a thousand times the speed the keys gave, where almost nothing
/// moves.
const MAX_SQUARED_SPEED: f64 = 1e6;
/// A path slope below this (degrees or metres per path second) is at rest.
const AT_REST: f64 = 1e-9;
/// Share of a linear corner's allowance (its velocity change turned within one control period
/// at the acceleration limit) the profile plans for: the curve's own acceleration on either
/// side is turned in the same period.
const CORNER_SHARE: f64 = 0.5;

/// What [`fastest`] made of a sequence.
#[derive(Debug, Clone)]
pub struct FastestOutcome {
    /// The sequence with timing profiles and the key times they give.
    pub sequence: Sequence,
    /// Plan-and-check rounds it took.
    pub rounds: usize,
    /// (segment, moving seconds before, after) of every segment given a profile.
    pub segments: Vec<(usize, f64, f64)>,
    /// (key, hold seconds before, after) of every hold made longer: under jerk limits, a hold
    /// through which a joint moves that cannot stop and start again within its seconds.
    pub holds: Vec<(usize, f64, f64)>,
    /// The paths the arm runs from rest to rest (or from and to a segment that keeps its
    /// time): runs of profiled segments without a hold between them.
    pub runs: Vec<FastestRun>,
    /// The check of the result; violations left here cannot be fixed by timing (positions,
    /// steps).
    pub report: CheckReport,
}

/// Profiled segments the path runs through without stopping.
#[derive(Debug, Clone, PartialEq)]
pub struct FastestRun {
    /// Its segments, `first .. end` (segment i runs from key i to key i + 1).
    pub segments: std::ops::Range<usize>,
    /// Path time it starts and ends ([`Trajectory::path_time`]).
    pub path: (f64, f64),
    /// Whether it starts and ends at rest (else at the pace of a hold or a segment beside it
    /// in which a joint moves).
    pub from_rest: [bool; 2],
    /// Seconds it takes after retiming.
    pub seconds: f64,
}

impl FastestOutcome {
    /// Moving seconds of the profiled segments, before and after.
    pub fn moving_time(&self) -> (f64, f64) {
        self.segments
            .iter()
            .fold((0.0, 0.0), |(a, b), (_, before, after)| {
                (a + before, b + after)
            })
    }
}

/// `sequence` timed as fast as `robot`'s velocity and acceleration limits allow along its path,
/// corners judged at a control rate of `rate` Hz.
pub fn fastest(
    sequence: &Sequence,
    robot: &Robot,
    rate: f64,
) -> Result<FastestOutcome, InputError> {
    let mut base = sequence.clone();
    base.make_times_absolute();
    let trajectory = Trajectory::build(&base, robot)?;
    let jerk_limited = robot.joints.iter().any(|j| j.limits.jerk.is_some());
    let path = Path::of(&base, &trajectory, robot, jerk_limited);
    let first_share = if jerk_limited {
        SCURVE_SHARE
    } else {
        FIRST_SHARE
    };
    let mut shares = vec![first_share; path.segments.len()];
    let mut rounds = 0;
    loop {
        rounds += 1;
        let candidate = if jerk_limited {
            path.s_curves(&base, robot, &shares)
        } else {
            let speeds = path.plan(robot, &shares, 1.0 / rate);
            path.timed(&base, &speeds)
        };
        let timed = Trajectory::build(&candidate, robot)?;
        let mut report = check_limits(&timed, robot, rate);
        let loads = check_loads(&timed, robot, 1.0);
        let mut over = over_limits(&report, jerk_limited);
        over_lines(&loads, &mut over);
        let done = over
            .iter()
            .all(|&(i, _)| path.segments.get(i).is_none_or(|s| s.is_none()));
        if done || rounds == MAX_ROUNDS {
            let times = candidate.key_times();
            let before = base.key_times();
            let segments = (0..path.segments.len())
                .filter(|&i| path.segments[i].is_some())
                .map(|i| {
                    (
                        i,
                        before[i + 1] - before[i] - base.keyframes[i].hold,
                        times[i + 1] - times[i] - candidate.keyframes[i].hold,
                    )
                })
                .collect();
            let holds = (base.keyframes.iter().zip(&candidate.keyframes))
                .enumerate()
                .filter(|(_, (a, b))| b.hold > a.hold)
                .map(|(i, (a, b))| (i, a.hold, b.hold))
                .collect();
            let runs = path
                .runs()
                .into_iter()
                .map(|(first, end)| {
                    let grids = (path.segments[first], path.segments[end - 1]);
                    let (Some(a), Some(b)) = grids else {
                        unreachable!("a run is of profiled segments")
                    };
                    FastestRun {
                        segments: first..end,
                        path: (a.from, b.to),
                        from_rest: [
                            jerk_limited || path.boundary(first, Side::After) == 0.0,
                            jerk_limited || path.boundary(end, Side::Before) == 0.0,
                        ],
                        seconds: times[end] - times[first] - candidate.keyframes[first].hold,
                    }
                })
                .collect();
            // Timing moves the arm along the same path: its clearance is checked once, on
            // the result.
            add_clearance(&mut report, &timed, robot);
            report.loads = Some(loads);
            return Ok(FastestOutcome {
                sequence: candidate,
                rounds,
                segments,
                holds,
                runs,
                report,
            });
        }
        for (segment, ratio) in over {
            if let Some(share) = shares.get_mut(segment) {
                *share *= SHARE_BACKOFF / ratio;
            }
        }
    }
}

/// Each segment's worst ratio of peak to limit, for violations timing can mend (one in a hold
/// is its key's segment's, whose share the hold's S-curve is planned for too). With S-curves
/// (`stops_at_keys`) the path is at rest at every key, so a corner left is where a joint keeps
/// moving through a hold that no S-curve times (next to a segment that keeps its time), whose
/// pace no segment's profile sets.
fn over_limits(report: &CheckReport, stops_at_keys: bool) -> Vec<(usize, f64)> {
    let mut out: Vec<(usize, f64)> = Vec::new();
    for v in &report.violations {
        if !v.mendable_by_timing() || (stops_at_keys && v.cause == super::Cause::Corner) {
            continue;
        }
        let ratio = (v.peak.abs() / v.limit.abs()).max(1.0 + 1e-6);
        match out.iter_mut().find(|(s, _)| *s == v.segment) {
            Some(entry) => entry.1 = entry.1.max(ratio),
            None => out.push((v.segment, ratio)),
        }
    }
    out
}

/// Adds each segment's worst overload, as one plus its excess over the servo's stall torque:
/// the share of the limits (and of the stall torque) it is planned for again falls by about
/// that much. Not the torque over what the line gives, which near the no-load speed is next to
/// nothing: that share would leave the servo too weak to hold the arm at all.
fn over_lines(loads: &LoadScope, over: &mut Vec<(usize, f64)>) {
    let LoadScope::Checked(report) = loads else {
        return;
    };
    for o in &report.overloads {
        let stall = report
            .joints
            .iter()
            .find(|j| j.joint == o.joint)
            .and_then(|j| j.line)
            .map_or(o.available, |(stall, _)| stall);
        let excess = o.torque.abs() - o.available;
        let ratio = (1.0 + excess / stall.max(1e-9)).max(1.0 + 1e-6);
        match over.iter_mut().find(|(s, _)| *s == o.segment) {
            Some(entry) => entry.1 = entry.1.max(ratio),
            None => over.push((o.segment, ratio)),
        }
    }
}

/// The grid of one segment that gets a profile: its moving part in path time.
#[derive(Debug, Clone, Copy)]
struct Grid {
    /// Path time the moving part starts and ends.
    from: f64,
    to: f64,
    intervals: usize,
}

impl Grid {
    fn point(&self, k: usize) -> f64 {
        if k == self.intervals {
            return self.to;
        }
        self.from + (self.to - self.from) * k as f64 / self.intervals as f64
    }
}

/// Whether any joint moves somewhere on `grid`'s stretch of path (at its points, from either
/// side).
fn moves_along(trajectory: &Trajectory, grid: Grid) -> bool {
    (0..=grid.intervals).any(|k| {
        let u = grid.point(k);
        trajectory
            .tracks()
            .iter()
            .any(|t| t.rate_at(u).abs() > AT_REST || t.rate_before(u).abs() > AT_REST)
    })
}

/// Which segments get a profile, and the tracks their curves are on.
struct Path<'a> {
    trajectory: &'a Trajectory,
    /// Per segment, its grid; `None` for one that keeps its time.
    segments: Vec<Option<Grid>>,
    /// Keys where the played window starts and ends.
    window: (usize, usize),
    /// Each key's path time and the path time of its hold.
    paths: Vec<f64>,
    holds: Vec<f64>,
    /// Whether the path stops at every key (S-curve profiles for jerk limits).
    stops_at_keys: bool,
    /// Per key, its hold's stretch of path when the hold gets an S-curve of its own (a joint
    /// without a key there moves through it, between S-curves that stop at its ends).
    holds_timed: Vec<Option<Grid>>,
    /// Per key, whether its hold runs on an S-curve already (a file timed for jerk limits),
    /// which starts and ends at rest.
    hold_curves: Vec<bool>,
    /// The servos' inverse dynamics and lines, where the robot has masses: `--fastest` keeps
    /// every servo under its torque-speed line too.
    loads: Option<Loads>,
}

impl<'a> Path<'a> {
    fn of(
        sequence: &Sequence,
        trajectory: &'a Trajectory,
        robot: &Robot,
        stops_at_keys: bool,
    ) -> Path<'a> {
        let paths = sequence.path_times();
        let n = paths.len();
        let window = match sequence.ends {
            Ends::Played => (0, n - 1),
            Ends::Control => (1, n - 2),
        };
        let holds: Vec<f64> = sequence
            .keyframes
            .iter()
            .map(|k| k.hold_path_time())
            .collect();
        let segments = (0..n - 1)
            .map(|i| {
                let key = &sequence.keyframes[i];
                let mode = key.interp.unwrap_or(sequence.interpolation);
                let played = i >= window.0 && i < window.1;
                let (from, to) = (paths[i] + holds[i], paths[i + 1]);
                // A straight tool line's joints are splines through many samples: each
                // sample's stretch gets grid points of its own.
                let knots = trajectory
                    .tracks()
                    .iter()
                    .map(|t| t.times().iter().filter(|&&k| k > from && k < to).count())
                    .max()
                    .unwrap_or(0);
                let intervals = ((to - from) * INTERVALS_PER_SECOND)
                    .ceil()
                    .max((KNOT_INTERVALS * (knots + 1)) as f64)
                    .clamp(MIN_INTERVALS as f64, MAX_INTERVALS as f64);
                let grid = Grid {
                    from,
                    to,
                    intervals: intervals as usize,
                };
                let moves = moves_along(trajectory, grid);
                (played && (mode != Interp::Step || key.line) && moves).then_some(grid)
            })
            .collect::<Vec<Option<Grid>>>();
        let holds_timed = (0..n)
            .map(|i| {
                let hold = holds[i];
                let grid = Grid {
                    from: paths[i],
                    to: paths[i] + hold,
                    intervals: MIN_INTERVALS,
                };
                // Both sides stop at the hold's ends: the first played key's hold starts from
                // rest, and S-curves end and start at rest.
                let ends_at_rest = segments.get(i).is_some_and(Option::is_some)
                    && (i == window.0 || i.checked_sub(1).is_some_and(|p| segments[p].is_some()));
                (stops_at_keys && hold > 0.0 && ends_at_rest && moves_along(trajectory, grid))
                    .then_some(grid)
            })
            .collect();
        Path {
            trajectory,
            segments,
            window,
            holds,
            paths,
            stops_at_keys,
            holds_timed,
            hold_curves: sequence
                .keyframes
                .iter()
                .map(|k| k.hold > 0.0 && k.timing.as_ref().is_some_and(|t| t.hold.is_some()))
                .collect(),
            loads: Loads::of(robot),
        }
    }

    /// Every profiled segment's path speeds at its grid points, planned for `shares` of the
    /// limits; `None` for the others.
    fn plan(&self, robot: &Robot, shares: &[f64], period: f64) -> Vec<Option<Vec<f64>>> {
        let mut out = vec![None; self.segments.len()];
        for (first, end) in self.runs() {
            let speeds = self.plan_run(robot, shares, period, first, end);
            for (k, s) in speeds.into_iter().enumerate() {
                out[first + k] = Some(s);
            }
        }
        out
    }

    /// The runs of profiled segments the path goes through without stopping (no hold between
    /// them), as `(first, end)`.
    fn runs(&self) -> Vec<(usize, usize)> {
        let mut out = Vec::new();
        let mut i = 0;
        while i < self.segments.len() {
            if self.segments[i].is_none() {
                i += 1;
                continue;
            }
            let mut end = i + 1;
            while end < self.segments.len()
                && !self.stops_at_keys
                && self.segments[end].is_some()
                && self.holds[end] == 0.0
            {
                end += 1;
            }
            out.push((i, end));
            i = end;
        }
        out
    }

    /// Segments `first .. end`, one path from rest (or the speed its neighbour keeps) to rest.
    fn plan_run(
        &self,
        robot: &Robot,
        shares: &[f64],
        period: f64,
        first: usize,
        end: usize,
    ) -> Vec<Vec<f64>> {
        let tracks = self.trajectory.tracks();
        let mut points: Vec<Point> = Vec::new();
        let mut steps: Vec<f64> = Vec::new();
        let run = self.segments[first..end].iter().zip(&shares[first..end]);
        for (offset, (grid, &share)) in run.enumerate() {
            let grid = grid.expect("a profiled segment");
            let step = (grid.to - grid.from) / grid.intervals as f64;
            for k in 0..=grid.intervals {
                let u = grid.point(k);
                let mut rows = Vec::new();
                let mut torques = Vec::new();
                if k > 0 {
                    rows.extend(rows_at(tracks, robot, share, u, Side::Before));
                    torques.extend(self.torque_rows(share, u, Side::Before));
                }
                if k < grid.intervals {
                    rows.extend(rows_at(tracks, robot, share, u, Side::After));
                    torques.extend(self.torque_rows(share, u, Side::After));
                }
                if k == 0 && offset > 0 {
                    // The key between two segments of the run: both sides' rows, and its
                    // corner if the curve turns one there.
                    let previous = points.pop().expect("the previous segment's last point");
                    rows.extend(previous.rows);
                    torques.extend(previous.torques);
                    let corner = corner_bound(tracks, robot, share, u, period);
                    points.push(Point::new(rows, torques, corner));
                } else {
                    points.push(Point::new(rows, torques, f64::INFINITY));
                }
                if k < grid.intervals {
                    steps.push(step);
                }
            }
        }
        let start_speed = self.boundary(first, Side::After);
        let end_speed = self.boundary(end, Side::Before);
        let squared = plan_squared_speeds(&points, &steps, start_speed, end_speed);
        // Back to per-segment lists: each segment's first point is the previous one's last.
        let mut out = Vec::new();
        let mut at = 0;
        for i in first..end {
            let intervals = self.segments[i].expect("a profiled segment").intervals;
            out.push(
                squared[at..=at + intervals]
                    .iter()
                    .map(|x| x.sqrt())
                    .collect(),
            );
            at += intervals;
        }
        out
    }

    /// The servos' torque rows at path time `u` from `side`, for `share` of their stall
    /// torque; none where the robot has no masses.
    fn torque_rows(&self, share: f64, u: f64, side: Side) -> Vec<TorqueRow> {
        let Some(loads) = &self.loads else {
            return Vec::new();
        };
        let tracks = self.trajectory.tracks();
        let q: Vec<f64> = tracks.iter().map(|t| t.sample(u)).collect();
        let (p, c): (Vec<f64>, Vec<f64>) = tracks
            .iter()
            .map(|t| match side {
                Side::After => (t.rate_at(u), t.second_rate_at(u)),
                Side::Before => (t.rate_before(u), t.second_rate_before(u)),
            })
            .unzip();
        loads.rows(&q, &p, &c, share)
    }

    /// The squared path speed at key `key` from the side of the run: 0 at the window's ends,
    /// at a hold on an S-curve and where every joint is at rest, else 1 (the pace of the hold
    /// or the segment beside it, which keeps its time).
    fn boundary(&self, key: usize, side: Side) -> f64 {
        if key == self.window.0 || key == self.window.1 || self.hold_curves[key] {
            return 0.0;
        }
        let u = match side {
            // The run starts after the key's hold.
            Side::After => self.paths[key] + self.holds[key],
            Side::Before => self.paths[key],
        };
        let tracks = self.trajectory.tracks();
        let moving = tracks.iter().any(|t| {
            let rate = match side {
                Side::After => t.rate_at(u),
                Side::Before => t.rate_before(u),
            };
            rate.abs() > AT_REST
        });
        if moving {
            1.0
        } else {
            0.0
        }
    }

    /// `base` with the profiles of `speeds` and the key times they give (to the microsecond).
    fn timed(&self, base: &Sequence, speeds: &[Option<Vec<f64>>]) -> Sequence {
        self.with_profiles(base, f64::round, |i, grid| {
            let timing = SegmentTiming {
                path_time: grid.to - grid.from,
                profile: TimeProfile::Speeds(
                    speeds[i].as_ref()?.iter().map(|&v| written(v)).collect(),
                ),
                hold: base.keyframes[i].timing.as_ref().and_then(|t| t.hold),
            };
            Some((timing, base.keyframes[i].hold))
        })
    }

    /// `base` with the timing `profile` gives segment `i` on its stretch of path, and the
    /// seconds of the key's hold (`None`: the segment keeps its key times and the key its
    /// hold), and the key times that follow, each rounded to the microsecond by `round`.
    fn with_profiles(
        &self,
        base: &Sequence,
        round: fn(f64) -> f64,
        mut profile: impl FnMut(usize, Grid) -> Option<(SegmentTiming, f64)>,
    ) -> Sequence {
        let mut out = base.clone();
        let times = base.key_times();
        let mut time = times[0];
        for i in 0..out.keyframes.len() {
            out.keyframes[i].time = Some(time);
            let Some(next) = times.get(i + 1) else {
                break;
            };
            let key = &mut out.keyframes[i];
            let moving = match self.segments[i].and_then(|grid| profile(i, grid)) {
                Some((timing, hold)) => {
                    let seconds = timing.seconds();
                    key.timing = Some(timing);
                    key.hold = hold;
                    seconds
                }
                None => next - times[i] - key.hold,
            };
            time = round((time + key.hold + moving) * 1e6) / 1e6;
        }
        out
    }
}

impl Path<'_> {
    /// The fastest S-curve along `grid`'s stretch of path within `share` of the limits: of the
    /// shapes whose bounds keep the limits everywhere (`scurve::candidates`), each stretched or
    /// shrunk in time until its measured peaks meet the limits (`scurve::time_scale`), the
    /// shortest. The bounds take every derivative at its worst at once; the measured peaks do
    /// not, so the result is faster than the bounds alone give, and still checked exactly.
    fn s_curve(&self, robot: &Robot, grid: Grid, share: f64) -> Option<SCurve> {
        let length = grid.to - grid.from;
        let tracks = self.trajectory.tracks();
        let joints: Vec<AlongPath> = tracks
            .iter()
            .zip(&robot.joints)
            .map(|(track, joint)| along_track(track, grid.from, grid.to, &joint.limits, share))
            .collect();
        let limits: Vec<&Limits> = robot.joints.iter().map(|j| &j.limits).collect();
        candidates(length, &joints)
            .into_iter()
            .map(|curve| {
                let factor = time_scale(&curve, tracks, &limits, grid.from, share);
                SCurve::shaped(curve.shape(), curve.duration() * factor, length)
            })
            .filter(|curve| curve.duration().is_finite() && curve.duration() > 0.0)
            .min_by(|a, b| a.duration().total_cmp(&b.duration()))
    }

    /// How key `key`'s hold runs, if it gets an S-curve, and its seconds: the fastest S-curve
    /// along the hold's path time within `share` of the limits ([`Path::s_curve`]), stretched
    /// to the hold's `seconds` where it is shorter (stretching lowers every peak); where it is
    /// longer, the hold lasts as long as it takes (to the microsecond, rounded up).
    fn hold_timing(
        &self,
        robot: &Robot,
        key: usize,
        seconds: f64,
        share: f64,
    ) -> Option<(HoldTiming, f64)> {
        let grid = self.holds_timed[key]?;
        let curve = self.s_curve(robot, grid, share)?;
        let needed = (curve.duration() * 1e6).ceil() / 1e6;
        let timing = HoldTiming {
            path_time: self.holds[key],
            scurve: curve.shape(),
        };
        Some((timing, needed.max(seconds)))
    }

    /// `base` with an S-curve profile on every profiled segment, each planned for its share
    /// of the limits, and the key times they give (rounded up to the microsecond, so a
    /// profile never runs faster than planned).
    fn s_curves(&self, base: &Sequence, robot: &Robot, shares: &[f64]) -> Sequence {
        self.with_profiles(base, f64::ceil, |i, grid| {
            let seconds = base.keyframes[i].hold;
            let hold = self.hold_timing(robot, i, seconds, shares[i]);
            let timing = SegmentTiming {
                path_time: grid.to - grid.from,
                profile: TimeProfile::SCurve(self.s_curve(robot, grid, shares[i])?.shape()),
                hold: hold.map(|(timing, _)| timing),
            };
            Some((timing, hold.map_or(seconds, |(_, seconds)| seconds)))
        })
    }
}

/// A speed as the file keeps it: six significant digits.
fn written(v: f64) -> f64 {
    format!("{v:.5e}").parse().unwrap_or(v)
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Side {
    Before,
    After,
}

/// One joint at one grid point: its slope `p` and curvature `c` along the path (per path
/// second), and its limits times the segment's share.
#[derive(Debug, Clone, Copy)]
struct Row {
    p: f64,
    c: f64,
    velocity: f64,
    acceleration: f64,
}

fn rows_at(tracks: &[Track<f64>], robot: &Robot, share: f64, u: f64, side: Side) -> Vec<Row> {
    tracks
        .iter()
        .zip(&robot.joints)
        .map(|(track, joint)| {
            let (p, c) = match side {
                Side::After => (track.rate_at(u), track.second_rate_at(u)),
                Side::Before => (track.rate_before(u), track.second_rate_before(u)),
            };
            Row {
                p,
                c,
                velocity: joint.limits.velocity * share,
                acceleration: joint.limits.acceleration * share,
            }
        })
        .collect()
}

/// The largest squared path speed at which the corner at path time `u` (the slope jumping) is
/// turned within one control period inside the acceleration limit; ∞ without a corner.
fn corner_bound(tracks: &[Track<f64>], robot: &Robot, share: f64, u: f64, period: f64) -> f64 {
    tracks
        .iter()
        .zip(&robot.joints)
        .map(|(track, joint)| {
            let jump = (track.rate_at(u) - track.rate_before(u)).abs();
            if jump <= AT_REST {
                return f64::INFINITY;
            }
            let allowed = CORNER_SHARE * share * joint.limits.acceleration * period / jump;
            allowed * allowed
        })
        .fold(f64::INFINITY, f64::min)
}

/// One grid point: the rows of its joints (and of its servos' torque-speed lines) and the
/// largest squared speed it allows.
#[derive(Debug, Clone)]
struct Point {
    rows: Vec<Row>,
    torques: Vec<TorqueRow>,
    max_x: f64,
}

impl Point {
    fn new(rows: Vec<Row>, torques: Vec<TorqueRow>, corner: f64) -> Point {
        let mut max_x = MAX_SQUARED_SPEED.min(corner);
        for row in &rows {
            if row.p.abs() > AT_REST {
                max_x = max_x.min((row.velocity / row.p).powi(2));
            } else if row.c.abs() > 0.0 {
                max_x = max_x.min(row.acceleration / row.c.abs());
            }
        }
        let mut point = Point {
            rows,
            torques,
            max_x,
        };
        point.max_x = point.largest_feasible(max_x);
        point
    }

    /// The path accelerations (d²u/dt²) the limits allow at squared speed `x`.
    fn accelerations(&self, x: f64) -> (f64, f64) {
        let (mut low, mut high) = (f64::NEG_INFINITY, f64::INFINITY);
        for row in &self.rows {
            if row.p.abs() <= AT_REST {
                continue;
            }
            // |p·ü + c·x| ≤ a.
            let a = (-row.acceleration - row.c * x) / row.p;
            let b = (row.acceleration - row.c * x) / row.p;
            low = low.max(a.min(b));
            high = high.min(a.max(b));
        }
        self.torques
            .iter()
            .fold((low, high), |bounds, row| row.narrow(x, bounds))
    }

    /// The largest squared speed up to `limit` at which some path acceleration keeps every
    /// joint inside its limit (the set of such speeds is an interval from 0).
    fn largest_feasible(&self, limit: f64) -> f64 {
        let feasible = |x: f64| {
            let (low, high) = self.accelerations(x);
            low <= high
        };
        if feasible(limit) {
            return limit;
        }
        let (mut a, mut b) = (0.0, limit);
        for _ in 0..100 {
            let m = 0.5 * (a + b);
            if feasible(m) {
                a = m;
            } else {
                b = m;
            }
        }
        a
    }
}

/// The constraints on one step from a grid point to the next, the path acceleration ü constant
/// on it: every joint's at the first point at squared speed x, and at the second at
/// x + 2·step·ü (TOPP-RA's "interpolation" discretisation: a step from rest cannot leap to a
/// speed the second point forbids).
fn stage(first: &Point, second: &Point, step: f64) -> Point {
    let mut rows = first.rows.clone();
    rows.extend(second.rows.iter().map(|r| Row {
        p: r.p + 2.0 * step * r.c,
        ..*r
    }));
    // The second point's lines are read at the first point's speed: the exact check judges
    // what the step's speed change leaves.
    let mut torques = first.torques.clone();
    torques.extend(second.torques.iter().map(|t| t.ahead(step)));
    // The second point's rows bound the first point's x through ü only; its own velocity
    // limits act on its own x (its `max_x`), so only acceleration matters here.
    let mut point = Point {
        rows,
        torques,
        max_x: first.max_x,
    };
    point.max_x = point.largest_feasible(first.max_x);
    point
}

/// Squared path speeds at `points` (`steps` apart in path time), from `start` to `end`, as
/// fast as the points allow: TOPP-RA's backward pass of controllable sets and its greedy
/// forward pass, the path acceleration constant on each step.
fn plan_squared_speeds(points: &[Point], steps: &[f64], start: f64, end: f64) -> Vec<f64> {
    let m = points.len() - 1;
    let stages: Vec<Point> = (0..m)
        .map(|k| stage(&points[k], &points[k + 1], steps[k]))
        .collect();
    // Backward: the largest squared speed at each point from which the next point's set is
    // reached with an allowed acceleration.
    let mut reach = vec![0.0; m + 1];
    reach[m] = end.min(points[m].max_x);
    for k in (0..m).rev() {
        let stage = &stages[k];
        let (step, next) = (steps[k], reach[k + 1]);
        // x + 2·step·low(x) is convex in x: the set where it is at most `next` is an interval.
        let fits = |x: f64| {
            let (low, high) = stage.accelerations(x);
            low <= high && x + 2.0 * step * low <= next
        };
        reach[k] = if fits(stage.max_x) {
            stage.max_x
        } else {
            let (mut a, mut b) = (0.0, stage.max_x);
            for _ in 0..100 {
                let mid = 0.5 * (a + b);
                if fits(mid) {
                    a = mid;
                } else {
                    b = mid;
                }
            }
            a
        };
    }
    // Forward: as hard as allowed, never leaving the controllable sets.
    let mut x = vec![0.0; m + 1];
    x[0] = start.min(reach[0]);
    for k in 0..m {
        let high = stages[k].accelerations(x[k]).1;
        let next = x[k] + 2.0 * steps[k] * high;
        x[k + 1] = next.min(reach[k + 1]).max(0.0);
    }
    x
}

//! Key tracks and their interpolation.
//!
//! A [`Track`] holds the keys of one degree of freedom over time. The logic that is the same for
//! every kind of value — locating the segment, holds, which slope each key gets, monotone slope
//! limiting, cursors — lives here once; what differs between a scalar, a translation and a
//! rotation is behind [`Interpolant`].
//!
//! Slopes ("rates") are expressed per second. For a rotation the rate is the angular velocity
//! vector in the parent frame, so a rotation about a fixed axis has a rate along that axis whose
//! length is the scalar angle's rate: that is what makes the spherical modes reduce exactly to the
//! scalar ones.

use crate::pose::{self, RigidTransform};
use glam::{DQuat, DVec3};
use std::fmt;

/// How a segment moves from its first key to the next.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Interp {
    /// Keeps the value of the first key until the next key.
    Step,
    /// Lerp for translations and scalars, slerp for rotations.
    Linear,
    /// Acceleration continuous through every key, and zero where the motion starts or stops:
    /// between keys at rest, the clamped cubic spline through the keys, whose first and last
    /// pieces are quintics that leave and reach rest with zero acceleration. Its jerk is finite
    /// everywhere (for a rotation, its rotation vector from the first key is the quintic).
    Smooth,
    /// Key-time Catmull-Rom Hermite; zero slope at the first and last key.
    Cubic,
    /// Hermite with Fritsch–Carlson limited slopes: never overshoots between two keys.
    Monotone,
}

impl Interp {
    /// Every mode, in the order the help text lists them and the teach pendant's and the
    /// studio's mode key cycles through them (smooth after cubic, so from monotone three
    /// presses still reach cubic, as before smooth was there).
    pub const ALL: [Interp; 5] = [
        Interp::Step,
        Interp::Linear,
        Interp::Cubic,
        Interp::Smooth,
        Interp::Monotone,
    ];

    /// The mode's name in sequence files and on the command line (`"cubic"`).
    pub fn name(self) -> &'static str {
        match self {
            Interp::Step => "step",
            Interp::Linear => "linear",
            Interp::Smooth => "smooth",
            Interp::Cubic => "cubic",
            Interp::Monotone => "monotone",
        }
    }

    /// Every mode's name, as a list to put in an error: "step, linear, …".
    pub fn names() -> String {
        Interp::ALL.map(Interp::name).join(", ")
    }

    /// The mode named `s` ([`Interp::name`]); `None` for any other text.
    pub fn parse(s: &str) -> Option<Interp> {
        Interp::ALL.into_iter().find(|m| m.name() == s)
    }

    /// Whether the mode's velocity is shaped by the keys around a segment (not a step's or a
    /// straight line's).
    fn is_curved(self) -> bool {
        matches!(self, Interp::Smooth | Interp::Cubic | Interp::Monotone)
    }
}

impl fmt::Display for Interp {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// One key of a track. `interp` is the mode of the segment that starts at this key.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrackKey<V> {
    /// When the key is reached, seconds from the start of the track.
    pub time: f64,
    /// The value at the key.
    pub value: V,
    /// Seconds the value stays at this key before the segment to the next key begins.
    pub hold: f64,
    /// How the segment from this key to the next one moves.
    pub interp: Interp,
    /// The motion is at rest at this key whatever its neighbours (the ends of a straight tool
    /// line, timed to start and stop there): its rate is zero, as at a hold.
    pub rest: bool,
}

impl<V> TrackKey<V> {
    /// A key at `time` seconds with no hold.
    pub fn new(time: f64, value: V, interp: Interp) -> Self {
        Self {
            time,
            value,
            hold: 0.0,
            interp,
            rest: false,
        }
    }

    /// The same key, with the motion at rest there (rate zero) whatever its neighbours.
    pub fn at_rest(mut self) -> Self {
        self.rest = true;
        self
    }

    /// The same key, staying at its value for `hold` seconds before it moves on.
    pub fn with_hold(mut self, hold: f64) -> Self {
        self.hold = hold;
        self
    }
}

/// Why a list of keys cannot form a track. `index` is the key's position in time order.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CurveError {
    /// No keys were given.
    #[error("a track needs at least one key")]
    Empty,
    /// A key's time is NaN or infinite.
    #[error("key {index}: time must be a finite number of seconds")]
    NonFiniteTime {
        /// Position of the key.
        index: usize,
    },
    /// A key's time is not after the previous key's.
    #[error("key {index}: time {time} s is not after the previous key's {previous} s")]
    NotIncreasing {
        /// Position of the key.
        index: usize,
        /// The key's time, seconds.
        time: f64,
        /// The previous key's time, seconds.
        previous: f64,
    },
    /// A hold is negative, NaN or infinite.
    #[error("key {index}: hold must be finite and at least 0 s, found {hold}")]
    BadHold {
        /// Position of the key.
        index: usize,
        /// The hold found, seconds.
        hold: f64,
    },
    /// A hold leaves less than [`MIN_MOVING_TIME`] to move to the next key.
    #[error(
        "key {index}: hold {hold} s does not end at least {MIN_MOVING_TIME} s before the next key, {gap} s later"
    )]
    HoldOverrun {
        /// Position of the key that holds.
        index: usize,
        /// Its hold, seconds.
        hold: f64,
        /// Seconds from this key to the next.
        gap: f64,
    },
}

/// Shortest moving time of a segment, seconds. Below it 1/duration loses all precision (and
/// for subnormal durations overflows to infinity); no servo resolves such a segment anyway.
pub const MIN_MOVING_TIME: f64 = 1e-6;

/// What a segment is built to meet at its two keys.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ends<R> {
    /// The rate at the first key and at the second, per second.
    pub rates: [R; 2],
    /// The second derivative at the first key and at the second, per second²: met by
    /// [`Interp::Smooth`] segments only (a cubic's follows from its values and rates).
    pub second_rates: [R; 2],
}

/// A value that a track can interpolate.
pub trait Interpolant: Copy + fmt::Debug {
    /// Rate of change per second (a slope, or an angular velocity vector).
    type Rate: Rate;
    /// Precomputed form of one segment, so that sampling is a locate plus a cheap evaluation.
    type Segment: Copy + fmt::Debug;

    /// The change from `a` to `b` (a difference, or the rotation vector of `b·a⁻¹`).
    fn displacement(a: &Self, b: &Self) -> Self::Rate;
    /// Builds the segment from `a` to `b` of duration `h` seconds meeting `ends`.
    fn segment(a: &Self, b: &Self, ends: Ends<Self::Rate>, h: f64, mode: Interp) -> Self::Segment;
    /// The value at fraction `f` ∈ [0, 1] of the segment.
    fn eval(segment: &Self::Segment, f: f64) -> Self;
}

/// The vector-space operations that slope computation needs.
pub trait Rate: Copy + fmt::Debug {
    /// At rest.
    const ZERO: Self;
    /// This rate multiplied by `s`.
    fn scale(self, s: f64) -> Self;
    /// The sum of two rates.
    fn add(self, other: Self) -> Self;
    /// The inner product, whose sign says whether two rates point the same way.
    fn dot(self, other: Self) -> f64;
}

impl Rate for f64 {
    const ZERO: Self = 0.0;
    fn scale(self, s: f64) -> Self {
        self * s
    }
    fn add(self, other: Self) -> Self {
        self + other
    }
    fn dot(self, other: Self) -> f64 {
        self * other
    }
}

impl Rate for DVec3 {
    const ZERO: Self = DVec3::ZERO;
    fn scale(self, s: f64) -> Self {
        self * s
    }
    fn add(self, other: Self) -> Self {
        self + other
    }
    fn dot(self, other: Self) -> f64 {
        DVec3::dot(self, other)
    }
}

/// Coefficients `c0 + c1·f + … + c5·f⁵` of a segment's polynomial in its fraction f.
type Coefficients<T> = [T; 6];

/// The arithmetic a polynomial segment's values need (scalars, translations).
trait Polynomial:
    Copy
    + std::ops::Sub<Output = Self>
    + std::ops::Add<Output = Self>
    + std::ops::Mul<f64, Output = Self>
{
}
impl<T> Polynomial for T where
    T: Copy
        + std::ops::Sub<Output = T>
        + std::ops::Add<Output = T>
        + std::ops::Mul<f64, Output = T>
{
}

/// The cubic Hermite whose end values are `a`, `b` and whose end derivatives with respect to
/// f are `da`, `db`.
fn hermite_coefficients<T: Polynomial>(a: T, b: T, da: T, db: T) -> Coefficients<T> {
    let delta = b - a;
    let zero = a * 0.0;
    [
        a,
        da,
        delta * 3.0 - da * 2.0 - db,
        delta * -2.0 + da + db,
        zero,
        zero,
    ]
}

/// The quintic Hermite that also meets second derivatives (with respect to f) `sa`, `sb`:
/// the six conditions at f = 0 and f = 1 solved by hand. With every derivative zero it is
/// the minimum-jerk profile 10f³ − 15f⁴ + 6f⁵; through a cubic's values and derivatives it is
/// that cubic.
fn quintic_coefficients<T: Polynomial>(a: T, b: T, da: T, db: T, sa: T, sb: T) -> Coefficients<T> {
    let delta = b - a;
    [
        a,
        da,
        sa * 0.5,
        delta * 10.0 - da * 6.0 - db * 4.0 - sa * 1.5 + sb * 0.5,
        delta * -15.0 + da * 8.0 + db * 7.0 + sa * 1.5 - sb,
        delta * 6.0 - da * 3.0 - db * 3.0 - sa * 0.5 + sb * 0.5,
    ]
}

fn polynomial_segment<T: Polynomial>(
    a: T,
    b: T,
    ends: Ends<T>,
    h: f64,
    mode: Interp,
) -> Coefficients<T> {
    let zero = a * 0.0;
    let [ra, rb] = ends.rates;
    let [sa, sb] = ends.second_rates;
    match mode {
        Interp::Step => [a, zero, zero, zero, zero, zero],
        Interp::Linear => [a, b - a, zero, zero, zero, zero],
        Interp::Cubic | Interp::Monotone => hermite_coefficients(a, b, ra * h, rb * h),
        Interp::Smooth => quintic_coefficients(a, b, ra * h, rb * h, sa * (h * h), sb * (h * h)),
    }
}

fn eval_coefficients<T: Polynomial>(c: &Coefficients<T>, f: f64) -> T {
    c[..5].iter().rev().fold(c[5], |sum, &k| sum * f + k)
}

impl Interpolant for f64 {
    type Rate = f64;
    type Segment = Coefficients<f64>;

    fn displacement(a: &Self, b: &Self) -> f64 {
        b - a
    }
    fn segment(a: &Self, b: &Self, ends: Ends<f64>, h: f64, mode: Interp) -> Self::Segment {
        polynomial_segment(*a, *b, ends, h, mode)
    }
    fn eval(c: &Self::Segment, f: f64) -> f64 {
        eval_coefficients(c, f)
    }
}

impl Interpolant for DVec3 {
    type Rate = DVec3;
    type Segment = Coefficients<DVec3>;

    fn displacement(a: &Self, b: &Self) -> DVec3 {
        *b - *a
    }
    fn segment(a: &Self, b: &Self, ends: Ends<DVec3>, h: f64, mode: Interp) -> Self::Segment {
        polynomial_segment(*a, *b, ends, h, mode)
    }
    fn eval(c: &Self::Segment, f: f64) -> DVec3 {
        eval_coefficients(c, f)
    }
}

/// A rotation segment: a slerp, or a spherical Bézier whose inner control rotations come from
/// the end rates exactly as a scalar Bézier's come from its slopes (`c1 = a + ra·h/3`).
#[derive(Debug, Clone, Copy)]
pub enum RotationSegment {
    /// A step: the first key's rotation until the next key.
    Hold(DQuat),
    /// Linear: slerp from the first rotation to the second.
    Slerp(DQuat, DQuat),
    /// Cubic or monotone: the four control rotations of a spherical Bézier.
    Bezier([DQuat; 4]),
    /// Smooth: `exp(r(f))·a`, the rotation vector `r` a quintic from 0 to the displacement
    /// whose end derivatives are the keys' angular velocities and accelerations as rates of
    /// `r` (exact for the velocities; for a rotation about a fixed axis, the scalar curve).
    Quintic(DQuat, Coefficients<DVec3>),
}

impl Interpolant for DQuat {
    type Rate = DVec3;
    type Segment = RotationSegment;

    fn displacement(a: &Self, b: &Self) -> DVec3 {
        pose::rotation_vector(pose::same_hemisphere(DQuat::IDENTITY, *b * a.conjugate()))
    }
    fn segment(a: &Self, b: &Self, ends: Ends<DVec3>, h: f64, mode: Interp) -> RotationSegment {
        match mode {
            Interp::Step => RotationSegment::Hold(*a),
            Interp::Linear => RotationSegment::Slerp(*a, *b),
            Interp::Smooth => {
                let delta = DQuat::displacement(a, b);
                // At the far end, the rates of r that give the key's angular velocity and (up
                // to the Jacobian's own change) its acceleration.
                let far = |w: DVec3| pose::rotation_vector_rate(delta, w);
                let [ra, rb] = ends.rates;
                let [sa, sb] = ends.second_rates;
                let (hh, zero) = (h * h, DVec3::ZERO);
                let c =
                    quintic_coefficients(zero, delta, ra * h, far(rb) * h, sa * hh, far(sb) * hh);
                RotationSegment::Quintic(*a, c)
            }
            Interp::Cubic | Interp::Monotone => {
                let [ra, rb] = ends.rates;
                let c1 = pose::from_rotation_vector(ra * (h / 3.0)) * *a;
                let c2 = pose::from_rotation_vector(rb * (-h / 3.0)) * *b;
                RotationSegment::Bezier([*a, c1, c2, *b])
            }
        }
    }
    fn eval(segment: &RotationSegment, f: f64) -> DQuat {
        match *segment {
            RotationSegment::Hold(q) => q,
            RotationSegment::Slerp(a, b) => pose::slerp(a, b, f),
            RotationSegment::Quintic(a, ref c) => {
                pose::from_rotation_vector(eval_coefficients(c, f)) * a
            }
            RotationSegment::Bezier([p0, p1, p2, p3]) => {
                // De Casteljau with slerps in place of lerps.
                let q01 = pose::slerp(p0, p1, f);
                let q12 = pose::slerp(p1, p2, f);
                let q23 = pose::slerp(p2, p3, f);
                let r0 = pose::slerp(q01, q12, f);
                let r1 = pose::slerp(q12, q23, f);
                pose::slerp(r0, r1, f)
            }
        }
    }
}

/// A rigid transform's rate: linear velocity and angular velocity, both in the parent frame.
impl Rate for (DVec3, DVec3) {
    const ZERO: Self = (DVec3::ZERO, DVec3::ZERO);
    fn scale(self, s: f64) -> Self {
        (self.0 * s, self.1 * s)
    }
    fn add(self, other: Self) -> Self {
        (self.0 + other.0, self.1 + other.1)
    }
    fn dot(self, other: Self) -> f64 {
        // Metres and radians do not add; this is used only for the monotone sign and circle
        // tests, where the two parts of a transform keyed along one direction agree anyway.
        self.0.dot(other.0) + self.1.dot(other.1)
    }
}

/// A full rigid transform interpolates its translation as a vector and its rotation spherically,
/// with the same mode: linear is lerp + slerp.
impl Interpolant for RigidTransform {
    type Rate = (DVec3, DVec3);
    type Segment = (Coefficients<DVec3>, RotationSegment);

    fn displacement(a: &Self, b: &Self) -> Self::Rate {
        (
            DVec3::displacement(&a.t, &b.t),
            DQuat::displacement(&a.r, &b.r),
        )
    }
    fn segment(a: &Self, b: &Self, ends: Ends<Self::Rate>, h: f64, mode: Interp) -> Self::Segment {
        let part = |pick: fn(Self::Rate) -> DVec3| Ends {
            rates: ends.rates.map(pick),
            second_rates: ends.second_rates.map(pick),
        };
        (
            DVec3::segment(&a.t, &b.t, part(|r| r.0), h, mode),
            DQuat::segment(&a.r, &b.r, part(|r| r.1), h, mode),
        )
    }
    fn eval(segment: &Self::Segment, f: f64) -> Self {
        RigidTransform::new(DVec3::eval(&segment.0, f), DQuat::eval(&segment.1, f))
    }
}

/// The keys of one degree of freedom and the segments between them, ready to sample.
///
/// ```
/// use keypose::curve::{Interp, Track, TrackKey};
///
/// // 0 → 10 over two seconds.
/// let keys = |mode| [TrackKey::new(0.0, 0.0, mode), TrackKey::new(2.0, 10.0, mode)];
/// let linear = Track::new(&keys(Interp::Linear)).unwrap();
/// assert_eq!(linear.sample(0.5), 2.5);
///
/// // Cubic with zero end slopes: between two keys the smoothstep 3f² − 2f³,
/// // so a quarter of the way (f = 0.25) it is at 10 · 0.15625.
/// let cubic = Track::new(&keys(Interp::Cubic)).unwrap();
/// assert!((cubic.sample(0.5) - 1.5625).abs() < 1e-12);
/// assert!((cubic.sample(1.0) - 5.0).abs() < 1e-12);
///
/// // Outside the keys a track holds its end values.
/// assert_eq!(cubic.sample(-1.0), 0.0);
/// assert_eq!(cubic.sample(9.0), 10.0);
/// ```
#[derive(Debug, Clone)]
pub struct Track<V: Interpolant> {
    times: Vec<f64>,
    /// Time at which each segment starts moving (key time plus hold).
    move_start: Vec<f64>,
    /// 1 / (moving duration) of each segment; 0 for a segment that does not move.
    inv_duration: Vec<f64>,
    values: Vec<V>,
    holds: Vec<f64>,
    modes: Vec<Interp>,
    rates: Vec<V::Rate>,
    second_rates: Vec<V::Rate>,
    segments: Vec<V::Segment>,
}

/// Where a time falls on a track.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Place {
    /// Before the first key: the track holds the first value.
    Before,
    /// At key `index` or inside its hold.
    AtKey(usize),
    /// In segment `index` (from key `index` to key `index + 1`) at fraction `f`.
    Moving(usize, f64),
    /// After the last key: the track holds the last value.
    After,
}

impl<V: Interpolant> Track<V> {
    /// Builds a track from keys in strictly increasing time order.
    pub fn new(keys: &[TrackKey<V>]) -> Result<Self, CurveError> {
        validate(keys)?;
        let n = keys.len();
        let times: Vec<f64> = keys.iter().map(|k| k.time).collect();
        let values: Vec<V> = keys.iter().map(|k| k.value).collect();
        let holds: Vec<f64> = keys.iter().map(|k| k.hold).collect();
        let modes: Vec<Interp> = keys.iter().map(|k| k.interp).collect();
        let rest: Vec<bool> = keys.iter().map(|k| k.rest).collect();
        let moving: Vec<f64> = (0..n.saturating_sub(1))
            .map(|i| times[i + 1] - times[i] - holds[i])
            .collect();
        // Where the motion starts or stops whatever the modes: first and last key, a hold, a
        // rest, next to a step. There its rate is zero, and its acceleration.
        let resting: Vec<bool> = (0..n)
            .map(|i| {
                let step = |j: Option<usize>| j.is_some_and(|j| modes[j] == Interp::Step);
                i == 0
                    || i + 1 == n
                    || holds[i] > 0.0
                    || rest[i]
                    || step(i.checked_sub(1))
                    || step(Some(i))
            })
            .collect();
        let mut rates = key_rates(&times, &values, &modes, &resting, &moving);
        let spline: Vec<bool> = (0..n)
            .map(|i| !resting[i] && modes[i - 1] == Interp::Smooth && modes[i] == Interp::Smooth)
            .collect();
        spline_rates(&mut rates, &values, &moving, &spline);
        let second_rates = key_second_rates(&values, &modes, &rates, &moving, &spline, &resting);
        let segments = (0..n.saturating_sub(1))
            .map(|i| {
                let ends = Ends {
                    rates: [rates[i], rates[i + 1]],
                    second_rates: [second_rates[i], second_rates[i + 1]],
                };
                V::segment(&values[i], &values[i + 1], ends, moving[i], modes[i])
            })
            .collect();
        Ok(Self {
            move_start: (0..n).map(|i| times[i] + holds[i]).collect(),
            inv_duration: moving
                .iter()
                .map(|&h| if h > 0.0 { 1.0 / h } else { 0.0 })
                .collect(),
            times,
            values,
            holds,
            modes,
            rates,
            second_rates,
            segments,
        })
    }

    /// Number of keys (at least one).
    pub fn len(&self) -> usize {
        self.times.len()
    }

    /// Never true: [`Track::new`] refuses an empty list of keys.
    pub fn is_empty(&self) -> bool {
        self.times.is_empty()
    }

    /// Each key's time, seconds, increasing.
    pub fn times(&self) -> &[f64] {
        &self.times
    }

    /// Each key's value.
    pub fn values(&self) -> &[V] {
        &self.values
    }

    /// Each key's hold, seconds.
    pub fn holds(&self) -> &[f64] {
        &self.holds
    }

    /// Mode of each segment (the last entry belongs to the last key and is unused).
    pub fn modes(&self) -> &[Interp] {
        &self.modes
    }

    /// The rate (slope) each key was given.
    pub fn rates(&self) -> &[V::Rate] {
        &self.rates
    }

    /// The second derivative each key was given: what [`Interp::Smooth`] segments meet there
    /// (zero where the motion starts or stops, and at a key no smooth segment touches).
    pub fn second_rates(&self) -> &[V::Rate] {
        &self.second_rates
    }

    /// Time of the first key, seconds.
    pub fn start_time(&self) -> f64 {
        self.times[0]
    }

    /// Time of the last key (its hold, if any, is not included).
    pub fn end_time(&self) -> f64 {
        self.times[self.times.len() - 1]
    }

    /// Index of the last key at or before `t`, by binary search (0 before the first key).
    pub fn key_index_at(&self, t: f64) -> usize {
        self.times.partition_point(|&k| k <= t).saturating_sub(1)
    }

    /// Where `t` falls, given the last key at or before it.
    fn place_from(&self, key: usize, t: f64) -> Place {
        if t.is_nan() || t < self.times[0] {
            return Place::Before;
        }
        if key + 1 >= self.times.len() {
            return Place::After;
        }
        if t < self.move_start[key] {
            return Place::AtKey(key);
        }
        let f = ((t - self.move_start[key]) * self.inv_duration[key]).clamp(0.0, 1.0);
        Place::Moving(key, f)
    }

    /// Where time `t` (seconds) falls: before, at a key or its hold, moving, or after.
    pub fn place(&self, t: f64) -> Place {
        self.place_from(self.key_index_at(t), t)
    }

    fn value_at(&self, place: Place) -> V {
        match place {
            Place::Before => self.values[0],
            Place::After => self.values[self.values.len() - 1],
            Place::AtKey(i) => self.values[i],
            Place::Moving(i, f) => V::eval(&self.segments[i], f),
        }
    }

    /// The value at `t` by random access (binary search).
    pub fn sample(&self, t: f64) -> V {
        self.value_at(self.place(t))
    }

    /// A cursor for sampling at increasing times in O(1) amortised per sample.
    pub fn cursor(&self) -> Cursor<'_, V> {
        Cursor {
            track: self,
            key: 0,
        }
    }
}

impl Track<f64> {
    /// The slope (per second) at `t`: the derivative of the segment moving there, from the
    /// right at a key (where a linear corner or a step changes it), 0 at rest (before the first
    /// key, in a hold, after the last key, on a step).
    pub fn rate_at(&self, t: f64) -> f64 {
        match self.place(t) {
            Place::Moving(i, f) if self.modes[i] != Interp::Step => self.segment_rate(i, f),
            _ => 0.0,
        }
    }

    /// The slope just before `t` (the limit from the left): where it differs from
    /// [`Track::rate_at`] the curve turns a corner at `t`.
    pub fn rate_before(&self, t: f64) -> f64 {
        self.moving_before(t)
            .map_or(0.0, |(i, f)| self.segment_rate(i, f))
    }

    /// The segment moving just before `t` and the fraction of it at `t`: the one from key i
    /// to key i + 1 with times[i] < t <= times[i + 1], unless it rests there (a hold, a step).
    fn moving_before(&self, t: f64) -> Option<(usize, f64)> {
        let next = self.times.partition_point(|&k| k < t);
        if next == 0 || next >= self.times.len() {
            return None;
        }
        let i = next - 1;
        if t <= self.move_start[i] || self.modes[i] == Interp::Step {
            return None;
        }
        Some((
            i,
            ((t - self.move_start[i]) * self.inv_duration[i]).clamp(0.0, 1.0),
        ))
    }

    /// d/dt of segment `i` at fraction `f`: d/df of its polynomial in f, over its duration.
    fn segment_rate(&self, i: usize, f: f64) -> f64 {
        let c = &self.segments[i];
        let d = c[1] + f * (2.0 * c[2] + f * (3.0 * c[3] + f * (4.0 * c[4] + f * 5.0 * c[5])));
        d * self.inv_duration[i]
    }

    /// The second derivative (per second²) at `t`, from the right at a key, 0 at rest: with
    /// [`Track::rate_at`], what a time-scaling of the curve needs (`plan::fastest`).
    pub fn second_rate_at(&self, t: f64) -> f64 {
        match self.place(t) {
            Place::Moving(i, f) if self.modes[i] != Interp::Step => self.segment_second_rate(i, f),
            _ => 0.0,
        }
    }

    /// The second derivative just before `t` (the limit from the left).
    pub fn second_rate_before(&self, t: f64) -> f64 {
        self.moving_before(t)
            .map_or(0.0, |(i, f)| self.segment_second_rate(i, f))
    }

    /// d²/dt² of segment `i` at fraction `f`.
    fn segment_second_rate(&self, i: usize, f: f64) -> f64 {
        let c = &self.segments[i];
        let k = self.inv_duration[i];
        (2.0 * c[2] + f * (6.0 * c[3] + f * (12.0 * c[4] + f * 20.0 * c[5]))) * k * k
    }

    /// When segment `i` starts moving (its key's time plus hold).
    pub fn move_start(&self, i: usize) -> f64 {
        self.move_start[i]
    }

    /// Segment `i`'s motion as a polynomial in the seconds `s` since it starts moving
    /// ([`Track::move_start`]), `c0 + c1·s + … + c5·s⁵` (a quintic for a smooth segment, else
    /// a cubic: c4 = c5 = 0), valid until the next key's time; a step's is its first value,
    /// held until the next key, where the value jumps.
    pub fn segment_polynomial(&self, i: usize) -> [f64; 6] {
        let k = self.inv_duration[i];
        let mut scale = 1.0;
        self.segments[i].map(|c| {
            let out = c * scale;
            scale *= k;
            out
        })
    }
}

/// Sequential sampler: remembers the segment of the previous sample and walks forward from it.
/// A step back in time falls back to binary search, so any order of times is still correct.
#[derive(Debug, Clone)]
pub struct Cursor<'a, V: Interpolant> {
    track: &'a Track<V>,
    key: usize,
}

impl<V: Interpolant> Cursor<'_, V> {
    /// The value at `t` seconds, the same as [`Track::sample`].
    pub fn sample(&mut self, t: f64) -> V {
        let times = &self.track.times;
        if t >= times[self.key] {
            while self.key + 1 < times.len() && t >= times[self.key + 1] {
                self.key += 1;
            }
        } else {
            self.key = self.track.key_index_at(t);
        }
        self.track.value_at(self.track.place_from(self.key, t))
    }
}

fn validate<V>(keys: &[TrackKey<V>]) -> Result<(), CurveError> {
    if keys.is_empty() {
        return Err(CurveError::Empty);
    }
    for (index, key) in keys.iter().enumerate() {
        if !key.time.is_finite() {
            return Err(CurveError::NonFiniteTime { index });
        }
        if !(key.hold.is_finite() && key.hold >= 0.0) {
            return Err(CurveError::BadHold {
                index,
                hold: key.hold,
            });
        }
        if index > 0 {
            let previous = &keys[index - 1];
            if key.time <= previous.time || !(key.time - previous.time).is_finite() {
                return Err(CurveError::NotIncreasing {
                    index,
                    time: key.time,
                    previous: previous.time,
                });
            }
            let gap = key.time - previous.time;
            if gap - previous.hold < MIN_MOVING_TIME {
                return Err(CurveError::HoldOverrun {
                    index: index - 1,
                    hold: previous.hold,
                    gap,
                });
            }
        }
    }
    Ok(())
}

/// The rate each key gets, following the modes of the segments on either side of it.
///
/// - a resting key (`resting`: first key, last key, a key with a hold or marked at rest, a key next
///   to a step): zero (the motion is at rest);
/// - a key between a linear segment and a smooth one: the linear segment's rate, so the join is
///   continuous in velocity;
/// - otherwise the key-time central difference `(v[i+1] − v[i−1]) / (t[i+1] − t[i−1])`;
/// - then Fritsch–Carlson limiting on every monotone segment.
fn key_rates<V: Interpolant>(
    times: &[f64],
    values: &[V],
    modes: &[Interp],
    resting: &[bool],
    moving: &[f64],
) -> Vec<V::Rate> {
    let n = times.len();
    let mut rates = vec![V::Rate::ZERO; n];
    if n < 2 {
        return rates;
    }
    let displacement: Vec<V::Rate> = (0..n - 1)
        .map(|i| V::displacement(&values[i], &values[i + 1]))
        .collect();
    let secant = |i: usize| displacement[i].scale(1.0 / moving[i]);
    for i in 1..n - 1 {
        let (before, after) = (modes[i - 1], modes[i]);
        if resting[i] {
            continue;
        }
        rates[i] = match (before.is_curved(), after.is_curved()) {
            (false, false) => continue,
            (false, true) => secant(i - 1),
            (true, false) => secant(i),
            (true, true) => displacement[i - 1]
                .add(displacement[i])
                .scale(1.0 / (times[i + 1] - times[i - 1])),
        };
        // Fritsch–Carlson step 1: at a local extremum the slope must be zero, or the curve
        // overshoots the extreme key.
        let touches_monotone = before == Interp::Monotone || after == Interp::Monotone;
        if touches_monotone && displacement[i - 1].dot(displacement[i]) <= 0.0 {
            rates[i] = V::Rate::ZERO;
        }
    }
    // Fritsch–Carlson step 2: keep (α, β) inside the circle of radius 3, which is sufficient for a
    // monotone cubic. Scaling both rates towards zero cannot leave the region for a neighbouring
    // segment, because that region is closed under shrinking either rate.
    for i in 0..n - 1 {
        if modes[i] != Interp::Monotone {
            continue;
        }
        let d = secant(i);
        let d2 = d.dot(d);
        if d2 == 0.0 {
            rates[i] = V::Rate::ZERO;
            rates[i + 1] = V::Rate::ZERO;
            continue;
        }
        let alpha = rates[i].dot(d) / d2;
        let beta = rates[i + 1].dot(d) / d2;
        let radius2 = alpha * alpha + beta * beta;
        if radius2 > 9.0 {
            let tau = 3.0 / radius2.sqrt();
            rates[i] = rates[i].scale(tau);
            rates[i + 1] = rates[i + 1].scale(tau);
        }
    }
    rates
}

/// The second derivative each key gives the [`Interp::Smooth`] segments beside it.
///
/// - inside a run of smooth keys (a spline key): the spline's own, which the cubic pieces on
///   either side share;
/// - where a smooth segment meets a cubic or monotone one: the cubic's at that key, so the
///   acceleration is continuous across the join;
/// - everywhere else zero: at rest (first and last key, a hold, a rest, next to a step) and
///   beside a straight segment, whose acceleration is zero. So a smooth curve leaves and reaches
///   rest with zero acceleration.
fn key_second_rates<V: Interpolant>(
    values: &[V],
    modes: &[Interp],
    rates: &[V::Rate],
    moving: &[f64],
    spline: &[bool],
    resting: &[bool],
) -> Vec<V::Rate> {
    let n = values.len();
    let secant = |i: usize| V::displacement(&values[i], &values[i + 1]).scale(1.0 / moving[i]);
    // A cubic Hermite's second derivative at the start and at the end of segment i:
    // (6·d − 4·m0 − 2·m1)/h and (−6·d + 2·m0 + 4·m1)/h.
    let at_start = |i: usize| {
        let h = moving[i];
        secant(i)
            .scale(6.0 / h)
            .add(rates[i].scale(-4.0 / h))
            .add(rates[i + 1].scale(-2.0 / h))
    };
    let at_end = |i: usize| {
        let h = moving[i];
        secant(i)
            .scale(-6.0 / h)
            .add(rates[i].scale(2.0 / h))
            .add(rates[i + 1].scale(4.0 / h))
    };
    let cubic = |mode: Interp| matches!(mode, Interp::Cubic | Interp::Monotone);
    (0..n)
        .map(|i| {
            if spline[i] {
                return at_start(i);
            }
            let (before, after) = (
                i.checked_sub(1).map(|j| modes[j]),
                (i + 1 < n).then(|| modes[i]),
            );
            match (before, after) {
                (Some(Interp::Smooth), Some(other)) if cubic(other) && !resting[i] => at_start(i),
                (Some(other), Some(Interp::Smooth)) if cubic(other) && !resting[i] => at_end(i - 1),
                _ => V::Rate::ZERO,
            }
        })
        .collect()
}

/// The rates of every run of inner smooth keys (`spline`) that make the cubic Hermite segments meet
/// with equal second derivatives, the rates of the keys on either side of each run fixed: a
/// clamped cubic spline. With segment durations h and secants d, continuity at key k is
/// `m[k−1]/h[k−1] + 2·m[k]·(1/h[k−1] + 1/h[k]) + m[k+1]/h[k] = 3·(d[k−1]/h[k−1] + d[k]/h[k])`,
/// a tridiagonal system with a dominant diagonal, solved by elimination (Thomas).
fn spline_rates<V: Interpolant>(
    rates: &mut [V::Rate],
    values: &[V],
    moving: &[f64],
    spline: &[bool],
) {
    let mut k = 0;
    while k < spline.len() {
        if !spline[k] {
            k += 1;
            continue;
        }
        let first = k;
        while k < spline.len() && spline[k] {
            k += 1;
        }
        solve_spline_run(rates, values, moving, first, k);
    }
}

/// [`spline_rates`] for the keys `first .. end`, whose neighbours `first − 1` and `end` keep
/// their rates.
fn solve_spline_run<V: Interpolant>(
    rates: &mut [V::Rate],
    values: &[V],
    moving: &[f64],
    first: usize,
    end: usize,
) {
    let secant = |i: usize| V::displacement(&values[i], &values[i + 1]).scale(1.0 / moving[i]);
    // Forward elimination: each row k as `m[k] + upper[k]·m[k+1] = right[k]`.
    let mut upper: Vec<f64> = Vec::with_capacity(end - first);
    let mut right: Vec<V::Rate> = Vec::with_capacity(end - first);
    for k in first..end {
        let (before, after) = (1.0 / moving[k - 1], 1.0 / moving[k]);
        let mut diagonal = 2.0 * (before + after);
        let mut r = secant(k - 1)
            .scale(3.0 * before)
            .add(secant(k).scale(3.0 * after));
        if k == first {
            r = r.add(rates[k - 1].scale(-before));
        } else {
            let j = k - first - 1;
            diagonal -= before * upper[j];
            r = r.add(right[j].scale(-before));
        }
        if k + 1 == end {
            r = r.add(rates[end].scale(-after));
        }
        upper.push(if k + 1 == end { 0.0 } else { after / diagonal });
        right.push(r.scale(1.0 / diagonal));
    }
    // Back substitution.
    let mut next = V::Rate::ZERO;
    for k in (first..end).rev() {
        let j = k - first;
        let m = right[j].add(next.scale(-upper[j]));
        rates[k] = m;
        next = m;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scalar(keys: &[(f64, f64)], mode: Interp) -> Track<f64> {
        let keys: Vec<_> = keys
            .iter()
            .map(|&(t, v)| TrackKey::new(t, v, mode))
            .collect();
        Track::new(&keys).unwrap()
    }

    #[test]
    fn cursor_agrees_with_random_access_in_any_order() {
        let track = scalar(
            &[(0.0, 0.0), (1.0, 3.0), (2.5, -1.0), (4.0, 2.0)],
            Interp::Cubic,
        );
        let mut cursor = track.cursor();
        for t in [-1.0, 0.3, 0.9, 1.0, 2.0, 0.5, 3.9, 4.0, 5.0, 1.2] {
            assert_eq!(cursor.sample(t), track.sample(t), "t = {t}");
        }
    }

    #[test]
    fn hold_keeps_value_then_moves() {
        let keys = [
            TrackKey::new(0.0, 0.0, Interp::Linear).with_hold(1.0),
            TrackKey::new(2.0, 10.0, Interp::Linear),
        ];
        let track = Track::new(&keys).unwrap();
        assert_eq!(track.sample(0.9), 0.0);
        assert!((track.sample(1.5) - 5.0).abs() < 1e-12);
    }

    #[test]
    fn slopes_after_and_before_a_time() {
        // 0 → 10 linear over 2 s, then a hold of 1 s, then 10 → 4 linear over 1 s.
        let keys = [
            TrackKey::new(0.0, 0.0, Interp::Linear),
            TrackKey::new(2.0, 10.0, Interp::Linear).with_hold(1.0),
            TrackKey::new(4.0, 4.0, Interp::Linear),
        ];
        let track = Track::new(&keys).unwrap();
        assert_eq!(track.rate_at(1.0), 5.0);
        assert_eq!(track.rate_before(2.0), 5.0, "arriving at the key");
        assert_eq!(track.rate_at(2.0), 0.0, "held");
        assert_eq!(track.rate_before(3.0), 0.0, "the hold's end");
        assert_eq!(track.rate_at(3.0), -6.0);
        assert_eq!(track.rate_before(4.0), -6.0);
        assert_eq!(track.rate_at(4.0), 0.0, "after the last key");
        assert_eq!(track.rate_before(0.0), 0.0, "before the first");
        // A cubic's slope at an inner key is its key rate from both sides: (10 − 0)/(4 − 0).
        let cubic = Track::new(&[
            TrackKey::new(0.0, 0.0, Interp::Cubic),
            TrackKey::new(2.0, 5.0, Interp::Cubic),
            TrackKey::new(4.0, 10.0, Interp::Cubic),
        ])
        .unwrap();
        assert!((cubic.rate_at(2.0) - 2.5).abs() < 1e-12);
        assert!((cubic.rate_before(2.0) - 2.5).abs() < 1e-12);
    }

    #[test]
    fn invalid_keys_are_rejected() {
        let k = |t: f64| TrackKey::new(t, 0.0, Interp::Cubic);
        assert_eq!(Track::<f64>::new(&[]).unwrap_err(), CurveError::Empty);
        assert!(matches!(
            Track::new(&[k(1.0), k(1.0)]),
            Err(CurveError::NotIncreasing { index: 1, .. })
        ));
        assert!(matches!(
            Track::new(&[k(0.0).with_hold(2.0), k(1.0)]),
            Err(CurveError::HoldOverrun { index: 0, .. })
        ));
        assert!(matches!(
            Track::new(&[k(f64::NAN)]),
            Err(CurveError::NonFiniteTime { index: 0 })
        ));
    }

    /// Left and right limits of the second derivative at `t`.
    fn second_rates_around(track: &Track<f64>, t: f64) -> (f64, f64) {
        (track.second_rate_before(t), track.second_rate_at(t))
    }

    #[test]
    fn smooth_between_two_rests_is_the_minimum_jerk_profile() {
        // 0 → 30 in 2 s: 30·(10f³ − 15f⁴ + 6f⁵), f = t/2. Its velocity 30·30f²(1 − f)²/2 peaks
        // at f = ½ at 1.875·30/2 = 28.125; its acceleration 30·60f(1 − 2f)(1 − f)/4 is zero at
        // both ends; at f = ¼ the value is 30·(10/64 − 15/256 + 6/1024) = 3.105 46875.
        let track = scalar(&[(0.0, 0.0), (2.0, 30.0)], Interp::Smooth);
        assert!((track.sample(0.5) - 3.10546875).abs() < 1e-12);
        assert!((track.rate_at(1.0) - 28.125).abs() < 1e-12);
        assert!(track.second_rate_at(0.0).abs() < 1e-12);
        assert!(track.second_rate_before(2.0).abs() < 1e-12);
        let f: f64 = 0.3;
        let by_hand = 30.0 * 60.0 * f * (1.0 - 2.0 * f) * (1.0 - f) / 4.0;
        assert!((track.second_rate_at(2.0 * f) - by_hand).abs() < 1e-9);
    }

    #[test]
    fn smooth_keys_are_the_clamped_spline_inside_and_quintics_to_rest() {
        // Keys 0, 1, 1, 0 at t = 0, 1, 2, 3, at rest at both ends. The spline's rates solve
        // m0 + 4m1 + m2 = 3(d0 + d1) = 3 and m1 + 4m2 + m3 = 3(d1 + d2) = −3 with m0 = m3 = 0:
        // m1 = 1, m2 = −1. The middle piece is the cubic 1 + f − f² (peak 1.25 at t = 1.5), its
        // second derivative −2 at both inner keys; the first piece the quintic with value 1,
        // slope 1, second derivative −2 at f = 1 and all zero at f = 0: 5f³ − 6f⁴ + 2f⁵
        // (0.3125 at f = ½); the last its mirror.
        let track = scalar(
            &[(0.0, 0.0), (1.0, 1.0), (2.0, 1.0), (3.0, 0.0)],
            Interp::Smooth,
        );
        assert!((track.rates()[1] - 1.0).abs() < 1e-12);
        assert!((track.rates()[2] + 1.0).abs() < 1e-12);
        assert!((track.sample(1.5) - 1.25).abs() < 1e-12);
        assert!((track.sample(0.5) - 0.3125).abs() < 1e-12);
        assert!((track.sample(2.5) - 0.3125).abs() < 1e-12);
        for t in [1.0, 2.0] {
            let (before, after) = second_rates_around(&track, t);
            assert!(
                (before + 2.0).abs() < 1e-12 && (after + 2.0).abs() < 1e-12,
                "{t}"
            );
        }
        for t in [0.0, 3.0] {
            let (before, after) = second_rates_around(&track, t);
            assert!(before.abs() < 1e-12 && after.abs() < 1e-12, "{t}");
        }
    }

    #[test]
    fn smooth_joins_rests_lines_and_cubics_without_an_acceleration_jump() {
        // A hold, a straight segment after the smooth ones, and a cubic one: at each key the
        // acceleration is the same from both sides (zero at the hold and beside the line).
        let keys = [
            TrackKey::new(0.0, 0.0, Interp::Smooth),
            TrackKey::new(1.0, 20.0, Interp::Smooth).with_hold(0.5),
            TrackKey::new(2.5, -10.0, Interp::Smooth),
            TrackKey::new(3.2, 5.0, Interp::Smooth),
            TrackKey::new(4.0, 30.0, Interp::Linear),
            TrackKey::new(5.0, 40.0, Interp::Smooth),
            TrackKey::new(6.0, 10.0, Interp::Cubic),
            TrackKey::new(7.5, 15.0, Interp::Cubic),
        ];
        let track = Track::new(&keys).unwrap();
        for key in &keys[..7] {
            let t = key.time;
            let (before, after) = second_rates_around(&track, t);
            assert!(
                (after - before).abs() < 1e-9,
                "t = {t}: {before} then {after}"
            );
            assert!(
                (track.rate_at(t) - track.rate_before(t)).abs() < 1e-9,
                "t = {t}: the velocity jumps"
            );
        }
        let (_, after_hold) = second_rates_around(&track, 1.5);
        assert!(after_hold.abs() < 1e-12, "{after_hold}");
        // Beside the line (4 → 5 s) the slope is the line's, 10 per second, and the
        // acceleration zero.
        assert!((track.rate_before(4.0) - 10.0).abs() < 1e-9);
        assert!((track.rate_at(5.0) - 10.0).abs() < 1e-9);
        assert!(track.second_rate_before(4.0).abs() < 1e-9);
        assert!(track.second_rate_at(5.0).abs() < 1e-9);
    }

    #[test]
    fn a_smooth_rotation_turns_through_its_keys_without_a_jump_in_angular_velocity() {
        // Three rotations about different axes: the angular velocity (parent frame) just
        // before and just after the middle key, by central differences of the samples, is the
        // key's rate from both sides; zero at the first key.
        let q = |x: f64, y: f64, z: f64| DQuat::from_scaled_axis(DVec3::new(x, y, z));
        let keys = [
            TrackKey::new(0.0, q(0.0, 0.0, 0.0), Interp::Smooth),
            TrackKey::new(1.0, q(0.9, 0.2, -0.4), Interp::Smooth),
            TrackKey::new(2.2, q(-0.3, 1.1, 0.5), Interp::Smooth),
        ];
        let track = Track::new(&keys).unwrap();
        let omega = |t: f64, dt: f64| {
            let (a, b) = (track.sample(t - dt), track.sample(t + dt));
            pose::rotation_vector(pose::same_hemisphere(DQuat::IDENTITY, b * a.conjugate()))
                / (2.0 * dt)
        };
        let (before, after) = (omega(1.0 - 1e-4, 1e-5), omega(1.0 + 1e-4, 1e-5));
        let rate = track.rates()[1];
        assert!(rate.length() > 0.5, "{rate}");
        assert!((before - rate).length() < 1e-3, "{before} vs {rate}");
        assert!((after - rate).length() < 1e-3, "{after} vs {rate}");
        assert!(omega(1e-4, 1e-5).length() < 1e-3);
        let at_key = track.sample(1.0) - keys[1].value;
        assert!(at_key.length() < 1e-12, "{at_key}");
    }
}

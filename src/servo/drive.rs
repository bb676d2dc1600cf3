//! What a servo can drive: its torque-speed line, continuous rating, stiffness and rotor
//! inertia, per model variant and supply voltage. The numbers and their sources are in
//! docs/robots.md §4 and §6; each carries how sure it is ([`Basis`]), as the page marks it.
//!
//! A servo is a DC motor behind a gear train. With its supply fixed, the torque it can give
//! in the direction it turns falls on a straight line from the stall torque at rest to zero
//! at the no-load speed (back-EMF eats the voltage); braking, against its motion, it gives at
//! least the stall torque, which is all keypose counts on. Those two numbers are at the
//! output shaft, so reflected rotor inertia and speeds here are the gear train's output's too.

use super::ServoModel;

/// How a number is known, as docs/robots.md marks it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Basis {
    /// The maker's datasheet.
    Published,
    /// A system identification or bench measurement.
    Measured,
    /// Computed from published or measured numbers by a stated rule.
    Derived,
    /// A guess with a stated reason, to be tuned on the arm.
    Unverified,
}

impl Basis {
    /// How docs and reports name it.
    pub fn name(self) -> &'static str {
        match self {
            Basis::Published => "published",
            Basis::Measured => "measured",
            Basis::Derived => "derived",
            Basis::Unverified => "unverified",
        }
    }
}

/// A number and how it is known.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rated {
    /// The number, in the unit its field names.
    pub value: f64,
    /// How it is known.
    pub basis: Basis,
}

const fn published(value: f64) -> Rated {
    Rated {
        value,
        basis: Basis::Published,
    }
}
const fn measured(value: f64) -> Rated {
    Rated {
        value,
        basis: Basis::Measured,
    }
}
const fn derived(value: f64) -> Rated {
    Rated {
        value,
        basis: Basis::Derived,
    }
}
const fn unverified(value: f64) -> Rated {
    Rated {
        value,
        basis: Basis::Unverified,
    }
}

/// ROBOTIS's guideline for a stable continuous load: at most a fifth of the stall torque
/// (e-Manual, XL320 page; docs/robots.md §4). keypose applies it to every model: no maker of
/// these servos publishes a thermal rating.
pub const CONTINUOUS_FRACTION: f64 = 0.2;

/// One servo variant at one supply voltage: what it drives, at its output shaft.
#[derive(Debug, PartialEq)]
pub struct Drive {
    /// The supply, volts.
    pub supply_v: f64,
    /// Torque at rest, N·m.
    pub stall_torque: Rated,
    /// Speed without load, rad/s.
    pub no_load_speed: Rated,
    /// The position loop's stiffness below saturation at [`Drive::gain`], N·m/rad: how far
    /// the shaft gives under a steady load.
    pub stiffness: Rated,
    /// The firmware's position gain the stiffness is for: its register and value, as the arms'
    /// software writes it.
    pub gain: (&'static str, f64),
    /// The current the motor draws at stall, A: with the stall torque it gives the torque per
    /// ampere, and with the supply the winding's resistance (what heats it).
    pub stall_current: Rated,
    /// The rotor's inertia reflected through the gear train, kg·m².
    pub rotor_inertia: Rated,
    /// Coulomb friction, N·m.
    pub friction: Rated,
    /// Where the numbers come from, as docs/robots.md cites them.
    pub source: &'static str,
}

impl Drive {
    /// The most torque the servo gives, in the direction of `torque`, while its output turns
    /// at `velocity` rad/s, N·m: the torque-speed line when it drives the motion, the stall
    /// torque when it brakes it.
    pub fn available(&self, velocity: f64, torque: f64) -> f64 {
        let stall = self.stall_torque.value;
        if velocity * torque > 0.0 {
            stall * (1.0 - velocity.abs() / self.no_load_speed.value).max(0.0)
        } else {
            stall
        }
    }

    /// The continuous rating, N·m: what it holds for long without heating past its protection.
    pub fn continuous_torque(&self) -> f64 {
        CONTINUOUS_FRACTION * self.stall_torque.value
    }

    /// How far the shaft gives under a steady `torque` (N·m) at the firmware gain, radians.
    pub fn droop(&self, torque: f64) -> f64 {
        torque / self.stiffness.value
    }
}

/// A servo variant: a model's gear and winding, and what it drives at each supply it is
/// rated for (none where nothing is published).
#[derive(Debug, PartialEq)]
pub struct Variant {
    /// The model it is a variant of.
    pub model: ServoModel,
    /// The name robot files use (`"servo": {"variant": …}`); the model's own name where it
    /// has one variant.
    pub name: &'static str,
    /// What it is, for people.
    pub description: &'static str,
    /// Per supply, the first the default.
    pub drives: &'static [Drive],
}

impl Variant {
    /// Its drive at `supply_v` volts (within 0.05 V).
    pub fn at(&self, supply_v: f64) -> Option<&'static Drive> {
        self.drives
            .iter()
            .find(|d| (d.supply_v - supply_v).abs() < 0.05)
    }

    /// The supplies it is rated for, as "5, 6, 7.4 V".
    pub fn supplies(&self) -> String {
        let volts: Vec<String> = self
            .drives
            .iter()
            .map(|d| format!("{}", d.supply_v))
            .collect();
        format!("{} V", volts.join(", "))
    }
}

/// The Feetech STS3215's data: BAM is Rhoban's identification (docs/robots.md S12).
const STS3215_BAM: &str = "docs/robots.md §4, §6 (DFRobot ST3215; SO-ARM100 README; Rhoban BAM m1)";

/// Every variant keypose knows, models in [`ServoModel::ALL`]'s order, each model's default
/// variant first.
pub const VARIANTS: &[Variant] = &[
    Variant {
        model: ServoModel::Sts3215,
        name: "c001",
        description: "STS3215 7.4 V 1/345 (C001): the SO-101 follower's standard servo",
        drives: &[
            // The standard SO-101 follower runs these on 5 V: the 6 V stall torque scaled by
            // 5/6, the speed from BAM's motor model; stiffness kt·V·P·0.166/R at LeRobot's P=16;
            // stall current V/R with BAM's winding resistance, 2.676 Ω.
            Drive {
                supply_v: 5.0,
                stall_current: derived(1.87),
                stall_torque: unverified(1.35),
                no_load_speed: derived(3.5),
                stiffness: derived(6.0),
                gain: ("P_Coefficient", 16.0),
                rotor_inertia: measured(0.0284),
                friction: measured(0.0524),
                source: STS3215_BAM,
            },
            Drive {
                supply_v: 6.0,
                stall_current: derived(2.24),
                stall_torque: published(1.62),
                no_load_speed: published(4.40),
                stiffness: derived(7.2),
                gain: ("P_Coefficient", 16.0),
                rotor_inertia: measured(0.0284),
                friction: measured(0.0524),
                source: STS3215_BAM,
            },
            Drive {
                supply_v: 7.4,
                stall_current: derived(2.77),
                stall_torque: published(1.91),
                no_load_speed: published(5.45),
                stiffness: derived(8.9),
                gain: ("P_Coefficient", 16.0),
                rotor_inertia: measured(0.0284),
                friction: measured(0.0524),
                source: STS3215_BAM,
            },
        ],
    },
    Variant {
        model: ServoModel::Sts3215,
        name: "c018",
        description: "STS3215 12 V 1/345 (C018, 30 kg·cm): the SO-101's 12 V option",
        drives: &[STS3215_12V],
    },
    Variant {
        model: ServoModel::Sts3215,
        name: "c047",
        description: "STS3215 12 V 1/345 (C047, 30 kg·cm): the SO-101's 12 V option",
        drives: &[STS3215_12V],
    },
    Variant {
        model: ServoModel::Sts3215,
        name: "c044",
        description: "STS3215 7.4 V 1/191 (C044): SO-101 leader only; no drive data published",
        drives: &[],
    },
    Variant {
        model: ServoModel::Sts3215,
        name: "c046",
        description: "STS3215 7.4 V 1/147 (C046): SO-101 leader only; no drive data published",
        drives: &[],
    },
    Variant {
        model: ServoModel::Xl330M288,
        name: "xl330-m288",
        description: "ROBOTIS XL330-M288-T: the Koch follower's elbow, wrist and gripper",
        drives: &[
            xl330_m288(5.0, 0.52, 10.79),
            xl330_m288(6.0, 0.60, 12.88),
            xl330_m288(3.7, 0.42, 7.96),
        ],
    },
    Variant {
        model: ServoModel::Xl330M077,
        name: "xl330-m077",
        description: "ROBOTIS XL330-M077-T: the Koch leader",
        drives: &[
            xl330_m077(5.0, 0.215, 40.1),
            xl330_m077(6.0, 0.228, 47.8),
            xl330_m077(3.7, 0.180, 29.1),
        ],
    },
    Variant {
        model: ServoModel::Xl430W250,
        name: "xl430-w250",
        description: "ROBOTIS XL430-W250-T: the Koch follower's shoulder",
        drives: &[
            xl430_w250(12.0, 1.5, 6.39),
            xl430_w250(11.1, 1.4, 5.97),
            xl430_w250(9.0, 1.0, 4.92),
        ],
    },
    Variant {
        model: ServoModel::Xm430W350,
        name: "xm430-w350",
        description: "ROBOTIS XM430-W350-T: every OpenMANIPULATOR-X joint",
        drives: &[
            xm430_w350(12.0, 4.1, 4.82),
            xm430_w350(11.1, 3.8, 4.50),
            xm430_w350(14.8, 4.8, 5.97),
        ],
    },
];

/// The 12 V STS3215 (C018, C047): stiffness from BAM's 12 V fit at LeRobot's P=16, rotor
/// inertia BAM's.
const STS3215_12V: Drive = Drive {
    supply_v: 12.0,
    stall_current: published(2.7),
    stall_torque: published(2.94),
    no_load_speed: published(4.71),
    stiffness: derived(22.0),
    gain: ("P_Coefficient", 16.0),
    rotor_inertia: measured(0.032),
    friction: measured(0.20),
    source: STS3215_BAM,
};

/// The e-Manual's rating at `supply_v`. ROBOTIS publishes no stiffness or rotor inertia: the
/// stiffness reaches the stall torque at 0.09 rad of error (a starting value to tune), the
/// rotor inertia is the STS3215's scaled by the square of the gear ratio.
const fn dynamixel(
    supply_v: f64,
    stall_current: Rated,
    stall: f64,
    no_load: f64,
    rotor_inertia: f64,
    friction: f64,
) -> Drive {
    Drive {
        supply_v,
        stall_current,
        stall_torque: published(stall),
        no_load_speed: published(no_load),
        stiffness: unverified(stall / 0.09),
        gain: ("Position_P_Gain", 0.0),
        rotor_inertia: unverified(rotor_inertia),
        friction: unverified(friction),
        source: "docs/robots.md §4, §6 (ROBOTIS e-Manual)",
    }
}

/// The stall current at `supply_v` of a winding that draws `amps` at `rated_v` (the e-Manual's
/// rating): published there, through the same resistance (Ohm's law) at another supply.
const fn winding(supply_v: f64, rated_v: f64, amps: f64) -> Rated {
    if supply_v == rated_v {
        published(amps)
    } else {
        derived(amps * supply_v / rated_v)
    }
}

/// 288.4:1; rotor inertia and friction from BAM's "xl330" fit; 1.47 A stall at 5 V.
const fn xl330_m288(supply_v: f64, stall: f64, no_load: f64) -> Drive {
    let current = winding(supply_v, 5.0, 1.47);
    dynamixel(supply_v, current, stall, no_load, 0.0017, 0.02)
}

/// 77.5:1; the M288's rotor through (77.5 / 288.4)²; the same 1.47 A stall at 5 V.
const fn xl330_m077(supply_v: f64, stall: f64, no_load: f64) -> Drive {
    let current = winding(supply_v, 5.0, 1.47);
    dynamixel(supply_v, current, stall, no_load, 0.000123, 0.02)
}

/// 258.5:1; the STS3215's rotor through (258.5 / 345)²; 1.4 A stall at 12 V (e-Manual
/// XL430-W250 specifications; not in docs/robots.md §6, so unverified here).
const fn xl430_w250(supply_v: f64, stall: f64, no_load: f64) -> Drive {
    let current = Rated {
        basis: Basis::Unverified,
        ..winding(supply_v, 12.0, 1.4)
    };
    dynamixel(supply_v, current, stall, no_load, 0.0157, 0.05)
}

/// 353.5:1; the STS3215's rotor through (353.5 / 345)²; 2.3 A stall at 12 V.
const fn xm430_w350(supply_v: f64, stall: f64, no_load: f64) -> Drive {
    let current = winding(supply_v, 12.0, 2.3);
    dynamixel(supply_v, current, stall, no_load, 0.0294, 0.1)
}

impl ServoModel {
    /// The model's variants.
    pub fn variants(self) -> impl Iterator<Item = &'static Variant> {
        VARIANTS.iter().filter(move |v| v.model == self)
    }

    /// The variant a robot file means when it names none.
    pub fn default_variant(self) -> &'static Variant {
        self.variants()
            .next()
            .expect("every model has a variant in VARIANTS")
    }

    /// The variant robot files call `name`.
    pub fn variant(self, name: &str) -> Option<&'static Variant> {
        self.variants().find(|v| v.name == name)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_model_has_a_default_variant_and_every_variant_a_unique_name() {
        for model in ServoModel::ALL {
            assert_eq!(model.default_variant().model, model);
        }
        for (i, a) in VARIANTS.iter().enumerate() {
            assert!(
                VARIANTS[i + 1..].iter().all(|b| b.name != a.name),
                "{}",
                a.name
            );
        }
        // The standard SO-101's servo on its 5 V supply is the default.
        let c001 = ServoModel::Sts3215.default_variant();
        assert_eq!((c001.name, c001.drives[0].supply_v), ("c001", 5.0));
    }

    #[test]
    fn the_line_falls_from_stall_at_rest_to_nothing_at_no_load_speed_and_braking_keeps_stall() {
        // XM430-W350 at 12 V: 4.1 N·m stall, 4.82 rad/s no load (e-Manual).
        let d = ServoModel::Xm430W350.default_variant().at(12.0).unwrap();
        assert_eq!(d.available(0.0, 1.0), 4.1);
        assert!((d.available(2.41, 1.0) - 2.05).abs() < 1e-12);
        assert!((d.available(-2.41, -1.0) - 2.05).abs() < 1e-12);
        assert_eq!(d.available(5.0, 1.0), 0.0);
        // Braking: against the motion the servo holds at least its stall torque.
        assert_eq!(d.available(4.0, -1.0), 4.1);
        assert!((d.continuous_torque() - 0.82).abs() < 1e-12);
    }

    #[test]
    fn the_5_v_sts3215_droops_by_its_load_over_its_stiffness() {
        // 0.86 N·m of gravity at the SO-101's shoulder on a stiffness of 6 N·m/rad: 8.2°
        // (docs/robots.md §6, "Predicted sag").
        let d = ServoModel::Sts3215.default_variant().at(5.0).unwrap();
        assert!((d.droop(0.86).to_degrees() - 8.21).abs() < 0.01);
        assert!(ServoModel::Sts3215
            .variant("c046")
            .unwrap()
            .at(5.0)
            .is_none());
        assert_eq!(
            ServoModel::Xl430W250.default_variant().supplies(),
            "12, 11.1, 9 V"
        );
    }
}

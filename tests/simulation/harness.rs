//! The MuJoCo harness (`sim/sim_harness.py`) for real: MuJoCo 4 in keypose's Python
//! environment, driven over its JSON-lines protocol (sim/PROTOCOL.md), checked against physics
//! worked out by hand for a small model written here.
//!
//! The model is a two-link pendulum hanging from a fixed pivot 0.4 m above a floor plane: two
//! hinges about +y (so +q turns the link from +x towards -z, i.e. downwards), links along +x at
//! q = 0, explicit masses and centres of mass, position servos without velocity gain, joint
//! damping so that it settles.
//!
//! The environment is built on first use in `target/tmp/python_cache` and reused by later
//! runs (a changed `sim/requirements.txt` builds a new one beside it). Without python3 (3.11+,
//! with venv), PyPI, or the system's EGL and OSMesa libraries these tests fail and say so:
//! they never skip.

use keypose::python::{Harness, HarnessError, HarnessOptions, PyConfig, PythonEnv};
use serde_json::{json, Value};
use std::f64::consts::FRAC_PI_2;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;
use std::time::Duration;

const G: f64 = 9.81;
const BASE_Z: f64 = 0.4;
const L1: f64 = 0.3;
const L2: f64 = 0.2;
const M1: f64 = 1.0;
const M2: f64 = 0.5;
/// Centres of mass along each link.
const C1: f64 = 0.15;
const C2: f64 = 0.1;
const KP1: f64 = 200.0;
const KP2: f64 = 100.0;
const ELBOW_LIMIT: f64 = 1.0;

fn pendulum_mjcf() -> String {
    format!(
        r#"<mujoco model="pendulum">
  <compiler angle="radian"/>
  <option timestep="0.002" gravity="0 0 -{G}"/>
  <worldbody>
    <light pos="0 -1 2" dir="0 0.5 -1"/>
    <geom name="floor" type="plane" size="2 2 0.1" rgba="0.3 0.35 0.4 1"/>
    <body name="link1" pos="0 0 {BASE_Z}">
      <joint name="shoulder" type="hinge" axis="0 1 0" range="-3 3" damping="2" armature="0.01"/>
      <inertial pos="{C1} 0 0" mass="{M1}" diaginertia="0.001 0.0075 0.0075"/>
      <geom type="capsule" fromto="0 0 0 {L1} 0 0" size="0.02" rgba="0.9 0.5 0.1 1"/>
      <body name="link2" pos="{L1} 0 0">
        <joint name="elbow" type="hinge" axis="0 1 0" range="-{ELBOW_LIMIT} {ELBOW_LIMIT}" damping="1" armature="0.01"/>
        <inertial pos="{C2} 0 0" mass="{M2}" diaginertia="0.0005 0.0017 0.0017"/>
        <geom type="capsule" fromto="0 0 0 {L2} 0 0" size="0.02" rgba="0.1 0.5 0.9 1"/>
        <site name="tip" pos="{L2} 0 0"/>
      </body>
    </body>
  </worldbody>
  <actuator>
    <position name="shoulder_servo" joint="shoulder" kp="{KP1}" forcerange="-50 50"/>
    <position name="elbow_servo" joint="elbow" kp="{KP2}"/>
  </actuator>
</mujoco>
"#
    )
}

/// One hinge with almost no inertia behind a very stiff servo: explicit integration of the
/// servo's spring is stable only while sqrt(kp / I) * timestep < 2; here it is
/// sqrt(1e6 / 1e-4) * 0.002 = 200, so any step towards the target grows without bound.
const UNSTABLE_MJCF: &str = r#"<mujoco model="unstable">
  <compiler angle="radian"/>
  <option timestep="0.002"/>
  <worldbody>
    <body name="bar">
      <joint name="spin" type="hinge" axis="0 0 1" armature="0.0001"/>
      <inertial pos="0 0 0" mass="0.001" diaginertia="1e-9 1e-9 1e-9"/>
      <geom type="box" size="0.01 0.01 0.01" contype="0" conaffinity="0"/>
    </body>
  </worldbody>
  <actuator>
    <position joint="spin" kp="1e6"/>
  </actuator>
</mujoco>
"#;

struct Shared {
    config: PyConfig,
    env: PythonEnv,
    models: PathBuf,
}

/// The environment and the model files, made on first use by whichever test gets here first.
fn shared() -> &'static Shared {
    static SHARED: OnceLock<Result<Shared, String>> = OnceLock::new();
    let built = SHARED.get_or_init(|| {
        let cache = crate::common::python_cache();
        let config = PyConfig::with_cache_dir(&cache);
        let env = config.ensure_python().map_err(|e| {
            format!(
                "building keypose's Python environment in {} failed; these tests need python3 \
                 {}.{}+ with its venv module and access to PyPI: {e}",
                cache.display(),
                keypose::python::MIN_PYTHON.0,
                keypose::python::MIN_PYTHON.1
            )
        })?;
        let models = cache.join("harness_test_models");
        fs::create_dir_all(&models).map_err(|e| format!("{}: {e}", models.display()))?;
        for (name, text) in [
            ("pendulum.xml", pendulum_mjcf()),
            ("unstable.xml", UNSTABLE_MJCF.to_string()),
        ] {
            let path = models.join(name);
            fs::write(&path, text).map_err(|e| format!("{}: {e}", path.display()))?;
        }
        Ok(Shared {
            config,
            env,
            models,
        })
    });
    match built {
        Ok(shared) => shared,
        Err(reason) => panic!("{reason}"),
    }
}

fn model(name: &str) -> String {
    shared().models.join(name).display().to_string()
}

fn start(gl: &str) -> Harness {
    let options = HarnessOptions {
        env: vec![("MUJOCO_GL".to_string(), gl.to_string())],
        ..crate::common::patient_harness()
    };
    let harness = Harness::start_in(&shared().config, "sim_harness.py", options)
        .unwrap_or_else(|e| panic!("the MuJoCo harness did not start with MUJOCO_GL={gl}: {e}"));
    assert_eq!(harness.ready()["gl"], json!(gl), "{}", harness.ready());
    harness
}

fn pendulum(gl: &str) -> Harness {
    let mut harness = start(gl);
    request(
        &mut harness,
        json!({"op": "load", "mjcf": model("pendulum.xml")}),
    );
    harness
}

fn request(harness: &mut Harness, body: Value) -> Value {
    harness
        .request(&body)
        .unwrap_or_else(|e| panic!("{body}: {e}"))
}

/// The reply of a request that must fail.
fn refused(harness: &mut Harness, body: Value) -> Value {
    match harness.request(&body) {
        Err(error @ HarnessError::Failed { .. }) => error.reply().cloned().expect("a reply"),
        other => panic!("{body}: expected an error reply, got {other:?}"),
    }
}

fn floats(value: &Value) -> Vec<f64> {
    value
        .as_array()
        .unwrap_or_else(|| panic!("not a list: {value}"))
        .iter()
        .map(|x| x.as_f64().unwrap_or_else(|| panic!("not a number: {x}")))
        .collect()
}

fn rows(value: &Value) -> Vec<Vec<f64>> {
    value
        .as_array()
        .unwrap_or_else(|| panic!("not a list of rows: {value}"))
        .iter()
        .map(floats)
        .collect()
}

fn close(got: f64, want: f64, tolerance: f64, what: &str) {
    assert!(
        (got - want).abs() <= tolerance,
        "{what}: got {got}, want {want} ± {tolerance}"
    );
}

fn hold(joints: &[&str], initial: &[f64], target: &[f64], rows: usize) -> Value {
    json!({
        "op": "run",
        "joints": joints,
        "control_hz": 100,
        "initial": initial,
        "commands": vec![target; rows],
    })
}

#[test]
fn the_harness_is_ready_with_the_pinned_versions() {
    let harness = start("egl");
    let ready = harness.ready();
    let requirements = keypose::python::pinned_versions();
    let pin = |name: &str| {
        requirements
            .iter()
            .find(|(pinned, _)| *pinned == name)
            .map(|(_, version)| *version)
            .unwrap_or_else(|| panic!("sim/requirements.txt does not pin {name}"))
    };
    assert_eq!(ready["mujoco"], json!(pin("mujoco")), "{ready}");
    assert_eq!(ready["numpy"], json!(pin("numpy")), "{ready}");
    for name in ["mujoco", "numpy", "pyopengl", "pillow", "imageio-ffmpeg"] {
        assert_eq!(ready["packages"][name], json!(pin(name)), "{name}: {ready}");
    }
    assert!(ready.get("gl_error").is_none(), "{ready}");
    assert_eq!(harness.python(), shared().env.python.as_path());
}

/// Where the user's environment forbids bytecode (container images often set
/// PYTHONDONTWRITEBYTECODE), keypose's own environment still keeps what Python compiles, or
/// every start would compile numpy and MuJoCo's Python again: the harness's own modules are
/// compiled beside it once it has started.
#[test]
fn the_harness_keeps_its_bytecode_where_the_user_forbids_it() {
    // A cache of its own for the scripts, so that no other test's harness can write the
    // bytecode looked for here; its environment is the shared one in use (its interpreter's
    // `venv-KEY/bin/python`), linked in under the same name: keypose finds its environment by
    // the requirements' key.
    let private = tempfile::tempdir().expect("temp dir");
    let venv = shared()
        .env
        .python
        .parent()
        .and_then(Path::parent)
        .expect("the shared environment's folder");
    let name = venv.file_name().expect("venv-KEY");
    std::os::unix::fs::symlink(venv, private.path().join(name)).unwrap();
    let config = PyConfig::with_cache_dir(private.path());
    let compiled = private.path().join("sim").join("__pycache__");
    let options = HarnessOptions {
        env: vec![
            ("MUJOCO_GL".to_string(), "disable".to_string()),
            ("PYTHONDONTWRITEBYTECODE".to_string(), "1".to_string()),
        ],
        ..crate::common::patient_harness()
    };
    let harness = Harness::start_in(&config, "sim_harness.py", options)
        .unwrap_or_else(|e| panic!("the MuJoCo harness did not start: {e}"));
    drop(harness);
    let names: Vec<String> = fs::read_dir(&compiled)
        .unwrap_or_else(|e| panic!("no bytecode in {}: {e}", compiled.display()))
        .flatten()
        .map(|entry| entry.file_name().to_string_lossy().into_owned())
        .collect();
    for module in ["harness_io", "sim_model", "sim_run"] {
        assert!(
            names
                .iter()
                .any(|n| n.starts_with(&format!("{module}.")) && n.ends_with(".pyc")),
            "{module}: {names:?}"
        );
    }
}

#[test]
fn load_describes_the_model() {
    let mut harness = start("egl");
    let reply = request(
        &mut harness,
        json!({"op": "load", "mjcf": model("pendulum.xml")}),
    );
    assert_eq!(reply["timestep"], json!(0.002), "{reply}");
    assert_eq!(
        reply["joints"],
        json!([
            {"name": "shoulder", "type": "hinge", "range": [-3.0, 3.0], "limited": true},
            {"name": "elbow", "type": "hinge", "range": [-ELBOW_LIMIT, ELBOW_LIMIT], "limited": true},
        ]),
        "{reply}"
    );
    let actuators = reply["actuators"].as_array().expect("actuators");
    assert_eq!(actuators.len(), 2, "{reply}");
    assert_eq!(actuators[0]["name"], json!("shoulder_servo"));
    assert_eq!(actuators[0]["joint"], json!("shoulder"));
    assert_eq!(actuators[0]["kp"], json!(KP1));
    assert_eq!(actuators[0]["forcerange"], json!([-50.0, 50.0]));
    assert_eq!(actuators[0]["forcelimited"], json!(true));
    assert_eq!(actuators[1]["joint"], json!("elbow"));
    assert_eq!(actuators[1]["kp"], json!(KP2));
    assert_eq!(actuators[1]["forcelimited"], json!(false));
    assert_eq!(reply["bodies"], json!(["world", "link1", "link2"]));
    assert_eq!(reply["sites"], json!(["tip"]));
}

/// The `contacts` request at two poses worked out by hand: level (the arm 0.4 m up, nothing
/// near the floor) and hanging straight down, where the tip capsule's end sphere reaches
/// BASE_Z − L1 − L2 − radius = 0.4 − 0.5 − 0.02 = −0.12 m: 0.12 m into the floor, and the
/// elbow end of that capsule (0.1 − 0.02 = 0.08 m up) and all of link1 stay clear.
#[test]
fn contacts_of_one_pose_are_found_without_dynamics() {
    let mut harness = pendulum("egl");
    let level = request(
        &mut harness,
        json!({"op": "contacts", "qpos": {"shoulder": 0.0, "elbow": 0.0}}),
    );
    assert_eq!(level["contacts"], json!([]), "{level}");
    // A run, then a pose: the pose uses its own data, so the run can still be continued.
    request(
        &mut harness,
        hold(&["shoulder", "elbow"], &[0.0, 0.0], &[0.0, 0.0], 5),
    );
    let down = request(
        &mut harness,
        json!({"op": "contacts", "qpos": {"shoulder": FRAC_PI_2}}),
    );
    let contacts = down["contacts"].as_array().expect("contacts");
    assert_eq!(contacts.len(), 1, "{down}");
    let c = &contacts[0];
    assert_eq!(c["kind"], json!("floor"), "{down}");
    let mut bodies = [c["body1"].as_str().unwrap(), c["body2"].as_str().unwrap()];
    bodies.sort();
    assert_eq!(bodies, ["link2", "world"], "{down}");
    close(c["depth"].as_f64().unwrap(), 0.12, 1e-9, "depth");
    assert!(c.get("time").is_none(), "{down}");
    let mut more = hold(&["shoulder", "elbow"], &[0.0, 0.0], &[0.0, 0.0], 5);
    more["reset"] = json!(false);
    request(&mut harness, more);
    let bad = refused(
        &mut harness,
        json!({"op": "contacts", "qpos": {"wrist": 0.1}}),
    );
    assert_eq!(bad["kind"], json!("request"), "{bad}");
}

#[test]
fn kinematics_match_the_closed_form() {
    let mut harness = pendulum("egl");
    for (q1, q2) in [
        (0.0, 0.0),
        (0.3, -0.2),
        (FRAC_PI_2, 0.0),
        (-1.2, 0.9),
        (2.5, -1.0),
    ] {
        let reply = request(
            &mut harness,
            json!({"op": "kinematics", "qpos": {"shoulder": q1, "elbow": q2}, "sites": ["tip"]}),
        );
        // A rotation by q about +y takes +x to (cos q, 0, -sin q).
        let elbow = [L1 * q1.cos(), 0.0, BASE_Z - L1 * q1.sin()];
        let tip = [
            elbow[0] + L2 * (q1 + q2).cos(),
            0.0,
            elbow[2] - L2 * (q1 + q2).sin(),
        ];
        let what = format!("q = ({q1}, {q2})");
        for (got, want, name) in [
            (floats(&reply["sites"]["tip"]), tip, "tip"),
            (floats(&reply["anchors"]["elbow"]), elbow, "elbow anchor"),
            (
                floats(&reply["anchors"]["shoulder"]),
                [0.0, 0.0, BASE_Z],
                "shoulder anchor",
            ),
            (
                floats(&reply["axes"]["elbow"]),
                [0.0, 1.0, 0.0],
                "elbow axis",
            ),
        ] {
            for axis in 0..3 {
                close(got[axis], want[axis], 1e-12, &format!("{name} at {what}"));
            }
        }
    }
    // Joints not given sit at 0.
    let reply = request(
        &mut harness,
        json!({"op": "kinematics", "qpos": {"shoulder": FRAC_PI_2}, "sites": ["tip"]}),
    );
    close(
        floats(&reply["sites"]["tip"])[2],
        BASE_Z - L1 - L2,
        1e-12,
        "tip z, elbow not given",
    );
}

/// Holding 0 under gravity, each servo settles where its spring balances the gravity torque
/// about its joint: kp·q = g·Σ m·(lever arm), the lever arms shortened by the cosine of the
/// sagged angles (q > 0 is downwards):
///   kp2·q2 = g·m2·c2·cos(q1 + q2)
///   kp1·q1 = g·(m1·c1·cos q1 + m2·(L1·cos q1 + c2·cos(q1 + q2)))
/// i.e. about (m1·c1 + m2·(L1 + c2))·g / kp1 = 0.0172 rad and m2·c2·g / kp2 = 0.0049 rad.
#[test]
fn holding_zero_under_gravity_sags_by_gravity_torque_over_kp() {
    let (mut q1, mut q2) = (0.0_f64, 0.0_f64);
    for _ in 0..100 {
        q2 = G * M2 * C2 * (q1 + q2).cos() / KP2;
        q1 = G * (M1 * C1 * q1.cos() + M2 * (L1 * q1.cos() + C2 * (q1 + q2).cos())) / KP1;
    }
    let mut harness = pendulum("egl");
    // 3 s: the slower joint's oscillation decays as exp(-damping / (2·inertia) · t), with
    // inertia about the shoulder m1·c1² + m2·(L1 + c2)² + armature ≈ 0.11, so by exp(-27).
    let reply = request(
        &mut harness,
        hold(&["shoulder", "elbow"], &[0.0, 0.0], &[0.0, 0.0], 300),
    );
    assert_eq!(reply["steps"], json!(1500), "5 steps of 2 ms per 10 ms row");
    assert_eq!(reply["divergence"], json!([]));
    assert_eq!(reply["contacts"], json!([]));
    let trace = &reply["trace"];
    let time = floats(&trace["time"]);
    assert_eq!(time.len(), 300);
    close(time[0], 0.01, 1e-12, "first sample time");
    close(time[299], 3.0, 1e-9, "last sample time");
    let qpos = rows(&trace["qpos"]);
    let force = rows(&trace["force"]);
    let last = qpos.last().expect("rows");
    close(last[0], q1, 1e-4 * q1, "shoulder sag");
    close(last[1], q2, 1e-4 * q2, "elbow sag");
    // The servo's force is kp·(target - q): the gravity torque, with the sign that lifts.
    let torque = force.last().expect("rows");
    close(
        torque[0],
        -KP1 * q1,
        1e-4 * KP1 * q1,
        "shoulder servo torque",
    );
    close(torque[1], -KP2 * q2, 1e-4 * KP2 * q2, "elbow servo torque");
    let qvel = rows(&trace["qvel"]);
    assert!(qvel.last().expect("rows").iter().all(|v| v.abs() < 1e-6));
    assert!(rows(&trace["limit"])
        .iter()
        .flatten()
        .all(|flag| *flag == 0.0));
}

#[test]
fn a_command_past_the_range_activates_the_limit() {
    let mut harness = pendulum("egl");
    let reply = request(
        &mut harness,
        hold(&["shoulder", "elbow"], &[0.0, 0.0], &[0.0, 1.5], 150),
    );
    let trace = &reply["trace"];
    let limit = rows(&trace["limit"]);
    let qpos = rows(&trace["qpos"]);
    assert_eq!(limit[0], vec![0.0, 0.0], "at rest at 0, far from the limit");
    assert_eq!(limit[149], vec![0.0, 1.0], "the elbow pushed past +1 rad");
    // Whenever the flag is up the elbow is at or past its limit, and it is up once it is past.
    for (flags, q) in limit.iter().zip(&qpos) {
        assert_eq!(flags[0], 0.0, "the shoulder never reaches ±3 rad");
        if flags[1] == 1.0 {
            assert!(q[1] > ELBOW_LIMIT - 0.01, "flag up at q = {}", q[1]);
        }
        if q[1] > ELBOW_LIMIT + 1e-3 {
            assert_eq!(
                flags[1], 1.0,
                "past the limit at q = {} without the flag",
                q[1]
            );
        }
    }
    // The limit is soft, but it holds the servo's 1.5 rad target well short.
    let elbow = qpos[149][1];
    assert!(
        elbow > ELBOW_LIMIT && elbow < 1.25,
        "elbow ends at {elbow} rad"
    );
}

/// Pointing straight down, the arm would reach BASE_Z - L1 - L2 = -0.1 m: the floor stops it.
#[test]
fn driving_the_arm_into_the_floor_reports_a_floor_contact_with_force() {
    let mut harness = pendulum("egl");
    let reply = request(
        &mut harness,
        hold(&["shoulder", "elbow"], &[0.0, 0.0], &[FRAC_PI_2, 0.0], 200),
    );
    assert_eq!(reply["divergence"], json!([]), "{}", reply["divergence"]);
    let contacts = reply["contacts"].as_array().expect("contacts");
    assert!(!contacts.is_empty(), "no contact reported");
    let first = contacts[0]["time"].as_f64().expect("time");
    assert!(first > 0.01, "in contact from the start, at {first} s");
    for contact in contacts {
        assert_eq!(contact["kind"], json!("floor"), "{contact}");
        assert_eq!(contact["body1"], json!("world"), "{contact}");
        assert!(
            contact["body2"] == json!("link2") || contact["body2"] == json!("link1"),
            "{contact}"
        );
        // MuJoCo's contacts are soft: the arm swings down and sinks in on impact (centimetres
        // at a few m/s), then rests on the floor.
        let depth = contact["depth"].as_f64().expect("depth");
        assert!(depth > 0.0 && depth < 0.1, "{contact}");
        assert!(contact["force"].as_f64().expect("force") > 0.0, "{contact}");
    }
    // The floor holds the arm up: the shoulder stays short of the 90° it is driven to.
    let qpos = rows(&reply["trace"]["qpos"]);
    let shoulder = qpos.last().expect("rows")[0];
    assert!(shoulder < FRAC_PI_2 - 0.1, "shoulder ends at {shoulder}");
    let resting: Vec<&Value> = contacts
        .iter()
        .filter(|c| c["time"].as_f64().is_some_and(|t| (t - 2.0).abs() < 1e-9))
        .collect();
    assert!(!resting.is_empty(), "no longer in contact at the end");
    for contact in resting {
        let depth = contact["depth"].as_f64().expect("depth");
        assert!(depth < 0.005, "still sunk in at the end: {contact}");
    }
}

#[test]
fn a_diverging_run_stops_and_says_so() {
    let mut harness = start("egl");
    request(
        &mut harness,
        json!({"op": "load", "mjcf": model("unstable.xml")}),
    );
    let reply = request(&mut harness, hold(&["spin"], &[0.0], &[1.0], 100));
    let divergence = reply["divergence"].as_array().expect("divergence");
    assert!(
        divergence.iter().any(|d| d["fatal"] == json!(true)),
        "{reply}"
    );
    let time = floats(&reply["trace"]["time"]);
    assert!(time.len() < 100, "the run went on for {} rows", time.len());
    let stopped = divergence[0]["time"].as_f64().expect("time");
    assert!(time.iter().all(|t| *t < stopped));
    // Nothing to continue from a diverged state.
    let refusal = refused(
        &mut harness,
        json!({"op": "run", "joints": ["spin"], "control_hz": 100, "reset": false, "commands": [[0.0]]}),
    );
    assert_eq!(refusal["kind"], json!("state"), "{refusal}");
    request(&mut harness, json!({"op": "ping"}));
}

#[test]
fn a_run_with_reset_false_continues_the_previous_one() {
    let mut harness = pendulum("egl");
    let continued = json!({"op": "run", "joints": ["shoulder", "elbow"], "control_hz": 100,
                           "reset": false, "commands": [[0.0, 0.0]]});
    let refusal = refused(&mut harness, continued.clone());
    assert_eq!(refusal["kind"], json!("state"), "{refusal}");
    let first = request(
        &mut harness,
        hold(&["shoulder", "elbow"], &[0.0, 0.0], &[0.5, 0.0], 50),
    );
    let second = request(&mut harness, continued);
    let end = floats(&first["trace"]["time"])[49];
    close(
        floats(&second["trace"]["time"])[0],
        end + 0.01,
        1e-9,
        "the clock goes on",
    );
    // Half a second after a step to 0.5 rad the shoulder is well on its way, not back at 0.
    let shoulder = rows(&second["trace"]["qpos"])[0][0];
    assert!(shoulder > 0.3, "shoulder at {shoulder}");
}

#[test]
fn bad_requests_get_error_replies_and_the_harness_keeps_answering() {
    let mut harness = start("egl");
    let before_load = refused(
        &mut harness,
        json!({"op": "kinematics", "qpos": {}, "sites": []}),
    );
    assert_eq!(before_load["kind"], json!("state"), "{before_load}");
    let missing_file = refused(
        &mut harness,
        json!({"op": "load", "mjcf": "/no/such/model.xml"}),
    );
    assert_eq!(missing_file["kind"], json!("model"), "{missing_file}");
    request(
        &mut harness,
        json!({"op": "load", "mjcf": model("pendulum.xml")}),
    );

    let cases = [
        (json!({"op": "fly"}), "fly"),
        (json!({"op": "load"}), "mjcf"),
        (
            json!({"op": "kinematics", "qpos": {"wrist": 0.1}, "sites": ["tip"]}),
            "wrist",
        ),
        (
            json!({"op": "kinematics", "qpos": {"elbow": "far"}, "sites": ["tip"]}),
            "elbow",
        ),
        (
            json!({"op": "kinematics", "qpos": {}, "sites": ["gripper"]}),
            "gripper",
        ),
        (
            json!({"op": "run", "joints": ["shoulder", "wrist"], "control_hz": 100,
                   "initial": [0, 0], "commands": [[0, 0]]}),
            "wrist",
        ),
        (
            json!({"op": "run", "joints": ["shoulder", "elbow"], "control_hz": 100,
                   "initial": [0], "commands": [[0, 0]]}),
            "initial",
        ),
        (
            json!({"op": "run", "joints": ["shoulder", "elbow"], "control_hz": 100,
                   "initial": [0, 0], "commands": [[0, 0], [0, 0, 0]]}),
            "commands[1]",
        ),
        (
            json!({"op": "run", "joints": ["shoulder"], "initial": [0], "commands": [[0]]}),
            "control_hz",
        ),
        (
            json!({"op": "run", "joints": ["shoulder"], "control_hz": 1000,
                   "initial": [0], "commands": [[0]]}),
            "control_hz",
        ),
        (
            json!({"op": "render", "joints": ["shoulder"], "frames": [[0]], "path": "out.bmp"}),
            ".png",
        ),
        (
            json!({"op": "render", "joints": ["shoulder"], "frames": [[0]], "path": "out.png",
                   "elevation": 95}),
            "'elevation' must be between -90 and 90",
        ),
        (
            json!({"op": "render", "joints": ["shoulder"], "frames": [[0]], "path": "out.png",
                   "azimuth": "left"}),
            "'azimuth' must be a finite number",
        ),
    ];
    for (body, words) in cases {
        let reply = refused(&mut harness, body.clone());
        assert_eq!(reply["kind"], json!("request"), "{body}: {reply}");
        let error = reply["error"].as_str().expect("error text");
        assert!(error.contains(words), "{body}: {error}");
        request(&mut harness, json!({"op": "ping"}));
    }
    for line in ["this is not json", "[1, 2]", "{\"op\": NaN}"] {
        let reply = harness.send_raw_line(line).expect("a reply");
        assert_eq!(reply["ok"], json!(false), "{line}: {reply}");
        assert_eq!(reply["kind"], json!("request"), "{line}: {reply}");
    }
    // Still the same model, still right.
    let reply = request(
        &mut harness,
        json!({"op": "kinematics", "qpos": {"shoulder": 0.0, "elbow": 0.0}, "sites": ["tip"]}),
    );
    assert_eq!(floats(&reply["sites"]["tip"]), vec![L1 + L2, 0.0, BASE_Z]);
}

/// Width and height from a PNG's IHDR chunk, which follows the 8-byte signature.
fn png_size(path: &Path) -> (u32, u32) {
    let bytes = fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    assert_eq!(
        &bytes[..8],
        b"\x89PNG\r\n\x1a\n",
        "{} is not a PNG",
        path.display()
    );
    assert_eq!(&bytes[12..16], b"IHDR");
    let word = |at: usize| u32::from_be_bytes(bytes[at..at + 4].try_into().expect("4 bytes"));
    (word(16), word(20))
}

/// Asks the environment's own Pillow / imageio-ffmpeg what the file holds.
fn inspect(path: &Path, code: &str) -> String {
    let output = Command::new(&shared().env.python)
        .arg("-c")
        .arg(code)
        .arg(path)
        .output()
        .expect("running the environment's python");
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    String::from_utf8_lossy(&output.stdout).trim().to_string()
}

/// How many distinct colours a picture has: a failed render is one flat colour.
const COLOURS: &str =
    "import sys; from PIL import Image; print(len(Image.open(sys.argv[1]).convert('RGB').getcolors(1 << 24)))";

fn render_sheets_with(gl: &str) {
    let dir = tempfile::tempdir().expect("temp dir");
    let mut harness = pendulum(gl);
    let two = dir.path().join("two.png");
    let reply = request(
        &mut harness,
        json!({"op": "render", "joints": ["shoulder", "elbow"], "frames": [[0.0, 0.0], [1.0, -0.5]],
               "labels": ["rest", "bent"], "path": two.display().to_string(),
               "width": 160, "height": 120, "columns": 2}),
    );
    assert_eq!(reply["gl"], json!(gl), "{reply}");
    assert_eq!(reply["frames"], json!(2), "{reply}");
    assert_eq!(png_size(&two), (2 * 160, 120));
    let colours: usize = inspect(&two, COLOURS).parse().expect("a count");
    assert!(colours > 50, "{colours} colours: a blank render?");

    // Five frames in rows of two: three rows, the last one half empty.
    let five = dir.path().join("five.png");
    let frames: Vec<[f64; 2]> = (0..5).map(|i| [0.3 * f64::from(i), 0.0]).collect();
    let reply = request(
        &mut harness,
        json!({"op": "render", "joints": ["shoulder", "elbow"], "frames": frames,
               "path": five.display().to_string(), "width": 100, "height": 80, "columns": 2}),
    );
    assert_eq!(png_size(&five), (2 * 100, 3 * 80), "{reply}");
    assert_eq!(reply["columns"], json!(2));
    assert_eq!(reply["rows"], json!(3));
}

#[test]
fn a_png_contact_sheet_has_the_asked_size_with_egl() {
    render_sheets_with("egl");
}

#[test]
fn a_png_contact_sheet_has_the_asked_size_with_osmesa() {
    render_sheets_with("osmesa");
}

#[test]
fn animations_are_written_as_gif_and_mp4() {
    let dir = tempfile::tempdir().expect("temp dir");
    let mut harness = pendulum("egl");
    let frames: Vec<[f64; 2]> = (0..6).map(|i| [0.2 * f64::from(i), -0.1]).collect();
    for name in ["walk.gif", "walk.mp4"] {
        let path = dir.path().join(name);
        let reply = request(
            &mut harness,
            json!({"op": "render", "joints": ["shoulder", "elbow"], "frames": frames,
                   "path": path.display().to_string(), "width": 96, "height": 64, "fps": 10}),
        );
        assert_eq!(reply["frames"], json!(6), "{reply}");
        let found = if name.ends_with(".gif") {
            inspect(
                &path,
                "import sys; from PIL import Image; im = Image.open(sys.argv[1]); \
                 print(im.format, im.n_frames, im.size[0], im.size[1])",
            )
        } else {
            inspect(
                &path,
                "import sys, imageio_ffmpeg as f; r = f.read_frames(sys.argv[1]); m = next(r); \
                 print('MP4', sum(1 for _ in r), m['size'][0], m['size'][1])",
            )
        };
        let want = if name.ends_with(".gif") {
            "GIF 6 96 64"
        } else {
            "MP4 6 96 64"
        };
        assert_eq!(found, want, "{name}");
    }
    let leftovers: Vec<_> = fs::read_dir(dir.path())
        .expect("dir")
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|name| name.contains("partial"))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");
}

#[test]
fn an_unusable_gl_backend_is_a_render_error_and_physics_still_works() {
    physics_without_rendering("no-such-backend", "is not a backend keypose renders with");
}

/// MUJOCO_GL=disable, as keypose starts a harness that only simulates: no rendering, physics.
#[test]
fn a_harness_for_physics_only_refuses_renders_and_simulates() {
    physics_without_rendering("disable", "rendering is off in this process");
}

/// A harness started with MUJOCO_GL=`gl` says why it cannot render (`why`), refuses a render
/// as a render error, and runs physics.
fn physics_without_rendering(gl: &str, why: &str) {
    let mut harness = start(gl);
    let gl_error = harness.ready()["gl_error"].as_str().unwrap_or_default();
    assert!(gl_error.contains(why), "{}", harness.ready());
    request(
        &mut harness,
        json!({"op": "load", "mjcf": model("pendulum.xml")}),
    );
    let dir = tempfile::tempdir().expect("temp dir");
    let reply = refused(
        &mut harness,
        json!({"op": "render", "joints": ["shoulder"], "frames": [[0.0]],
               "path": dir.path().join("x.png").display().to_string()}),
    );
    assert_eq!(reply["kind"], json!("render"), "{reply}");
    assert_eq!(reply["gl"], json!(gl), "{reply}");
    let reply = request(
        &mut harness,
        hold(&["shoulder", "elbow"], &[0.0, 0.0], &[0.0, 0.0], 10),
    );
    assert_eq!(floats(&reply["trace"]["time"]).len(), 10);
}

#[test]
fn a_long_run_is_one_request_with_a_row_per_command() {
    // A long run is one request: the caller sets the timeout, the harness answers when done.
    let mut harness = pendulum("egl");
    harness.set_request_timeout(Duration::from_secs(120));
    let reply = request(
        &mut harness,
        hold(&["shoulder", "elbow"], &[0.0, 0.0], &[0.2, 0.2], 2000),
    );
    assert_eq!(floats(&reply["trace"]["time"]).len(), 2000);
    assert_eq!(reply["steps"], json!(10_000));
}

/// The binary trace (sim/PROTOCOL.md, run) read by hand from its documented layout: the header's
/// magic, version, rows and joints, then time and the four matrices as little-endian f64.
fn binary_trace(bytes: &[u8]) -> (u32, Value) {
    let word = |at: usize| u32::from_le_bytes(bytes[at..at + 4].try_into().unwrap());
    assert_eq!(&bytes[..4], b"KPTR");
    let (version, rows, joints) = (word(4), word(8) as usize, word(12) as usize);
    let values: Vec<f64> = bytes[16..]
        .chunks(8)
        .map(|b| f64::from_le_bytes(b.try_into().unwrap()))
        .collect();
    assert_eq!(
        values.len(),
        rows * (1 + 4 * joints),
        "values after the header"
    );
    let matrix = |k: usize| -> Value {
        let start = rows + k * rows * joints;
        json!(values[start..start + rows * joints]
            .chunks(joints)
            .collect::<Vec<_>>())
    };
    let trace = json!({"time": &values[..rows], "qpos": matrix(0), "qvel": matrix(1),
                       "force": matrix(2), "limit": matrix(3)});
    (version, trace)
}

/// The same run asked for a binary trace carries, after its reply line, exactly the values the
/// JSON trace lists (both rounded to nine decimals by the harness; the run is deterministic).
/// The elbow is sent past its range so that the limit column holds ones too.
#[test]
fn a_binary_trace_holds_the_values_of_the_json_trace() {
    let mut harness = pendulum("egl");
    let run = hold(&["shoulder", "elbow"], &[0.0, 0.0], &[0.3, 1.4], 60);
    let listed = request(&mut harness, run.clone());
    let mut binary_run = run.clone();
    binary_run["trace"] = json!("binary");
    let answer = harness
        .request_with_payload(&binary_run)
        .unwrap_or_else(|e| panic!("{binary_run}: {e}"));
    let bytes = answer.payload.expect("a payload after the reply line");
    // 16-byte header, then 60 rows of time and 4 matrices of 2 joints.
    assert_eq!(bytes.len(), 16 + 8 * 60 * (1 + 4 * 2));
    assert_eq!(answer.reply["payload"], json!(bytes.len()));
    assert!(answer.reply.get("trace").is_none(), "{}", answer.reply);
    let (version, trace) = binary_trace(&bytes);
    assert_eq!(version, 1);
    let limit = rows(&listed["trace"]["limit"]);
    assert!(
        limit.iter().any(|r| r[1] == 1.0),
        "the elbow reaches its stop"
    );
    assert_eq!(floats(&trace["time"]), floats(&listed["trace"]["time"]));
    // As numbers: the JSON limit column lists integers.
    for column in ["qpos", "qvel", "force", "limit"] {
        assert_eq!(
            rows(&trace[column]),
            rows(&listed["trace"][column]),
            "{column}"
        );
    }
    for member in ["contacts", "divergence", "steps"] {
        assert_eq!(answer.reply[member], listed[member], "{member}");
    }
    binary_run["trace"] = json!("csv");
    let reply = refused(&mut harness, binary_run);
    assert_eq!(reply["kind"], json!("request"), "{reply}");
}

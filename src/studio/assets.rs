//! The page and its scripts, compiled into the binary: nothing is read from disk at run time
//! and no Node toolchain is needed (three.js is vendored, see web/vendor/three/README.md).
//! These files hold no secret, so they are served without the token (the page itself is not
//! one of them: it needs the token).

/// (path, content type, bytes)
const FILES: &[(&str, &str, &[u8])] = &[
    ("/app.js", JS, include_bytes!("web/app.js")),
    ("/view3d.js", JS, include_bytes!("web/view3d.js")),
    ("/timeline.js", JS, include_bytes!("web/timeline.js")),
    ("/handle.js", JS, include_bytes!("web/handle.js")),
    ("/heartbeat.js", JS, include_bytes!("web/heartbeat.js")),
    ("/playhead.js", JS, include_bytes!("web/playhead.js")),
    ("/findings.js", JS, include_bytes!("web/findings.js")),
    ("/meshes.js", JS, include_bytes!("web/meshes.js")),
    ("/framing.js", JS, include_bytes!("web/framing.js")),
    ("/collision.js", JS, include_bytes!("web/collision.js")),
    ("/undo.js", JS, include_bytes!("web/undo.js")),
    ("/selection.js", JS, include_bytes!("web/selection.js")),
    ("/easing.js", JS, include_bytes!("web/easing.js")),
    ("/a11y.js", JS, include_bytes!("web/a11y.js")),
    ("/unsaved.js", JS, include_bytes!("web/unsaved.js")),
    ("/connection.js", JS, include_bytes!("web/connection.js")),
    (
        "/style.css",
        "text/css; charset=utf-8",
        include_bytes!("web/style.css"),
    ),
    (
        "/vendor/three/three.module.min.js",
        JS,
        include_bytes!("web/vendor/three/three.module.min.js"),
    ),
    (
        "/vendor/three/three.core.min.js",
        JS,
        include_bytes!("web/vendor/three/three.core.min.js"),
    ),
    (
        "/vendor/three/OrbitControls.js",
        JS,
        include_bytes!("web/vendor/three/OrbitControls.js"),
    ),
    (
        "/vendor/three/TransformControls.js",
        JS,
        include_bytes!("web/vendor/three/TransformControls.js"),
    ),
    (
        "/vendor/three/STLLoader.js",
        JS,
        include_bytes!("web/vendor/three/STLLoader.js"),
    ),
    (
        "/vendor/three/LICENSE",
        "text/plain; charset=utf-8",
        include_bytes!("web/vendor/three/LICENSE"),
    ),
];

const JS: &str = "text/javascript; charset=utf-8";

/// One vendored mesh file: its URL path, content type and bytes.
macro_rules! mesh {
    ($robot:literal, $file:literal) => {
        mesh!($robot, $file, "model/stl")
    };
    ($robot:literal, $file:literal, $kind:expr) => {
        (
            concat!("/meshes/", $robot, "/", $file),
            $kind,
            include_bytes!(concat!("web/meshes/", $robot, "/", $file)),
        )
    };
}

/// The official meshes of the built-in robots (web/meshes/ROBOT/, docs/meshes.md: sources,
/// commits, licences), served at /meshes/ROBOT/FILE; each robot's `parts.json`, which places
/// them, is read by `meshes`.
const MESHES: &[(&str, &str, &[u8])] = &[
    mesh!("so101", "base_motor_holder_so101_v1.stl"),
    mesh!("so101", "base_so101_v2.stl"),
    mesh!("so101", "motor_holder_so101_base_v1.stl"),
    mesh!("so101", "motor_holder_so101_wrist_v1.stl"),
    mesh!("so101", "moving_jaw_so101_v1.stl"),
    mesh!("so101", "rotation_pitch_so101_v1.stl"),
    mesh!("so101", "sts3215_03a_no_horn_v1.stl"),
    mesh!("so101", "sts3215_03a_v1.stl"),
    mesh!("so101", "under_arm_so101_v1.stl"),
    mesh!("so101", "upper_arm_so101_v1.stl"),
    mesh!("so101", "waveshare_mounting_plate_so101_v2.stl"),
    mesh!("so101", "wrist_roll_follower_so101_v1.stl"),
    mesh!("so101", "wrist_roll_pitch_so101_v2.stl"),
    mesh!("so101", "LICENSE", "text/plain; charset=utf-8"),
    mesh!("so100", "Base.stl"),
    mesh!("so100", "Base_Motor.stl"),
    mesh!("so100", "Fixed_Jaw.stl"),
    mesh!("so100", "Fixed_Jaw_Motor.stl"),
    mesh!("so100", "Lower_Arm.stl"),
    mesh!("so100", "Lower_Arm_Motor.stl"),
    mesh!("so100", "Moving_Jaw.stl"),
    mesh!("so100", "Rotation_Pitch.stl"),
    mesh!("so100", "Rotation_Pitch_Motor.stl"),
    mesh!("so100", "Upper_Arm.stl"),
    mesh!("so100", "Upper_Arm_Motor.stl"),
    mesh!("so100", "Wrist_Pitch_Roll.stl"),
    mesh!("so100", "Wrist_Pitch_Roll_Motor.stl"),
    mesh!("so100", "LICENSE", "text/plain; charset=utf-8"),
    mesh!("koch", "base_link.stl"),
    mesh!("koch", "base_link_motor.stl"),
    mesh!("koch", "link_1.stl"),
    mesh!("koch", "link_1_motor.stl"),
    mesh!("koch", "link_2.stl"),
    mesh!("koch", "link_2_motor.stl"),
    mesh!("koch", "link_3.stl"),
    mesh!("koch", "link_3_motor.stl"),
    mesh!("koch", "link_4.stl"),
    mesh!("koch", "link_4_motor.stl"),
    mesh!("koch", "link_5.stl"),
    mesh!("koch", "link_5_motor.stl"),
    mesh!("koch", "link_6.stl"),
    mesh!("koch", "LICENSE", "text/plain; charset=utf-8"),
    mesh!("omx", "gripper_left_palm.stl"),
    mesh!("omx", "gripper_right_palm.stl"),
    mesh!("omx", "link1.stl"),
    mesh!("omx", "link2.stl"),
    mesh!("omx", "link3.stl"),
    mesh!("omx", "link4.stl"),
    mesh!("omx", "link5.stl"),
    mesh!("omx", "LICENSE", "text/plain; charset=utf-8"),
];

/// The page (served only with the token).
pub(crate) const INDEX: &[u8] = include_bytes!("web/index.html");

/// The SHA-256 of the page's one inline script, the importmap (base64), for the
/// Content-Security-Policy: no other inline script runs. The browser test fails on the
/// console error a stale hash causes.
pub(crate) const IMPORTMAP_SHA256: &str = "uf2n9gE+fRPxAfwYRML9WbFRmjhihYqNtE008MLrj9o=";

/// A static file by its URL path.
pub(crate) fn file(path: &str) -> Option<(&'static str, &'static [u8])> {
    FILES
        .iter()
        .chain(MESHES)
        .find(|(p, _, _)| *p == path)
        .map(|(_, kind, bytes)| (*kind, *bytes))
}

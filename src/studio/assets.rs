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
    ("/undo.js", JS, include_bytes!("web/undo.js")),
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
        "/vendor/three/LICENSE",
        "text/plain; charset=utf-8",
        include_bytes!("web/vendor/three/LICENSE"),
    ),
];

const JS: &str = "text/javascript; charset=utf-8";

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
        .find(|(p, _, _)| *p == path)
        .map(|(_, kind, bytes)| (*kind, *bytes))
}

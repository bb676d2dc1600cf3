"""Renders of poses: choosing the OpenGL backend before MuJoCo is imported, framing every pose
with one camera, and writing the frames out (sim_images).

It knows nothing about runs or the request loop.
"""

import json
import math
import os
import sys
from types import SimpleNamespace

from harness_io import member
from sim_images import labelled, write_gif, write_mp4, write_sheet
from sim_requests import SimError, integer, matrix, number, request_error, string_list

# The backends' libraries, and the Debian/Ubuntu packages that provide them.
GL_LIBRARIES = {"egl": "EGL", "osmesa": "OSMesa"}
GL_PACKAGES = {
    "egl": "libegl1 libgl1-mesa-dri",
    "osmesa": "libosmesa6",
    "glx": "libgl1 libglx-mesa0 (and an X display)",
    "glfw": "libglfw3 libgl1 (and a display)",
}

# MUJOCO_GL for a harness that only simulates: MuJoCo then imports none of its rendering
# (PyOpenGL and the EGL context take a fifth of the start-up on a busy machine).
PHYSICS_ONLY = "disable"

# Formats a render can write, by file extension.
RENDER_FORMATS = (".png", ".gif", ".mp4")

MAX_IMAGE_SIDE = 8192
# Where the camera looks from by default: front-left and a little above (degrees, MuJoCo's
# free-camera azimuth and elevation).
DEFAULT_AZIMUTH = 135.0
DEFAULT_ELEVATION = -20.0


def choose_gl():
    """The MUJOCO_GL backend to use and, if its library cannot be loaded, why.

    MuJoCo reads MUJOCO_GL when it is imported, and when the backend's library is missing the
    import itself fails (PyOpenGL calls into a library it could not load), which would take
    physics down with rendering. So the library is tried first; without it rendering is
    disabled for this process and render requests say which package is missing.
    """
    gl = os.environ.get("MUJOCO_GL", "").strip().lower()
    if not gl:
        gl = "egl"
    os.environ["MUJOCO_GL"] = gl
    if gl == PHYSICS_ONLY:
        return gl, f"rendering is off in this process (MUJOCO_GL={PHYSICS_ONLY}, physics only)"
    if gl not in GL_PACKAGES:
        # MuJoCo's import raises on a value it does not know, physics included.
        os.environ["MUJOCO_GL"] = "disable"
        return gl, f"MUJOCO_GL={gl} is not a backend keypose renders with (egl, osmesa, glx, glfw)"
    library = GL_LIBRARIES.get(gl)
    if library is None or not sys.platform.startswith("linux"):
        return gl, None
    import ctypes
    import ctypes.util

    found = ctypes.util.find_library(library)
    if found is None:
        problem = f"the {library} library (lib{library}.so) is not installed"
    else:
        try:
            ctypes.CDLL(found)
            return gl, None
        except OSError as e:
            problem = f"the {library} library {found} cannot be loaded: {e}"
    os.environ["MUJOCO_GL"] = "disable"
    return gl, problem


class Renderer:
    """Renders with the backend chosen at start; when it has no context, says which package
    provides it."""

    def __init__(self, mujoco, np, gl, gl_problem):
        self.mujoco = mujoco
        self.np = np
        self.gl = gl
        self.gl_problem = gl_problem

    def render(self, model, req):
        r = self._render_request(model, req)
        if self.gl_problem is not None:
            raise self._gl_error(self.gl_problem)
        images = self._images(model, r)
        if r.labels is not None:
            images = [labelled(image, label) for image, label in zip(images, r.labels)]
        out = {"path": os.path.abspath(r.path), "frames": len(images), "gl": self.gl, "width": r.width, "height": r.height}
        try:
            if r.ext == ".png":
                out.update(write_sheet(images, r.columns, r.path))
            elif r.ext == ".gif":
                write_gif(images, r.fps, r.path)
            else:
                write_mp4(images, r.fps, r.path)
        except OSError as e:
            raise request_error(f"cannot write {r.path}: {e}")
        return out

    def _render_request(self, model, req):
        """The render request's joints, frames, labels, output file and image size, checked
        (before any GL context is needed, so that a bad request says so on any machine)."""
        names = string_list(req, "joints")
        joints = [model.joint(n) for n in names]
        frames = matrix(self.np, req, "frames", len(joints), nonempty=True)
        labels = member(req, "labels", None, required=False)
        if labels is not None:
            if not isinstance(labels, list) or not all(isinstance(x, str) for x in labels) or len(labels) != len(frames):
                raise request_error(f"'labels' must be a list of {len(frames)} strings (one per frame)")
        path = member(req, "path")
        if not isinstance(path, str) or not path:
            raise request_error(f"'path' must be a file path, not {json.dumps(path)}")
        ext = os.path.splitext(path)[1].lower()
        if ext not in RENDER_FORMATS:
            raise request_error(f"'path' {path!r} must end in .png (contact sheet), .gif or .mp4 (animation)")
        width = integer(req, "width", 320, 16, MAX_IMAGE_SIDE)
        height = integer(req, "height", 240, 16, MAX_IMAGE_SIDE)
        fps = number(req, "fps", 25, positive=True)
        columns = integer(req, "columns", 4, 1, 1000)
        azimuth = number(req, "azimuth", DEFAULT_AZIMUTH)
        elevation = number(req, "elevation", DEFAULT_ELEVATION)
        if not -90.0 <= elevation <= 90.0:
            raise request_error(f"'elevation' must be between -90 and 90 degrees, not {elevation:g}")
        if ext == ".mp4" and (width % 2 or height % 2):
            raise request_error(f"an MP4 (H.264, yuv420p) needs an even width and height, not {width}x{height}")
        directory = os.path.dirname(os.path.abspath(path))
        if not os.path.isdir(directory):
            raise request_error(f"cannot write {path}: the directory {directory} does not exist")
        return SimpleNamespace(
            joints=joints, frames=frames, labels=labels, path=path, ext=ext,
            width=width, height=height, fps=fps, columns=columns,
            azimuth=azimuth, elevation=elevation,
        )

    def _images(self, model, r):
        """One RGB array per frame, all seen by the same camera."""
        mujoco, m, data = self.mujoco, model.m, model.scratch
        # The offscreen buffer bounds the image size; it only matters for rendering.
        m.vis.global_.offwidth = max(int(m.vis.global_.offwidth), r.width)
        m.vis.global_.offheight = max(int(m.vis.global_.offheight), r.height)
        try:
            renderer = mujoco.Renderer(m, r.height, r.width)
        except Exception as e:
            raise self._gl_error(f"{type(e).__name__}: {e}")
        try:
            poses = []
            for row in r.frames:
                model.set_joints(data, r.joints, row)
                mujoco.mj_forward(m, data)
                poses.append(data.qpos.copy())
            camera = self._camera(model, poses, r)
            images = []
            for qpos in poses:
                data.qpos[:] = qpos
                mujoco.mj_forward(m, data)
                renderer.update_scene(data, camera)
                images.append(renderer.render().copy())
        finally:
            renderer.close()
        return images

    def _camera(self, model, poses, r):
        """A fixed free camera, by default from the front-left and above, that sees every frame
        whole."""
        width, height = r.width, r.height
        mujoco, np = self.mujoco, self.np
        m, data = model.m, model.scratch
        # Planes are infinite and would make the bounding box so; they are the floor anyway.
        solid = np.flatnonzero(m.geom_type != int(mujoco.mjtGeom.mjGEOM_PLANE))
        lo = np.full(3, np.inf)
        hi = np.full(3, -np.inf)
        for qpos in poses:
            data.qpos[:] = qpos
            mujoco.mj_kinematics(m, data)
            if solid.size:
                centers = data.geom_xpos[solid]
                radius = m.geom_rbound[solid][:, None]
                lo = np.minimum(lo, (centers - radius).min(axis=0))
                hi = np.maximum(hi, (centers + radius).max(axis=0))
        camera = mujoco.MjvCamera()
        camera.type = int(mujoco.mjtCamera.mjCAMERA_FREE)
        if np.isfinite(lo).all() and np.isfinite(hi).all():
            center = (lo + hi) / 2.0
            radius = max(float(np.linalg.norm(hi - lo)) / 2.0, 1e-3)
        else:
            center = np.array(m.stat.center)
            radius = max(float(m.stat.extent), 1e-3)
        fovy = math.radians(float(m.vis.global_.fovy))
        fovx = 2.0 * math.atan(math.tan(fovy / 2.0) * width / height)
        camera.lookat[:] = center
        camera.distance = 1.1 * radius / math.sin(min(fovx, fovy) / 2.0)
        camera.azimuth = r.azimuth
        camera.elevation = r.elevation
        return camera

    def _gl_error(self, detail):
        packages = GL_PACKAGES.get(self.gl, "")
        hint = f" (Debian/Ubuntu: apt install {packages})" if packages else ""
        return SimError(
            "render",
            f"no OpenGL context with MUJOCO_GL={self.gl}: {detail}{hint}",
            gl=self.gl,
            packages=packages,
        )

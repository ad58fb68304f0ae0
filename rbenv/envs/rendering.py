"""Software renderer of the satellite: inertia box, axes, thrusters, wheels, rods, overlay.

Draws with pygame-ce Surfaces, which need no display, so ``render_mode="rgb_array"`` works on a
headless machine; only :meth:`Renderer.show` (``render_mode="human"``) opens a window. pygame is
imported lazily so that ``import rbenv`` works without the ``render`` extra.

Conventions: quaternions are scalar first ``(w, x, y, z)``, Hamilton, body→world
(``v_W = q ⊗ v_B ⊗ q*``). The camera is orthographic, fixed in the world, looks at the origin from
the oblique direction :data:`VIEW_DIRECTION_W` with world +z up on screen.

Picture: the satellite is drawn as its *equivalent inertia box* (the uniform solid box with the
same mass and principal moments, oriented along the principal axes), body axes x/y/z as solid
red/green/blue lines from the centre, the target attitude's axes as dashed lines in the same
colours (aligned when the error is zero), each thruster as a dot at its mount point with a plume
opposite to its force whose length and opacity scale with throttle, each reaction wheel as a disc
on its spin axis, each set of torque rods as one dipole arrow, and a text overlay.
:data:`LEGEND` says what each element means, in words a user guide can quote.
"""

from __future__ import annotations

import itertools
import os
from pathlib import Path

import numpy as np

from rbenv.core import inertia as _inertia
from rbenv.core import quaternion as _quaternion
from rbenv.core import validation as check
from rbenv.core.errors import InvalidParameterError, describe

__all__ = ["LEGEND", "VIEW_DIRECTION_W", "Renderer", "equivalent_box", "save_video"]

#: What each drawn element of a frame means (the user guide quotes it).
LEGEND = """\
- Grey box: the satellite's equivalent inertia box (the uniform solid box with its mass and
  principal moments of inertia, along its principal axes), lit from the upper left; it is
  slightly translucent, so what lies behind it shows faintly.
- Solid red, green, blue lines from the centre: the body axes x, y, z, now.
- Dashed red, green, blue lines ending in a ring: the target attitude's axes x, y, z (the task's
  target frame; absent when the task has none, as in detumbling). Each dashed axis lies on the
  solid axis of its colour when the attitude error is zero; the angle between them is the error.
- Dots: thrusters at their mount points, grey when off, orange when firing; the plume points
  opposite to the thruster's force, its length and opacity grow with the throttle.
- Discs: reaction wheels, one per wheel, on its spin axis just outside the box, face normal to
  the axis. The filled slice is the wheel's speed as a fraction of its maximum (a full disc at
  the speed limit): orange when it spins positively about its axis, cyan when negatively.
- Magenta arrow: the torque rods' commanded magnetic dipole (the sum over the rods, body frame),
  leaving the box along its direction; its length outside the box grows with the dipole, full
  length at the dipole of every rod at its maximum. No arrow when the rods are off.
- Text, top left: attitude error to the target (deg), body rate (deg/s) and time (s).
The camera is fixed in the world (orthographic, world +z up on screen): the box turns as the
satellite does."""

_RENDER_EXTRA = "rendering needs the render extra: pip install 'rbenv[render]'"

#: Unit vector from the origin towards the (infinitely far) camera, world frame.
VIEW_DIRECTION_W = np.array([1.0, 0.62, 0.5]) / np.linalg.norm([1.0, 0.62, 0.5])

# Light direction in camera coordinates (x right, y up, z towards the viewer): upper left, front.
_LIGHT_CAM = np.array([-0.4, 0.6, 0.7]) / np.linalg.norm([-0.4, 0.6, 0.7])
_AMBIENT = 0.45

_BG_TOP, _BG_BOTTOM = np.array([8, 10, 26]), np.array([24, 30, 56])
_BOX_RGB = np.array([178.0, 186.0, 204.0])
_BOX_EDGE = (52, 58, 74)
_BOX_ALPHA = 238  # < 255 lets hidden axes and thrusters show through faintly (x-ray view)
_AXIS_RGB = ((235, 64, 64), (70, 205, 90), (80, 140, 255))
_GHOST_RGB = ((255, 160, 160), (165, 250, 175), (170, 200, 255))
_MARKER_IDLE, _MARKER_FIRE = np.array([120.0, 124.0, 136.0]), np.array([255.0, 170.0, 60.0])
_PLUME_OUTER, _PLUME_INNER = (255, 140, 40), (255, 236, 170)
_WHEEL_FACE, _WHEEL_RIM = (44, 48, 64), (200, 204, 220)
_WHEEL_POS, _WHEEL_NEG = (255, 150, 50), (70, 210, 235)
_DIPOLE_RGB = (235, 80, 235)

# Relative sizes, all in units of the box's half-diagonal |h|.
_AXIS_LENGTH = 1.3
_PLUME_LENGTH = 0.6
_PLUME_SPREAD = 0.28  # half-width of the plume's far end per unit plume length
_MIN_THROTTLE = 1e-3  # below this a thruster counts as off
_THROTTLE_TOL = 1e-9
_WHEEL_RADIUS = 0.14
_WHEEL_GAP = 0.2  # from the box surface to the disc's centre, along the spin axis
_DIPOLE_LENGTH = 0.7  # the arrow's length outside the box at the full dipole
_MIN_DIPOLE = 1e-3  # below this fraction of the full dipole no arrow is drawn


def _import_pygame():
    """The pygame module, or an ImportError telling the user which extra to install."""
    os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
    try:
        import pygame
    except ImportError as exc:
        raise ImportError(_RENDER_EXTRA) from exc
    return pygame


def equivalent_box(inertia, mass: float) -> tuple[np.ndarray, np.ndarray]:
    """Half-sizes and axes of the uniform solid box with the given mass and inertia.

    inertia: (3, 3) kg·m² about the centre of mass, body axes; mass in kg. Returns
    ``(half_sizes (3,) m, R (3, 3))``: half-size ``sqrt(3 (I_j + I_k − I_i) / (2 m))`` along
    principal axis i (moments ascending), R's columns the principal axes in body coordinates.
    """
    arr = _inertia.validate(inertia, name="inertia")
    m = check.positive("mass", mass)
    moments, R = _inertia.principal_axes(arr)
    twice = moments.sum() - 2.0 * moments  # I_j + I_k - I_i, >= 0 by the triangle inequality
    half = np.sqrt(np.maximum(twice, 0.0) * 3.0 / (2.0 * m))
    return half, R


class Renderer:
    """Draws RGB frames of the satellite; optionally shows them in a pygame window.

    inertia: (3, 3) kg·m² about the centre of mass, body axes; mass: kg;
    thruster_positions_B: (n, 3) m, mount points in the body frame (None: no thrusters);
    thruster_directions_B: (n, 3), direction of each thruster's force on the body (any non-zero
    length; the plume points the opposite way); width, height: frame size in pixels;
    supersample: render at this multiple of the size and downscale (antialiasing; 1 is fastest);
    wheel_axes_B: (k, 3) spin axes of k reaction wheels (any non-zero length; None: no wheels)
    and wheel_max_speed: their (k,) speed limits, rad/s; full_dipole: the torque rods' dipole
    (A·m²) drawn at the arrow's full length (None: no rods). See :data:`LEGEND`.
    """

    @classmethod
    def for_scene(cls, scene, **kwargs) -> Renderer:
        """Renderer for an :class:`rbenv.Scene`: its mass properties and what each of its
        actuator tables asks to be drawn (its parameters' ``drawing()``: keyword arguments of
        this class; a table without one is not drawn)."""
        drawn = {}
        for params in scene.actuators.values():
            drawing = getattr(params, "drawing", None)
            drawn.update(drawing() if drawing is not None else {})
        return cls(inertia=scene.body.inertia, mass=scene.body.mass, **{**drawn, **kwargs})

    def __init__(
        self,
        inertia,
        mass: float,
        thruster_positions_B=None,
        thruster_directions_B=None,
        width: int = 480,
        height: int = 480,
        *,
        supersample: int = 2,
        wheel_axes_B=None,
        wheel_max_speed=None,
        full_dipole: float | None = None,
    ):
        self.width = check.count("width", width, low=8, high=8192)
        self.height = check.count("height", height, low=8, high=8192)
        ss = check.count("supersample", supersample, low=1, high=4)
        half, R_p = equivalent_box(inertia, mass)
        pos = check.array("thruster_positions_B", np.zeros((0, 3)) if thruster_positions_B
                          is None else thruster_positions_B, (None, 3))
        n = len(pos)
        dirs = check.array("thruster_directions_B", np.zeros((0, 3)) if thruster_directions_B
                           is None else thruster_directions_B, (n, 3))
        norms = np.linalg.norm(dirs, axis=1)
        if n and not (norms > 0).all():
            i = int(np.argmin(norms))
            raise InvalidParameterError(
                f"thruster_directions_B[{i}] must be a non-zero vector, got {describe(dirs[i])}"
            )
        self._wheel_axes_B, self._wheel_max_speed = _wheels(wheel_axes_B, wheel_max_speed)
        self.n_wheels = len(self._wheel_max_speed)
        self._full_dipole = None if full_dipole is None else \
            check.positive("full_dipole", full_dipole)
        pg = _import_pygame()
        self._pg = pg
        self.n_thrusters = n
        self._ss = ss

        # A lamina (I1 + I2 = I3) has a zero half-size; keep it visible as a thin plate.
        diag = float(np.linalg.norm(half))
        self.half_sizes = half
        self._h = np.maximum(half, 0.01 * half.max())
        self._R_p = R_p
        self._eps = 1e-6 * diag

        signs = np.array(list(itertools.product((-1.0, 1.0), repeat=3)))
        self._corners_box = signs * self._h
        # Face (k, s): corners with sign s along box axis k, in cyclic order around the face.
        faces = []
        for k in range(3):
            j, l = (k + 1) % 3, (k + 2) % 3
            for s in (-1.0, 1.0):
                ring = []
                for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                    want = np.zeros(3)
                    want[k], want[j], want[l] = s, a, b
                    ring.append(int(np.flatnonzero((signs == want).all(axis=1))[0]))
                faces.append(ring)
        self._faces = np.array(faces)  # (6, 4); row 2k + (s > 0)

        self._axis_len = _AXIS_LENGTH * diag
        self._plume_len = _PLUME_LENGTH * diag
        # Body axes are body-fixed: where each leaves the box is known once and for all.
        self._body_exit, self._body_face = self._exits(R_p.T)

        self._thr_pos_B = pos
        self._thr_dir_B = dirs / np.where(norms > 0, norms, 1.0)[:, None] if n else dirs
        self._thr_pos_box = pos @ R_p
        # Wheels sit on their spin axes just outside the box: their centres are body-fixed.
        self._wheel_r = _WHEEL_RADIUS * diag
        if self.n_wheels:
            t_exit, self._wheel_face = self._exits(R_p.T @ self._wheel_axes_B.T)
            self._wheel_centre_B = self._wheel_axes_B * (t_exit + _WHEEL_GAP * diag)[:, None]

        # Camera: rows of V are screen right, screen up and the direction towards the viewer.
        e = VIEW_DIRECTION_W
        right = np.cross(-e, [0.0, 0.0, 1.0])
        right /= np.linalg.norm(right)
        up = np.cross(right, -e)
        self._view = np.stack([right, up, e])

        # Everything fits inside a sphere whose radius does not depend on the attitude.
        reach = max(diag, self._axis_len)
        if n:
            reach = max(reach, float(np.linalg.norm(pos, axis=1).max()) + self._plume_len)
        if self.n_wheels:
            reach = max(reach, float(np.linalg.norm(self._wheel_centre_B, axis=1).max())
                        + self._wheel_r)
        if self._full_dipole is not None:
            reach = max(reach, (1.0 + _DIPOLE_LENGTH) * diag)
        self._dipole_len = _DIPOLE_LENGTH * diag
        W, H = self.width * ss, self.height * ss
        margin = 0.05 * min(W, H)
        self._scale = (0.5 * min(W, H) - margin) / reach  # px per m
        self._centre = np.array([0.5 * W, 0.5 * H])
        self._proj_scale = np.array([self._scale, -self._scale])  # screen y points down
        self._px = ss  # one output pixel, in canvas pixels
        self._line_w = max(1, round(2.5 * ss * min(self.width, self.height) / 480))
        self._marker_r = max(2, round(0.011 * min(W, H)))
        # Ghost dashes at a fixed spacing along the axis, as fractions of its length.
        n_dash = 11
        starts = np.arange(n_dash) / n_dash
        self._dashes = np.stack([starts, starts + 0.55 / n_dash], axis=1)

        self._canvas = pg.Surface((W, H))
        self._scratch = pg.Surface((W, H), pg.SRCALPHA)
        self._scratch.fill((0, 0, 0, 0))
        self._out = pg.Surface((self.width, self.height)) if ss > 1 else self._canvas
        self._background = self._make_background(W, H)
        self._font = self._make_font()
        self._window = None
        self._window_closed_by_user = False

    # ------------------------------------------------------------------ public

    def frame(
        self,
        q,
        q_target=None,
        throttle=None,
        error_deg: float | None = None,
        rate_dps: float | None = None,
        time_s: float | None = None,
        wheel_speed=None,
        dipole_B=None,
    ) -> np.ndarray:
        """Render one frame. Returns (height, width, 3) uint8 RGB.

        q, q_target: (4,) body→world attitude and target, scalar first (w, x, y, z), Hamilton
        (normalised here; ``q_target=None`` draws no target axes); throttle: (n,) in [0, 1] or
        None for all off; error_deg (deg), rate_dps (deg/s), time_s (s): overlay text, a line is
        left out when its value is None; wheel_speed: (k,) rad/s relative to the body, or None
        for all at rest; dipole_B: (3,) A·m², the rods' dipole in body axes, or None for none.
        """
        R = _quaternion.to_matrix(check.unit_quaternion("q", q, normalize=True, single=True))
        R_t = None
        if q_target is not None:
            q_t = check.unit_quaternion("q_target", q_target, normalize=True, single=True)
            R_t = _quaternion.to_matrix(q_t)
        thr = self._throttle(throttle)
        speed = self._wheel_fraction(wheel_speed)
        dipole = self._dipole(dipole_B)
        labels = [
            ("error", error_deg, "{:.2f}°"),
            ("rate", rate_dps, "{:.3f}°/s"),
            ("time", time_s, "{:.1f} s"),
        ]
        text = [(name, _scalar(arg, value, fmt)) for (name, value, fmt), arg in
                zip(labels, ("error_deg", "rate_dps", "time_s"), strict=True) if value is not None]

        pg = self._pg
        canvas = self._canvas
        M = self._view @ R  # body -> camera
        Mb = M @ self._R_p  # box -> camera
        e_box = Mb[2]  # towards the viewer, in box coordinates

        # Draw calls: hidden by the box (or inside it), or in front of it; xray: outlines of
        # hidden firing thrusters drawn over the box, so every firing thruster can be seen.
        back, xray, front = [], [], []
        if R_t is not None:  # before the body axes, which cover them when aligned
            self._plan_ghosts(M, R.T @ R_t, e_box, back, front)
        self._plan_axes(M, e_box, back, front)
        self._plan_thrusters(M, e_box, thr, back, xray, front)
        self._plan_wheels(M, e_box, speed, back, front)
        self._plan_dipole(M, e_box, dipole, back, front)

        canvas.blit(self._background, (0, 0))
        self._draw_layer(back)
        self._draw_box(Mb, e_box)
        self._draw_layer(xray)
        self._draw_layer(front)
        if self._ss > 1:
            pg.transform.smoothscale(canvas, (self.width, self.height), self._out)
        if text and self._font is not None:
            self._draw_text(text)
        buf = pg.image.tobytes(self._out, "RGB")
        return np.frombuffer(buf, dtype=np.uint8).reshape(self.height, self.width, 3).copy()

    def show(self, frame: np.ndarray) -> None:
        """Show ``frame`` (H, W, 3) uint8 in a pygame window of that size, opening it if needed.

        Pumps the event queue so the window stays responsive. If the user closes the window,
        later calls do nothing (a rollout keeps running without it).
        """
        arr = np.asarray(frame)
        if arr.ndim != 3 or arr.shape[2] != 3 or arr.dtype != np.uint8:
            raise InvalidParameterError(
                f"frame must be an (H, W, 3) uint8 array, got shape {arr.shape}, dtype {arr.dtype}"
            )
        if self._window_closed_by_user:
            return
        pg = self._pg
        size = (arr.shape[1], arr.shape[0])
        if self._window is None or self._window.get_size() != size:
            try:
                pg.display.init()
                self._window = pg.display.set_mode(size)
            except pg.error as exc:
                raise RuntimeError(
                    f"render_mode='human' needs a display and none could be opened ({exc}); "
                    "use render_mode='rgb_array' on a headless machine"
                ) from exc
            pg.display.set_caption("rbenv")
        image = pg.image.frombuffer(np.ascontiguousarray(arr).tobytes(), size, "RGB")
        self._window.blit(image, (0, 0))
        pg.display.flip()
        for event in pg.event.get():
            if event.type == pg.QUIT:
                self.close()
                self._window_closed_by_user = True
                return

    def close(self) -> None:
        """Close the window opened by :meth:`show`, if any; frames can still be rendered."""
        if self._window is not None:
            self._window = None
            self._pg.display.quit()

    # ------------------------------------------------------------------ planning

    def _project(self, p_cam: np.ndarray) -> np.ndarray:
        """Canvas pixel coordinates of camera-frame points (..., 3) m. Returns (..., 2)."""
        return p_cam[..., :2] * self._proj_scale + self._centre

    def _exits(self, u_box: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Distance (m) along unit rays from the centre to the box surface, and the face crossed.

        u_box: (3, k) ray directions as columns, box coordinates. Returns ``(t (k,), face (k,))``
        with face ``2 axis + (direction > 0)``, the row of ``self._faces``.
        """
        with np.errstate(divide="ignore"):
            t_axis = self._h[:, None] / np.abs(u_box)
        axis = np.argmin(t_axis, axis=0)
        cols = np.arange(u_box.shape[1])
        return t_axis[axis, cols], 2 * axis + (u_box[axis, cols] > 0)

    def _face_front(self, face: np.ndarray, e_box: np.ndarray) -> np.ndarray:
        """Whether faces (k,) (rows of ``self._faces``) face the viewer. e_box: (3,)."""
        sign = np.where(face % 2 == 1, 1.0, -1.0)
        return sign * e_box[face // 2] > 0

    def _occluded(self, p_box: np.ndarray, e_box: np.ndarray) -> np.ndarray:
        """Whether the box hides points (k, 3) box coordinates (inside it counts as hidden).

        Slab test of the ray from each point towards the viewer ``p + s e``, ``s >= 0``.
        """
        h = self._h
        with np.errstate(divide="ignore", invalid="ignore"):
            t1 = (-h - p_box) / e_box
            t2 = (h - p_box) / e_box
        inside = np.abs(p_box) <= h
        flat = e_box == 0.0
        lo = np.where(flat, np.where(inside, -np.inf, np.inf), np.minimum(t1, t2))
        hi = np.where(flat, np.where(inside, np.inf, -np.inf), np.maximum(t1, t2))
        enter, leave = lo.max(axis=1), hi.min(axis=1)
        return (enter < leave) & (leave > self._eps)

    def _plan_axes(self, M, e_box, back, front) -> None:
        """Body axes: solid lines; only the part outside the box can ever be seen."""
        tips_cam = M.T * self._axis_len  # row i: tip of body axis i, camera coordinates
        is_front = self._face_front(self._body_face, e_box)
        for i in np.argsort(tips_cam[:, 2]):
            d = M[:, i]
            if is_front[i]:
                # Leaves through a visible face: the outside part is never hidden.
                start = self._project(d * self._body_exit[i])
                front.append(("line", _AXIS_RGB[i], start, self._project(tips_cam[i])))
            else:
                # Drawn before the box, which paints over the hidden part.
                start = self._project(np.zeros(3))
                back.append(("line", _AXIS_RGB[i], start, self._project(tips_cam[i])))

    def _plan_ghosts(self, M, R_rel, e_box, back, front) -> None:
        """Target axes: dashed lines with a ring at the tip. R_rel: target axes in body coords."""
        u_box = self._R_p.T @ R_rel
        t_exit, face = self._exits(u_box)
        is_front = self._face_front(face, e_box)
        dirs_cam = (M @ R_rel).T  # row i: target axis i, camera coordinates
        L = self._axis_len
        for i in np.argsort(dirs_cam[:, 2]):
            t0 = t_exit[i] if is_front[i] else 0.0
            seg = np.clip(self._dashes * L, t0, L)
            seg = seg[seg[:, 1] > seg[:, 0]]
            pts = self._project(seg[..., None] * dirs_cam[i])  # (k, 2, 2)
            target = front if is_front[i] else back
            target.append(("dashes", _GHOST_RGB[i], pts, self._project(dirs_cam[i] * L)))

    def _plan_thrusters(self, M, e_box, thr, back, xray, front) -> None:
        """Thruster dots at the mount points and plumes opposite to the force."""
        n = self.n_thrusters
        if n == 0:
            return
        pos_cam = self._thr_pos_B @ M.T
        dot_hidden = self._occluded(self._thr_pos_box, e_box)
        firing = np.flatnonzero(thr >= _MIN_THROTTLE)
        if firing.size:
            length = self._plume_len * thr[firing]
            plume_B = -self._thr_dir_B[firing]  # the exhaust leaves opposite to the force
            mid_box = (self._thr_pos_B[firing] + 0.5 * length[:, None] * plume_B) @ self._R_p
            plume_hidden = self._occluded(mid_box, e_box)
            outlines = self._plume_outlines(pos_cam[firing], plume_B @ M.T, length)
            for j, i in enumerate(firing):
                a = thr[i]
                item = ("plume", *outlines[j], int(100 + 140 * a), int(150 + 105 * a))
                if plume_hidden[j]:
                    back.append(item)
                    xray.append(("outline", _PLUME_OUTER, outlines[j][0], int(90 + 120 * a)))
                else:
                    front.append(item)
        for i in np.argsort(pos_cam[:, 2]):
            colour = _MARKER_IDLE + (_MARKER_FIRE - _MARKER_IDLE) * min(1.0, 2.0 * thr[i])
            item = ("dot", tuple(int(c) for c in colour), self._project(pos_cam[i]))
            if not dot_hidden[i]:
                front.append(item)
                continue
            back.append(item)
            if thr[i] >= _MIN_THROTTLE:
                xray.append(("ring", item[1], item[2]))

    def _plan_wheels(self, M, e_box, speed, back, front) -> None:
        """Wheel discs normal to their spin axes, with a slice for the speed fraction."""
        if not self.n_wheels:
            return
        is_front = self._face_front(self._wheel_face, e_box)
        centres_cam = self._wheel_centre_B @ M.T
        g_cam = self._wheel_axes_B @ M.T
        for i in np.argsort(centres_cam[:, 2]):
            a = np.cross(g_cam[i], [0.0, 0.0, 1.0])
            if np.linalg.norm(a) < 1e-6:  # spin axis towards the viewer
                a = np.array([1.0, 0.0, 0.0])
            a /= np.linalg.norm(a)
            b = np.cross(g_cam[i], a)  # (a, b, g) right-handed: angles grow with the spin
            r, c = self._wheel_r, centres_cam[i]
            rim = self._project(c + r * (_DISC[:, :1] * a + _DISC[:, 1:] * b))
            f = speed[i]
            turn = np.linspace(0.0, 2.0 * np.pi * abs(f), 25) * np.sign(f)
            pie = c + r * (np.cos(turn)[:, None] * a + np.sin(turn)[:, None] * b)
            slice_ = self._project(np.concatenate([c[None], pie])) if abs(f) > 1e-3 else None
            colour = _WHEEL_POS if f > 0 else _WHEEL_NEG
            (front if is_front[i] else back).append(("wheel", rim, slice_, colour))

    def _plan_dipole(self, M, e_box, dipole, back, front) -> None:
        """The rods' dipole: an arrow from the box surface outwards, along the dipole."""
        size = float(np.linalg.norm(dipole)) if dipole is not None else 0.0
        if size < _MIN_DIPOLE:
            return
        u_B = dipole / size
        t_exit, face = self._exits((self._R_p.T @ u_B)[:, None])
        d_cam = M @ u_B
        tip = d_cam * (t_exit[0] + self._dipole_len * min(size, 1.0))
        is_front = bool(self._face_front(face, e_box)[0])
        start = d_cam * t_exit[0] if is_front else np.zeros(3)
        side = np.cross(d_cam, [0.0, 0.0, 1.0])
        side = side / max(float(np.linalg.norm(side)), 1e-9) * 0.06 * self._dipole_len
        head = tip - 0.18 * self._dipole_len * d_cam
        item = ("arrow", self._project(start), self._project(tip),
                [self._project(p) for p in (tip, head + side, head - side)])
        (front if is_front else back).append(item)

    def _plume_outlines(self, nozzle_cam, d_cam, length) -> list:
        """Screen outlines of plume cones and their bright cores: hulls of the projected cones.

        nozzle_cam, d_cam: (k, 3) nozzle points (m) and unit plume directions, camera frame;
        length: (k,) plume lengths (m). Returns k pairs (outer, core) of vertex lists.
        """
        # a, b: unit vectors spanning the plane normal to d (a = d × z_cam, or x_cam if d ∥ z).
        a = np.stack([d_cam[:, 1], -d_cam[:, 0], np.zeros(len(d_cam))], axis=1)
        norm = np.linalg.norm(a, axis=1, keepdims=True)
        a = np.where(norm > 1e-6, a / np.maximum(norm, 1e-12), [1.0, 0.0, 0.0])
        b = np.cross(d_cam, a)
        ring = _RING[:, 0, None, None] * a + _RING[:, 1, None, None] * b  # (12, k, 3)
        L = length[:, None]
        cones = []
        for frac, spread in ((1.0, _PLUME_SPREAD), (0.6, 0.45 * _PLUME_SPREAD)):
            base = nozzle_cam + d_cam * (frac * L) + ring * (spread * L)
            cones.append(self._project(np.concatenate([nozzle_cam[None], base])))  # (13, k, 2)
        return [
            (_convex_hull(cones[0][:, j]), _convex_hull(cones[1][:, j]))
            for j in range(len(length))
        ]

    # ------------------------------------------------------------------ drawing

    def _draw_layer(self, items) -> None:
        """Execute planned draw calls in order; plumes go through the alpha scratch surface."""
        pg, canvas = self._pg, self._canvas
        w, px = self._line_w, self._px
        dirty = None
        for it in items:
            if it[0] == "plume":
                _, outer, inner, a_outer, a_inner = it
                r = pg.draw.polygon(self._scratch, (*_PLUME_OUTER, a_outer), outer)
                pg.draw.polygon(self._scratch, (*_PLUME_INNER, a_inner), inner)
            elif it[0] == "outline":
                _, colour, outer, alpha = it
                r = pg.draw.polygon(self._scratch, (*colour, alpha), outer, max(1, w // 2))
            else:
                continue
            dirty = r if dirty is None else dirty.union(r)
        if dirty is not None:
            self._flush_scratch(dirty)
        for it in items:
            kind = it[0]
            if kind == "line":
                _, colour, p0, p1 = it
                pg.draw.line(canvas, colour, p0, p1, w)
                pg.draw.circle(canvas, colour, p1, 0.5 * w + px)
            elif kind == "dashes":
                _, colour, segs, tip = it
                for p0, p1 in segs:
                    pg.draw.line(canvas, colour, p0, p1, max(1, round(0.6 * w)))
                pg.draw.circle(canvas, colour, tip, 2.2 * w, max(1, w // 2))
            elif kind == "dot":
                _, colour, p = it
                pg.draw.circle(canvas, colour, p, self._marker_r)
                pg.draw.circle(canvas, (20, 22, 30), p, self._marker_r, px)
            elif kind == "ring":
                _, colour, p = it
                pg.draw.circle(canvas, colour, p, self._marker_r, max(1, w // 2))
            elif kind == "wheel":
                _, rim, slice_, colour = it
                pg.draw.polygon(canvas, _WHEEL_FACE, rim)
                if slice_ is not None:
                    pg.draw.polygon(canvas, colour, slice_)
                pg.draw.polygon(canvas, _WHEEL_RIM, rim, max(1, w // 2))
            elif kind == "arrow":
                _, p0, p1, head = it
                pg.draw.line(canvas, _DIPOLE_RGB, p0, p1, w)
                pg.draw.polygon(canvas, _DIPOLE_RGB, head)

    def _draw_box(self, Mb, e_box) -> None:
        """Visible faces of the box, Lambert-shaded, painted back to front, edges outlined."""
        pg = self._pg
        corners = self._project(self._corners_box @ Mb.T)
        depth = (self._corners_box @ Mb.T)[:, 2]
        faces = []
        for k in range(3):
            if abs(e_box[k]) < 1e-9:
                continue  # seen edge-on
            s = 1.0 if e_box[k] > 0 else -1.0
            ring = self._faces[2 * k + (s > 0)]
            lambert = max(0.0, float(s * Mb[:, k] @ _LIGHT_CAM))
            faces.append((float(depth[ring].mean()), ring, _AMBIENT + (1 - _AMBIENT) * lambert))
        dirty = None
        for _, ring, shade in sorted(faces, key=lambda f: f[0]):
            colour = (*np.minimum(255, _BOX_RGB * shade).astype(int), _BOX_ALPHA)
            pts = corners[ring]
            r = pg.draw.polygon(self._scratch, colour, pts)
            pg.draw.polygon(self._scratch, (*_BOX_EDGE, 255), pts, self._px)
            dirty = r if dirty is None else dirty.union(r)
        if dirty is not None:
            self._flush_scratch(dirty.inflate(2 * self._px, 2 * self._px))

    def _flush_scratch(self, rect) -> None:
        """Blend the scratch surface's ``rect`` onto the canvas and clear it again."""
        rect = rect.clip(self._scratch.get_rect())
        self._canvas.blit(self._scratch, rect.topleft, rect)
        self._scratch.fill((0, 0, 0, 0), rect)

    def _draw_text(self, text) -> None:
        """Overlay ``[(label, value), ...]`` top left on a translucent panel."""
        pg, font = self._pg, self._font
        colour = (230, 233, 240)
        labels = [font.render(name, True, (160, 168, 190)) for name, _ in text]
        values = [font.render(value, True, colour) for _, value in text]
        pad = max(3, font.get_height() // 3)
        col = max(s.get_width() for s in labels) + 2 * pad
        width = col + max(max(s.get_width() for s in values), font.size("000.000°/s")[0])
        line = font.get_linesize()
        panel = pg.Surface((width + 2 * pad, line * len(text) + 2 * pad), pg.SRCALPHA)
        panel.fill((0, 0, 0, 120))
        self._out.blit(panel, (pad, pad))
        for n, (lab, val) in enumerate(zip(labels, values, strict=True)):
            y = 2 * pad + n * line
            self._out.blit(lab, (2 * pad, y))
            self._out.blit(val, (2 * pad + width - val.get_width(), y))

    def _make_background(self, W: int, H: int):
        """Vertical gradient with a fixed, seeded star field (identical frames for equal inputs)."""
        t = np.linspace(0.0, 1.0, H)[None, :, None]
        img = np.broadcast_to(_BG_TOP + (_BG_BOTTOM - _BG_TOP) * t, (W, H, 3)).copy()
        rng = np.random.default_rng(7)
        n = (W * H) // (900 * self._ss**2)
        xs, ys = rng.integers(0, W, n), rng.integers(0, H, n)
        img[xs, ys] = rng.uniform(70, 190, n)[:, None]
        return self._pg.surfarray.make_surface(img.astype(np.uint8))

    def _make_font(self):
        """pygame's default font at a size that suits the frame, or None if fonts are missing."""
        pg = self._pg
        try:
            pg.font.init()
            return pg.font.Font(None, max(12, round(min(self.width, self.height) / 22)))
        except Exception:  # no SDL_ttf or no default font: frames without text beat a crash
            return None

    def _throttle(self, throttle) -> np.ndarray:
        n = self.n_thrusters
        if throttle is None:
            return np.zeros(n)
        thr = check.array("throttle", throttle, (n,))
        if ((thr < -_THROTTLE_TOL) | (thr > 1.0 + _THROTTLE_TOL)).any():
            raise InvalidParameterError(f"throttle must lie in [0, 1], got {describe(thr)}")
        return np.clip(thr, 0.0, 1.0)


    def _wheel_fraction(self, wheel_speed) -> np.ndarray:
        """Wheel speeds (k,) rad/s as signed fractions of the limits, clipped to [-1, 1]."""
        if wheel_speed is None:
            return np.zeros(self.n_wheels)
        speed = check.array("wheel_speed", wheel_speed, (self.n_wheels,))
        return np.clip(speed / self._wheel_max_speed, -1.0, 1.0)

    def _dipole(self, dipole_B) -> np.ndarray | None:
        """The dipole (3,) A·m² as a fraction of the full dipole, or None."""
        if dipole_B is None or self._full_dipole is None:
            return None
        return check.array("dipole_B", dipole_B, (3,)) / self._full_dipole


def _wheels(axes_B, max_speed) -> tuple[np.ndarray, np.ndarray]:
    """Unit spin axes (k, 3) and speed limits (k,) rad/s, checked; none when axes_B is None."""
    if axes_B is None:
        return np.zeros((0, 3)), np.zeros(0)
    axes = check.array("wheel_axes_B", axes_B, (None, 3))
    limit = check.array("wheel_max_speed", max_speed, (len(axes),))
    norms = np.linalg.norm(axes, axis=1)
    if not ((norms > 0).all() and (limit > 0).all()):
        raise InvalidParameterError(
            f"wheel_axes_B must be non-zero vectors and wheel_max_speed positive, got "
            f"{describe(axes)} and {describe(limit)}")
    return axes / norms[:, None], limit


# ---------------------------------------------------------------------- video


def save_video(frames, path, fps: float = 10) -> Path:
    """Write frames to a .gif (imageio's pillow plugin) or .mp4 (needs imageio-ffmpeg).

    frames: sequence of (H, W, 3) uint8 arrays, all the same shape; path: file name ending in
    .gif or .mp4 (parent folders are created); fps: frames per second (> 0). Returns the path.
    A GIF stores delays in 10 ms steps, and its encoder may merge identical consecutive frames.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in (".gif", ".mp4"):
        raise InvalidParameterError(f"path must end in .gif or .mp4, got {str(path)!r}")
    fps = check.positive("fps", fps)
    try:
        frames = list(frames)
    except TypeError as exc:
        raise InvalidParameterError(
            f"frames must be a sequence of (H, W, 3) uint8 arrays, got {type(frames).__name__}"
        ) from exc
    if not frames:
        raise InvalidParameterError("frames must hold at least one frame, got an empty sequence")
    first = np.asarray(frames[0])
    for i, f in enumerate(frames):
        arr = np.asarray(f)
        if arr.ndim != 3 or arr.shape[2] != 3 or arr.dtype != np.uint8 or arr.shape != first.shape:
            raise InvalidParameterError(
                f"frames[{i}] must be an (H, W, 3) uint8 array shaped like frames[0] "
                f"{first.shape}, got shape {arr.shape}, dtype {arr.dtype}"
            )
    try:
        import imageio.v3 as iio
    except ImportError as exc:
        raise ImportError(_RENDER_EXTRA) from exc
    stack = np.stack([np.asarray(f) for f in frames])
    path.parent.mkdir(parents=True, exist_ok=True)
    if suffix == ".gif":
        iio.imwrite(path, stack, extension=".gif", plugin="pillow", duration=1000.0 / fps, loop=0)
        return path
    try:
        import imageio_ffmpeg  # noqa: F401
    except ImportError as exc:
        raise ImportError(
            f"writing {path.name!r} as .mp4 needs imageio-ffmpeg (pip install imageio-ffmpeg); "
            "or save a .gif instead, which needs nothing beyond the render extra"
        ) from exc
    # H.264 in yuv420p needs even sizes: pad by repeating the last row / column.
    h, w = stack.shape[1:3]
    stack = np.pad(stack, ((0, 0), (0, h % 2), (0, w % 2), (0, 0)), mode="edge")
    iio.imwrite(path, stack, plugin="FFMPEG", fps=fps, macro_block_size=1)
    return path


# ---------------------------------------------------------------------- helpers

_RING = np.stack(
    [np.cos(np.linspace(0, 2 * np.pi, 12, endpoint=False)),
     np.sin(np.linspace(0, 2 * np.pi, 12, endpoint=False))],
    axis=1,
)


_DISC = np.stack(
    [np.cos(np.linspace(0, 2 * np.pi, 32, endpoint=False)),
     np.sin(np.linspace(0, 2 * np.pi, 32, endpoint=False))],
    axis=1,
)


def _convex_hull(pts: np.ndarray) -> list[tuple[float, float]]:
    """Convex hull (monotone chain) of 2-D points (k, 2), as a polygon vertex list."""
    order = np.lexsort((pts[:, 1], pts[:, 0]))
    p = [(float(x), float(y)) for x, y in pts[order]]

    def half(seq):
        out: list[tuple[float, float]] = []
        for pt in seq:
            while len(out) >= 2:
                (ax, ay), (bx, by) = out[-2], out[-1]
                if (bx - ax) * (pt[1] - ay) - (by - ay) * (pt[0] - ax) > 0:
                    break
                out.pop()
            out.append(pt)
        return out

    lower, upper = half(p), half(reversed(p))
    hull = lower[:-1] + upper[:-1]
    return hull if len(hull) >= 3 else [*p[:1], *p[-1:], *p[:1]]


def _scalar(name: str, value, fmt: str) -> str:
    return fmt.format(check.number(name, value))

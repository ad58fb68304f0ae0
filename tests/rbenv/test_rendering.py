"""Tests for rbenv.envs.rendering: frame shape and content, determinism, input checks, video
files."""

from __future__ import annotations

import gc
import sys

import numpy as np
import pytest

pytest.importorskip("pygame")

from rbenv.core import inertia, quaternion

from rbenv.envs.rendering import Renderer, equivalent_box, save_video

MASS = 24.0
HALF = np.array([0.113, 0.17, 0.183])


def cubesat_thrusters() -> tuple[np.ndarray, np.ndarray]:
    """Twelve thrusters on the faces of the box, in pairs that make torques about each axis."""
    pos, dirs = [], []
    for k in range(3):
        for s in (-1.0, 1.0):
            for t in (-1.0, 1.0):
                p, d = np.zeros(3), np.zeros(3)
                p[k], p[(k + 1) % 3] = s * HALF[k], t * 0.8 * HALF[(k + 1) % 3]
                d[(k + 2) % 3] = s * t
                pos.append(p)
                dirs.append(d)
    return np.array(pos), np.array(dirs)


def make_renderer(width=200, height=160, inertia_B=None, **kwargs) -> Renderer:
    pos, dirs = cubesat_thrusters()
    I = inertia.solid_box(MASS, 2 * HALF) if inertia_B is None else inertia_B
    return Renderer(I, MASS, pos, dirs, width, height, **kwargs)


Q0 = quaternion.from_axis_angle([0.3, 1.0, 0.2], 0.5)
QT = quaternion.from_axis_angle([1.0, 0.0, 0.0], 0.9)


def changed_fraction(a: np.ndarray, b: np.ndarray) -> float:
    """Fraction of pixels whose colour differs noticeably between frames a and b."""
    return float((np.abs(a.astype(int) - b.astype(int)).max(axis=-1) > 24).mean())


@pytest.fixture(scope="module")
def renderer() -> Renderer:
    return make_renderer()


@pytest.mark.parametrize(("width", "height"), [(200, 160), (120, 240), (33, 17)])
def test_frame_shape_and_dtype(width, height):
    r = make_renderer(width, height)
    f = r.frame(Q0, QT, np.full(12, 0.5), 12.0, 1.5, 3.0)
    assert f.shape == (height, width, 3)
    assert f.dtype == np.uint8
    assert f.flags.writeable and f.flags.c_contiguous


def test_frame_is_not_blank(renderer):
    f = renderer.frame(Q0, QT, np.zeros(12), 0.0, 0.0, 0.0)
    assert f.std() > 10  # box, axes and background, not a flat fill


def test_attitude_changes_pixels(renderer):
    a = renderer.frame(Q0, QT, np.zeros(12), 10.0, 1.0, 2.0)
    b = renderer.frame(quaternion.from_axis_angle([0, 0, 1], 1.0), QT, np.zeros(12), 10.0, 1.0, 2.0)
    assert changed_fraction(a, b) > 0.05


def test_firing_thruster_draws_a_plume(renderer):
    off = renderer.frame(Q0, QT, np.zeros(12), 10.0, 1.0, 2.0)
    # Every thruster shows when it fires, also those behind the box (outlined over it).
    for i in range(12):
        thr = np.zeros(12)
        thr[i] = 1.0
        assert changed_fraction(off, renderer.frame(Q0, QT, thr, 10.0, 1.0, 2.0)) > 0.001, i

    def orange(f):  # plume colours: red > green > blue (the red x axis has little green)
        r, g, b = np.moveaxis(f.astype(int), -1, 0)
        return int(((r > 120) & (g > 80) & (r - b > 60) & (g - b > 30)).sum())

    def firing(i, level):
        thr = np.zeros(12)
        thr[i] = level
        return renderer.frame(Q0, QT, thr, 10.0, 1.0, 2.0)

    # Thruster 3 sits on a face turned to the camera: its plume is drawn in full.
    assert orange(firing(3, 1.0)) > orange(off) + 50
    assert orange(off) < orange(firing(3, 0.3)) < orange(firing(3, 1.0))  # scales with throttle
    assert changed_fraction(off, firing(3, 0.3)) < changed_fraction(off, firing(3, 1.0))


def test_target_axes_appear(renderer):
    aligned = renderer.frame(Q0, Q0, np.zeros(12), 0.0, 0.0, 0.0)
    apart = renderer.frame(Q0, QT, np.zeros(12), 0.0, 0.0, 0.0)
    none = renderer.frame(Q0, None, np.zeros(12), 0.0, 0.0, 0.0)
    assert changed_fraction(aligned, apart) > 0.002
    assert changed_fraction(none, apart) > 0.002
    # Aligned ghost axes hide under the body axes; only their tip rings remain.
    assert changed_fraction(none, aligned) < changed_fraction(none, apart)


def test_text_overlay_changes_with_values(renderer):
    a = renderer.frame(Q0, QT, np.zeros(12), 10.0, 1.0, 2.0)
    b = renderer.frame(Q0, QT, np.zeros(12), 99.0, 1.0, 2.0)
    assert not np.array_equal(a, b)


def test_frames_are_deterministic():
    thr = np.linspace(0, 1, 12)
    r1, r2 = make_renderer(), make_renderer()
    a = r1.frame(Q0, QT, thr, 3.0, 2.0, 1.0)
    r1.frame(QT, Q0, thr[::-1], 1.0, 1.0, 1.0)  # no state carried between frames
    assert np.array_equal(a, r1.frame(Q0, QT, thr, 3.0, 2.0, 1.0))
    assert np.array_equal(a, r2.frame(Q0, QT, thr, 3.0, 2.0, 1.0))


def test_quaternion_sign_and_scale_do_not_matter(renderer):
    a = renderer.frame(Q0, QT, np.zeros(12), 1.0, 1.0, 1.0)
    b = renderer.frame(-3.0 * Q0, 0.5 * QT, np.zeros(12), 1.0, 1.0, 1.0)
    assert changed_fraction(a, b) == 0.0


def test_equivalent_box_of_a_solid_box_is_the_box():
    size = np.array([0.2, 0.5, 0.3])
    half, R = equivalent_box(inertia.solid_box(5.0, size), 5.0)
    # half[i] is half the extent along principal axis i, which is one of the body axes.
    order = np.argmax(np.abs(R), axis=0)
    np.testing.assert_allclose(half, size[order] / 2, rtol=1e-12)


def test_non_diagonal_inertia():
    size = np.array([0.1, 0.2, 0.6])
    R = quaternion.to_matrix(quaternion.from_axis_angle([1.0, 2.0, 3.0], 0.7))
    I_rot = R @ inertia.solid_box(10.0, size) @ R.T
    half, R_p = equivalent_box(I_rot, 10.0)
    np.testing.assert_allclose(np.sort(half), np.sort(size) / 2, rtol=1e-9)
    # Each box axis is one of the rotated body axes.
    np.testing.assert_allclose(np.abs(R.T @ R_p).max(axis=0), 1.0, atol=1e-9)
    r = make_renderer(160, 120, inertia_B=I_rot)
    f = r.frame(Q0, QT, np.ones(12), 5.0, 1.0, 1.0)
    assert f.shape == (120, 160, 3)
    g = make_renderer(160, 120, inertia_B=inertia.solid_box(10.0, size))
    assert changed_fraction(f, g.frame(Q0, QT, np.ones(12), 5.0, 1.0, 1.0)) > 0.01


def test_no_thrusters_and_no_overlay():
    r = Renderer(inertia.solid_sphere(3.0, 0.2), 3.0, np.zeros((0, 3)), np.zeros((0, 3)), 64, 48)
    f = r.frame([1, 0, 0, 0])
    assert f.shape == (48, 64, 3)


def test_supersample_one_works():
    f = make_renderer(supersample=1).frame(Q0, QT, np.ones(12), 1.0, 1.0, 1.0)
    assert f.shape == (160, 200, 3)


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"q": [1.0, 0.0, 0.0]}, "q"),
        ({"q": [0.0, 0.0, 0.0, 0.0]}, "q"),
        ({"q": [1.0, np.nan, 0.0, 0.0]}, "q"),
        ({"q_target": np.eye(4)}, "q_target"),
        ({"throttle": np.zeros(11)}, "throttle"),
        ({"throttle": np.full(12, 1.5)}, "throttle"),
        ({"throttle": -np.ones(12)}, "throttle"),
        ({"error_deg": "big"}, "error_deg"),
        ({"rate_dps": [1.0, 2.0]}, "rate_dps"),
        ({"time_s": object()}, "time_s"),
    ],
)
def test_bad_frame_inputs_name_the_argument(renderer, kwargs, name):
    args = {"q": Q0, "q_target": QT, "throttle": np.zeros(12), "error_deg": 1.0,
            "rate_dps": 1.0, "time_s": 1.0}
    args.update(kwargs)
    with pytest.raises(ValueError, match=name):
        renderer.frame(**args)


@pytest.mark.parametrize(
    ("change", "name"),
    [
        ({"inertia": np.eye(2)}, "inertia"),
        ({"inertia": np.diag([1.0, 1.0, 3.0])}, "inertia"),  # breaks the triangle inequality
        ({"mass": 0.0}, "mass"),
        ({"thruster_positions_B": np.zeros((12, 2))}, "thruster_positions_B"),
        ({"thruster_directions_B": np.zeros((11, 3))}, "thruster_directions_B"),
        ({"thruster_directions_B": np.zeros((12, 3))}, "thruster_directions_B"),
        ({"width": 0}, "width"),
        ({"height": 2.5}, "height"),
        ({"supersample": 0}, "supersample"),
    ],
)
def test_bad_constructor_inputs_name_the_argument(change, name):
    pos, dirs = cubesat_thrusters()
    args = {"inertia": inertia.solid_box(MASS, 2 * HALF), "mass": MASS,
            "thruster_positions_B": pos, "thruster_directions_B": dirs, "width": 64, "height": 64}
    args.update(change)
    with pytest.raises(ValueError, match=name):
        Renderer(**args)


def test_save_video_gif_round_trip(renderer, tmp_path):
    iio = pytest.importorskip("imageio.v3")
    angles = np.linspace(0.0, 1.0, 6)
    frames = [renderer.frame(quaternion.from_axis_angle([0, 0, 1], a), QT, np.zeros(12), 0.0,
                             0.0, float(a)) for a in angles]
    path = save_video(frames, tmp_path / "sub" / "episode.gif", fps=5)
    assert path == tmp_path / "sub" / "episode.gif"
    back = iio.imread(path, index=None)
    assert back.shape[:3] == (6, 160, 200)
    assert iio.immeta(path)["duration"] == 200  # ms per frame at 5 fps
    # GIF quantises colours; the picture must survive.
    assert np.abs(back[3, ..., :3].astype(int) - frames[3]).mean() < 8


def test_save_video_mp4_without_ffmpeg_suggests_gif(renderer, tmp_path, monkeypatch):
    pytest.importorskip("imageio.v3")
    monkeypatch.setitem(sys.modules, "imageio_ffmpeg", None)  # makes the import fail
    frame = renderer.frame(Q0)
    with pytest.raises(ImportError, match=r"imageio-ffmpeg.*\.gif"):
        save_video([frame, frame], tmp_path / "episode.mp4")


# imageio's FFMPEG plugin leaves its ffmpeg pipes for the garbage collector to close; the
# test collects them itself, so that no later test meets them.
@pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")
@pytest.mark.filterwarnings("ignore:unclosed file:ResourceWarning")
def test_save_video_mp4(renderer, tmp_path):
    pytest.importorskip("imageio_ffmpeg")
    iio = pytest.importorskip("imageio.v3")
    frames = [renderer.frame(quaternion.from_axis_angle([0, 0, 1], a)) for a in (0.0, 0.5, 1.0)]
    path = save_video([f[:-1, :-1] for f in frames], tmp_path / "episode.mp4", fps=10)
    assert len(iio.imread(path, plugin="FFMPEG", index=None)) == 3
    gc.collect()


@pytest.mark.parametrize(
    ("frames", "path", "fps", "name"),
    [
        ([], "a.gif", 10, "frames"),
        ([np.zeros((4, 4, 3), np.float32)], "a.gif", 10, "frames"),
        ([np.zeros((4, 4, 3), np.uint8), np.zeros((4, 5, 3), np.uint8)], "a.gif", 10,
         r"frames\[1\]"),
        ([np.zeros((4, 4), np.uint8)], "a.gif", 10, "frames"),
        ([np.zeros((4, 4, 3), np.uint8)], "a.avi", 10, "path"),
        ([np.zeros((4, 4, 3), np.uint8)], "a.gif", 0, "fps"),
    ],
)
def test_save_video_bad_inputs(tmp_path, frames, path, fps, name):
    with pytest.raises(ValueError, match=name):
        save_video(frames, tmp_path / path, fps=fps)


def test_show_and_close_with_dummy_display(monkeypatch):
    import pygame

    monkeypatch.setenv("SDL_VIDEODRIVER", "dummy")
    r = make_renderer(64, 48)
    frame = r.frame(Q0, QT)
    try:
        r.show(frame)
        r.show(frame)
        assert pygame.display.get_surface().get_size() == (64, 48)
        with pytest.raises(ValueError, match="frame"):
            r.show(frame[..., 0])
    finally:
        r.close()
    assert not pygame.display.get_init()
    r.frame(Q0)  # still renders after the window is gone


def test_missing_pygame_gives_install_hint(monkeypatch):
    monkeypatch.setitem(sys.modules, "pygame", None)
    pos, dirs = cubesat_thrusters()
    with pytest.raises(ImportError, match=r"rbenv\[render\]"):
        Renderer(inertia.solid_box(MASS, 2 * HALF), MASS, pos, dirs)

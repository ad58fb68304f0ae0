"""``render_mode="human"`` under a real X server: Xvfb, started here on a free display.

The env runs in a child process with SDL's real (x11) video driver, steps a few times, and takes
a screenshot of the X screen with Pillow's ``ImageGrab`` (which talks to the X server through
XCB, independently of pygame). The window must show exactly the frame that
``render_mode="rgb_array"`` draws for the same seed and actions, and the screen must be blank
again once the env is closed.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import textwrap

import numpy as np
import pytest

pytest.importorskip("pygame", reason="pygame-ce is not installed (render extra)")
pytest.importorskip("PIL.ImageGrab", reason="Pillow is not installed")

SCREEN = (800, 600)

CHILD = textwrap.dedent("""
    import sys
    import gymnasium as gym
    import numpy as np
    import pygame
    from PIL import ImageGrab

    import rbenv

    display, out = sys.argv[1], sys.argv[2]
    human = gym.make(rbenv.ENV_ID, render_mode="human")
    ref = gym.make(rbenv.ENV_ID, render_mode="rgb_array")
    human.reset(seed=0)
    ref.reset(seed=0)
    action = np.linspace(-1, 1, human.action_space.shape[0]).astype(np.float32)
    for _ in range(3):
        human.step(action)
        ref.step(action)
    assert human.render() is None
    driver = pygame.display.get_driver()
    shot_open = np.asarray(ImageGrab.grab(xdisplay=display))
    human.close()
    shot_closed = np.asarray(ImageGrab.grab(xdisplay=display))
    np.savez(out, frame=ref.render(), shot_open=shot_open, shot_closed=shot_closed,
             driver=driver)
""")


@pytest.fixture
def xvfb():
    """A fresh Xvfb on a display number it picks itself (``-displayfd``); yields ':N'.

    ``-noreset``: by default Xvfb resets itself when its last client disconnects, and a client
    that connects during the reset is refused. The child closes the env's window (the last
    client) and then connects again for a screenshot, so the server must not reset.
    """
    exe = shutil.which("Xvfb")
    if exe is None:
        pytest.skip("Xvfb is not installed (Debian package xvfb; .ci/run installs it as root)")
    proc = subprocess.Popen(
        [exe, "-displayfd", "1", "-screen", "0", f"{SCREEN[0]}x{SCREEN[1]}x24", "-br",
         "-noreset", "-nolisten", "tcp"],
        stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    try:
        number = proc.stdout.readline().strip()
        if not number.isdigit():
            pytest.skip(f"Xvfb did not start (printed {number!r})")
        yield f":{number}"
    finally:
        proc.terminate()
        proc.wait(timeout=30)
        proc.stdout.close()  # the -displayfd pipe (an unclosed pipe warns, and warnings fail)


def test_human_window_shows_the_rgb_array_frame(xvfb, tmp_path):
    env = {k: v for k, v in os.environ.items() if k != "SDL_VIDEODRIVER"}
    env["DISPLAY"] = xvfb
    out = tmp_path / "shots.npz"
    subprocess.run([sys.executable, "-c", CHILD, xvfb, str(out)], env=env, check=True,
                   timeout=300, cwd=tmp_path)
    data = np.load(out)
    frame, shot = data["frame"], data["shot_open"]
    assert str(data["driver"]) == "x11"
    assert shot.shape == (SCREEN[1], SCREEN[0], 3)

    # Not a blank frame: a drawn scene with many colours.
    assert shot.std() > 10
    assert len(np.unique(shot.reshape(-1, 3), axis=0)) > 100

    # The window holds exactly the rgb_array frame (SDL centres it; find it by its extent).
    lit = np.argwhere(shot.any(axis=2))
    (y0, x0), (y1, x1) = lit.min(axis=0), lit.max(axis=0) + 1
    assert (y1 - y0, x1 - x0) == frame.shape[:2]
    np.testing.assert_array_equal(shot[y0:y1, x0:x1], frame)

    # Closing the env closes the window: the screen is back to Xvfb's black background.
    assert not data["shot_closed"].any()

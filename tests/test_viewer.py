"""``mjchar run --view``: MuJoCo's passive viewer follows the run in real time on a display
(here a virtual one, Xvfb: a screenshot of it, saved with the test's files, shows the humanoid),
and without a display the command fails in one line before simulating anything."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

BIN = Path(sys.executable).parent


def _env(**change) -> dict:
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY",
                                                             "MUJOCO_GL")}
    env["PATH"] = f"{BIN}{os.pathsep}{env.get('PATH', '')}"
    env.update(change)
    return env


def test_view_without_a_display_is_a_one_line_error(tmp_path):
    r = subprocess.run(["mjchar", "run", "static_balance", "--view", "--duration", "1"],
                       cwd=tmp_path, env=_env(), capture_output=True, text=True, timeout=300)
    assert r.returncode == 2, r.stderr
    assert r.stderr.count("\n") == 1, r.stderr
    assert r.stderr.startswith("mjchar run: error: --view needs a display"), r.stderr
    assert r.stdout == ""


@pytest.fixture
def display():
    """A virtual X display (Xvfb), its name."""
    if shutil.which("Xvfb") is None:
        pytest.skip("the viewer test needs a virtual display: install Xvfb "
                    "(apt-get install xvfb) and run it again")
    read, write = os.pipe()
    xvfb = subprocess.Popen(["Xvfb", "-displayfd", str(write), "-screen", "0", "1024x768x24",
                             "-nolisten", "tcp"], pass_fds=(write,),
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    os.close(write)
    with os.fdopen(read) as f:
        number = f.readline().strip()
    try:
        yield f":{number}"
    finally:
        xvfb.terminate()
        xvfb.wait(timeout=30)


def _screenshot(display: str, path: Path) -> np.ndarray | None:
    """The display's screen as an (H, W, 3) array (saved as ``path``), or None."""
    import imageio.v3 as iio
    import imageio_ffmpeg

    r = subprocess.run([imageio_ffmpeg.get_ffmpeg_exe(), "-loglevel", "error", "-y", "-f",
                        "x11grab", "-i", display, "-frames:v", "1", str(path)],
                       capture_output=True, timeout=60)
    return iio.imread(path)[..., :3] if r.returncode == 0 and path.is_file() else None


def _humanoid_pixels(image: np.ndarray) -> int:
    """Pixels of the bundled humanoid's brown (red above green above blue, not the grey-blue
    floor)."""
    r, g, b = (image[..., i].astype(int) for i in range(3))
    return int(np.count_nonzero((r > 90) & (r - g > 25) & (g - b > 15)))


def test_view_opens_mujocos_viewer_following_the_run(display, tmp_path):
    pytest.importorskip("imageio_ffmpeg", reason="the screenshot needs the video extra")
    duration = 8.0
    run = subprocess.Popen(["mjchar", "run", "static_balance", "--view", "--duration",
                            str(duration)], cwd=tmp_path, env=_env(DISPLAY=display),
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    shot, grab, found = tmp_path / "viewer.png", tmp_path / "grab.png", 0
    try:
        deadline = time.monotonic() + 600
        while run.poll() is None and time.monotonic() < deadline:  # the last view of it
            time.sleep(1.5)
            image = _screenshot(display, grab)
            if image is not None and _humanoid_pixels(image) > 500:
                found = _humanoid_pixels(image)
                grab.replace(shot)
        out, err = run.communicate(timeout=600)
    finally:
        if run.poll() is None:
            run.kill()
    print(f"screenshot of the viewer: {shot}")
    assert run.returncode == 0, err
    assert found, f"no humanoid on the screen (last screenshot: {shot})"
    assert f"no fall in {duration:g} s" in out, out
    wall = float(out.split(" s wall")[0].rsplit(" in ", 1)[1])
    assert wall >= duration * 0.95, out  # paced to real time, not faster

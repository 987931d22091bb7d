"""The recordings the guide makes, as a user first sees them.

``opening`` reads what a recording shows the moment it opens from its blueprint and data: the
time panel (paused: the viewer would otherwise play a timeline from its start at 1x), and
for every view the entities with data at that moment. Every view must show data of its own
(not only the machine). The slow test opens each recording in the real viewer (Rerun's web
viewer in headless Chromium, software rendering) and checks that the picture holds data:
pixels in colours that the machine alone, opened in the same viewer, never shows.
"""

from __future__ import annotations

import importlib.util
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
spec = importlib.util.spec_from_file_location("_docs_ext_viewer", ROOT / "docs" / "_ext" / "viewer.py")
viewer = importlib.util.module_from_spec(spec)
spec.loader.exec_module(viewer)

FAST = ["demo", "bare_urdf", "export", "gear", "predict"]
SLOW = [name for name in viewer.RECORDINGS if name not in FAST]


def _check_opening(name: str, rrd: Path) -> dict:
    seen = viewer.opening(rrd)
    assert seen["play_state"] == "paused", name
    for view in seen["views"]:
        own = [e for e in view["shown"] if not e.startswith("/machine")]
        assert own, f"{name}: the view '{view['name']}' opens with nothing of its own to show"
    return seen


@pytest.mark.parametrize("name", FAST)
def test_each_view_has_data_when_the_recording_opens(name, tmp_path):
    _check_opening(name, viewer.make(name, tmp_path))


@pytest.mark.slow
@pytest.mark.parametrize("name", SLOW)
def test_each_view_has_data_when_the_slower_recordings_open(name, tmp_path):
    seen = _check_opening(name, viewer.make(name, tmp_path))
    if name == "lathe_cold_start":
        assert seen["timeline"] == "time"
        series = [v for v in seen["views"] if v["kind"] == "TimeSeries"]
        assert series and all(v["shown"] for v in series)


def test_the_check_sees_an_empty_view_and_a_playing_recording(tmp_path):
    """The check can fail: a view whose origin holds no data, and a recording left to play."""
    import rerun as rr
    import rerun.blueprint as rrb

    import volerr_pin as vp
    from volerr_pin.model import default_config
    from volerr_pin.viz import log_machine, new_recording, streaming

    machine = vp.load_machine("vmc500")
    path = tmp_path / "bare.rrd"
    blueprint = rrb.Blueprint(rrb.Horizontal(rrb.Spatial3DView(origin="/", contents=["machine/**", "field/**"],
                                                               name="machine, no field"),
                                             rrb.TextDocumentView(origin="notes", name="notes")))
    rec = new_recording()
    with streaming(rec, path, blueprint):
        log_machine(rec, machine, default_config(machine))
        rec.set_time("step", sequence=3)
        rec.log("notes", rr.TextDocument("only at step 3"))
    seen = viewer.opening(path)
    assert seen["play_state"] is None
    by_name = {v["name"]: v for v in seen["views"]}
    assert by_name["machine, no field"]["shown"] and all(e.startswith("/machine")
                                                         for e in by_name["machine, no field"]["shown"])
    assert by_name["notes"]["shown"] == []   # no timeline chosen: data at step 3 does not show
    with pytest.raises(AssertionError):
        _check_opening("bare", path)


def _colours(png: Path) -> tuple[np.ndarray, np.ndarray]:
    """Each pixel's colour (8 levels per channel, as one integer) and its chroma (0-255)."""
    from matplotlib.image import imread

    rgb = (imread(png)[..., :3].reshape(-1, 3) * 255).astype(int)
    quantised = rgb // 8
    return quantised[:, 0] * 1024 + quantised[:, 1] * 32 + quantised[:, 2], rgb.max(axis=1) - rgb.min(axis=1)


def _data_pixels(png: Path, control: set[int]) -> int:
    """Pixels in colours the machine alone never shows (and not grey): the data. The viewer's
    chrome, grid, highlights and the machine are in the control's colours; the data, coloured
    by value and shaded in 3D, are not."""
    colour, chroma = _colours(png)
    return int(np.sum((chroma > 30) & ~np.isin(colour, list(control))))


def _needs_browser():
    if viewer.chromium() is None:
        pytest.skip("no Chromium (Debian's chromium; VOLERR_CHROMIUM names another)")
    pytest.importorskip("playwright")
    if shutil.which("rerun", path=str(Path(sys.executable).parent)) is None and shutil.which("rerun") is None:
        pytest.skip("no rerun command")


def _machine_alone_screenshot(folder: Path) -> Path:
    """vmc500 alone, without data, opened in the viewer: its screenshot."""
    import rerun.blueprint as rrb

    import volerr_pin as vp
    from volerr_pin.model import default_config
    from volerr_pin.viz import log_machine, new_recording, streaming

    machine = vp.load_machine("vmc500")
    path, shot = folder / "machine.rrd", folder / "machine.png"
    rec = new_recording()
    with streaming(rec, path, rrb.Blueprint(rrb.Spatial3DView(origin="/", name="the machine alone"))):
        log_machine(rec, machine, default_config(machine))
    viewer.screenshot(path, shot)
    return shot


@pytest.fixture(scope="module")
def machine_alone(tmp_path_factory) -> tuple[set[int], int]:
    """The control: vmc500 alone, without data, in the viewer. Its colours (each seen on 3 pixels
    or more), and how many of its own pixels are in rarer colours (the noise of the check)."""
    _needs_browser()
    shot = _machine_alone_screenshot(tmp_path_factory.mktemp("machine_alone"))
    colour, chroma = _colours(shot)
    values, counts = np.unique(colour[chroma > 30], return_counts=True)
    control = set(values[counts >= 3].tolist())
    return control, _data_pixels(shot, control)


def _enough(pixels: int, control) -> bool:
    """Ten times the control's own noise, and at least 300 pixels (a few dots' worth)."""
    return pixels > max(300, 10 * control[1])


@pytest.mark.slow
@pytest.mark.parametrize("name", list(viewer.RECORDINGS))
def test_the_viewer_opens_on_the_data(name, tmp_path, machine_alone):
    """In the real viewer, each recording opens on a picture with its data: pixels in colours
    the machine alone never shows, as the guide's screenshot of it shows (the screenshot is
    committed and linked from the guide)."""
    shot = tmp_path / f"{name}.png"
    viewer.screenshot(viewer.make(name, tmp_path), shot)
    pixels = _data_pixels(shot, machine_alone[0])
    assert _enough(pixels, machine_alone), (name, pixels, machine_alone[1])
    committed = ROOT / "docs" / "images" / "recordings" / f"{name}.png"
    assert committed.exists(), f"redraw the guide's screenshots: python docs/_ext/viewer.py {name}"
    pages = " ".join(p.read_text() for p in (ROOT / "docs" / "guide").glob("*.md"))
    assert f"images/recordings/{name}.png" in pages, f"no guide page shows the recording {name}"


@pytest.mark.slow
def test_the_committed_screenshots_pass_the_check(machine_alone):
    """The guide's screenshots, taken by ``python docs/_ext/viewer.py``, hold their data too."""
    for name in viewer.RECORDINGS:
        pixels = _data_pixels(ROOT / "docs" / "images" / "recordings" / f"{name}.png", machine_alone[0])
        assert _enough(pixels, machine_alone), (name, pixels)


@pytest.mark.slow
def test_the_check_fails_on_the_machine_alone(machine_alone, tmp_path):
    """The check can fail: a second screenshot of the machine alone is not taken for data."""
    assert not _enough(_data_pixels(_machine_alone_screenshot(tmp_path), machine_alone[0]), machine_alone)

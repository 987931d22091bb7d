"""Open Rerun recordings in the real Rerun viewer, as a user first sees them: the viewer's web
build (served by ``rerun --serve-web``, which comes with rerun-sdk) in headless Chromium with
software rendering (SwiftShader), driven by Playwright; a screenshot once the picture is still.

Used by the slow test that opens every recording the guide makes, and to redraw the guide's
pictures of the recordings::

    python docs/_ext/viewer.py            # every recording of RECORDINGS into docs/images/recordings/
    python docs/_ext/viewer.py demo gear  # some of them

Needs Chromium (Debian's ``chromium``; ``VOLERR_CHROMIUM`` names another) and Playwright
(``pip install playwright``; it drives the system's browser and downloads none).
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from urllib.parse import quote

ROOT = Path(__file__).resolve().parents[2]
OUT = ROOT / "docs" / "images" / "recordings"

#: the recordings the guide makes: name -> (the commands, run in a scratch folder with
#: ``examples/`` beside them; the recording they write)
RECORDINGS: dict[str, tuple[list[list[str]], str]] = {
    "demo": ([["volerr", "demo", "--grid", "7", "--out", "demo.rrd"]], "demo.rrd"),
    "field_cgm4000": ([["volerr", "field", "cgm4000", "--out", "cgm4000.rrd", "--grid", "7", "7", "7",
                        "--sweep-steps", "12"]], "cgm4000.rrd"),
    "bare_urdf": ([["volerr", "demo", "--machine", "examples/data/two_link_arm.urdf", "--tool-frame", "tool0",
                    "--workpiece-frame", "world", "--out", "arm.rrd"]], "arm.rrd"),
    "diagnose": ([["volerr", "diagnose", "vmc500", "examples/data/vmc500_tracker.csv", "--sigma-um", "0.3",
                   "--rrd", "diagnose.rrd"]], "diagnose.rrd"),
    "export": ([["volerr", "export", "vmc500", "--controller", "linuxcnc", "-o", "comp", "--rrd", "comp.rrd"]],
               "comp.rrd"),
    "lathe_cold_start": ([[sys.executable, "examples/lathe_cold_start.py", "lathe_cold_start.rrd"]],
                         "lathe_cold_start.rrd"),
    "gear": ([["volerr", "gear", "gear_roller", "--rrd", "gear_flanks.rrd"]], "gear_flanks.rrd"),
    "predict": ([["volerr", "predict", "vmc500", "examples/data/vmc500_testpiece.nc", "--rrd", "part.rrd"]], "part.rrd"),
    "predict_cone": ([["volerr", "predict", "cgm4000", "examples/data/cgm4000_cone.nc", "--tool-diameter", "20",
                       "--cone-heights", "2,10,18", "--rrd", "cone.rrd"]], "cone.rrd"),
    "uncertainty": ([["volerr", "uncertainty", "vmc500", "--instrument-sigma", "1", "--samples", "200", "--compensation", "point",
                      "--grid", "5", "--workers", "0", "--rrd", "uncertainty.rrd"]], "uncertainty.rrd"),
}

CHROMIUM_ARGS = ["--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--ignore-gpu-blocklist",
                 "--disable-background-networking", "--disable-component-update", "--disable-sync",
                 "--no-first-run"]


#: Rerun's PlayState values, by name
PLAY_STATES = {1: "paused", 2: "playing", 3: "following"}


def _matches(pattern: str, entity: str) -> bool:
    """Does a view's content pattern (``/a/**``, ``/a``) take the entity path?"""
    if pattern.endswith("/**"):
        stem = pattern[:-3]
        return entity == stem or entity.startswith(stem + "/") or stem == ""
    return entity == pattern


def _query(origin: str, expressions: list[str]) -> tuple[list[str], list[str]]:
    """A view's contents as (taken, left out) absolute patterns."""
    taken, left = [], []
    origin = "/" + origin.strip("/") if origin.strip("/") else ""
    for expression in expressions:
        sign, _, body = expression.strip().partition(" ") if expression.strip()[:1] in "+-" else ("+", "", expression)
        body = body.strip().replace("$origin", origin)
        body = "/" + body.lstrip("/")
        (left if sign == "-" else taken).append(body.rstrip("/") if body != "/**" else "/**")
    return taken, left


def opening(rrd: Path) -> dict:
    """What a recording shows the moment it opens, read from its blueprint and its data.

    Returns
    -------
    dict
        ``play_state`` (``paused``, ``playing``, ``following`` or None: the viewer's default,
        which plays), ``timeline`` (the time panel's, or None) and ``views``: per view its
        ``name``, ``kind`` (``3D``, ``2D``, ``TimeSeries``, ``TextDocument`` ...), ``origin``
        and ``shown``, the entities it takes that hold data when the recording opens: static
        data, or data at the start of the opening timeline (a paused recording opens with its
        cursor there), or, for a time series view, any data on that timeline.
    """
    import rerun as rr

    reader = rr.chunk.RrdReader(str(rrd))
    (store,) = reader.blueprints()
    views, contents, play, timeline = {}, {}, None, None
    for chunk in reader.stream(store=store):
        batch = chunk.to_record_batch()
        row = {name: batch.column(name).to_pylist()[-1] for name in batch.schema.names}
        path = chunk.entity_path
        if path == "/time_panel":
            play = PLAY_STATES.get((row.get("TimePanelBlueprint:play_state") or [None])[0], play)
            timeline = (row.get("TimePanelBlueprint:timeline") or [timeline])[0]
        elif path.startswith("/view/") and path.endswith("/ViewContents"):
            contents[path.rsplit("/", 1)[0]] = row["ViewContents:query"]
        elif path.startswith("/view/") and "ViewBlueprint:class_identifier" in row:
            views[path] = {"name": row["ViewBlueprint:display_name"][0], "kind": row["ViewBlueprint:class_identifier"][0],
                           "origin": row["ViewBlueprint:space_origin"][0]}
    start: dict[str, int] = {}
    timelines: dict[str, dict[str, list[int]]] = {}
    static: set[str] = set()
    for chunk in reader.stream():
        if chunk.is_static:
            static.add(chunk.entity_path)
            continue
        batch = chunk.to_record_batch()
        for name in chunk.timeline_names:
            values = [v for v in batch.column(name).cast("int64").to_pylist() if v is not None]
            if values:
                timelines.setdefault(chunk.entity_path, {}).setdefault(name, []).extend(values)
                start[name] = min(start.get(name, min(values)), min(values))
    for key, view in views.items():
        taken, left = _query(view["origin"], contents.get(key, ["$origin/**"]))
        entities = static | set(timelines)
        chosen = [e for e in entities if any(_matches(p, e) for p in taken) and not any(_matches(p, e) for p in left)]

        def shows(entity):
            if entity in static:
                return True
            times = timelines.get(entity, {}).get(timeline) if timeline else None
            if not times:
                return False
            return view["kind"] == "TimeSeries" or min(times) <= start[timeline]

        view["shown"] = sorted(e for e in chosen if shows(e))
    return {"play_state": play, "timeline": timeline, "views": list(views.values())}


def chromium() -> str | None:
    """The browser to drive, or None."""
    return os.environ.get("VOLERR_CHROMIUM") or shutil.which("chromium") or shutil.which("chromium-browser")


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@contextlib.contextmanager
def served(rrd: Path):
    """``rerun --serve-web`` on the recording, on free local ports: yields the viewer's URL."""
    grpc, web = _free_port(), _free_port()
    rerun = shutil.which("rerun", path=str(Path(sys.executable).parent)) or shutil.which("rerun")
    env = dict(os.environ, RERUN_ANALYTICS="0")   # no usage data sent from tests
    # a session of its own: the rerun command is a launcher whose server is its child, and the
    # whole group goes at the end
    proc = subprocess.Popen([rerun, "--serve-web", "--bind", "127.0.0.1", "--port", str(grpc),
                             "--web-viewer-port", str(web), str(rrd)], env=env, start_new_session=True,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            with contextlib.suppress(OSError), socket.create_connection(("127.0.0.1", web), timeout=1):
                break
            if proc.poll() is not None:
                raise RuntimeError(f"rerun --serve-web {rrd} exited with {proc.returncode}")
            time.sleep(0.2)
        else:
            raise RuntimeError(f"rerun --serve-web {rrd}: no web viewer after 60 s")
        yield f"http://127.0.0.1:{web}/?url={quote(f'rerun+http://127.0.0.1:{grpc}/proxy', safe='')}"
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGTERM)
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()


def screenshot(rrd: Path, png: Path, size=(1600, 1000), settle: float = 4.0, timeout: float = 120.0) -> float:
    """Open ``rrd`` in the viewer and write what it shows to ``png`` once the picture has not
    changed for ``settle`` seconds (the viewer has loaded the data and drawn its first view).
    Returns the seconds it took."""
    from playwright.sync_api import sync_playwright

    start = time.monotonic()
    with served(rrd) as url, sync_playwright() as p:
        browser = p.chromium.launch(executable_path=chromium(), headless=True, args=CHROMIUM_ARGS)
        try:
            page = browser.new_page(viewport={"width": size[0], "height": size[1]})
            page.goto(url)
            last, since = None, time.monotonic()
            while time.monotonic() - start < timeout:
                page.wait_for_timeout(1000)
                shot = page.screenshot()
                digest = hashlib.sha256(shot).hexdigest()
                if digest != last:
                    last, since = digest, time.monotonic()
                elif time.monotonic() - since >= settle:
                    break
            else:
                raise RuntimeError(f"{rrd}: the viewer's picture did not settle in {timeout:.0f} s")
        finally:
            browser.close()
    png.parent.mkdir(parents=True, exist_ok=True)
    tmp = png.with_name(f".{png.name}.part")
    tmp.write_bytes(shot)
    tmp.replace(png)
    return time.monotonic() - start


def make(name: str, folder: Path) -> Path:
    """Run the guide's commands of recording ``name`` in ``folder``; the recording's path."""
    commands, rrd = RECORDINGS[name]
    examples = folder / "examples"
    if not examples.exists():
        examples.symlink_to(ROOT / "examples")
    env = dict(os.environ, MPLBACKEND="Agg", PATH=str(Path(sys.executable).parent) + os.pathsep + os.environ["PATH"])
    for command in commands:
        subprocess.run(command, cwd=folder, env=env, check=True, stdout=subprocess.DEVNULL)
    return folder / rrd


def main(names: list[str]) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        for name in names or RECORDINGS:
            took = screenshot(make(name, Path(tmp)), OUT / f"{name}.png")
            print(f"{OUT / f'{name}.png'} ({took:.0f} s)")


if __name__ == "__main__":
    main(sys.argv[1:])

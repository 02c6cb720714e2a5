"""Screenshots of a recording in Rerun's web viewer, in headless Chromium (no display, no GPU).

    .venv/bin/python scripts/screenshot_recording.py runs/demo/recording.rrd runs/demo/viewer.png
    .venv/bin/python scripts/screenshot_recording.py runs/demo runs/demo/viewer.png --shots 3 --interval 10

Not run in CI (it needs Chromium: ``apt-get install chromium`` on Debian). What it does:

1. ``rerun --serve-web FILE --web-viewer-port P --port G --bind 127.0.0.1`` (the ``rerun`` of this
   virtual environment): the web viewer over HTTP on port P and the recording over gRPC on port G;
2. ``chromium --headless=new --remote-debugging-port=D`` with WebGL on SwiftShader (software),
   driven over the DevTools protocol (the ``websockets`` package): open
   ``http://127.0.0.1:P/?url=rerun+http://127.0.0.1:G/proxy``, wait ``--wait`` seconds of real time
   (the viewer's WebAssembly loads and compiles in real time, so Chromium's
   ``--virtual-time-budget`` does not help: its screenshot shows "Loading Application Bundle"),
   then ``Page.captureScreenshot`` ``--shots`` times, ``--interval`` seconds apart (``name-1.png``,
   ``name-2.png`` … when more than one);
3. stop both processes it started, with their children (each runs in its own process group).

The viewer opens the recording at its end with the recording's default blueprint.
"""

from __future__ import annotations

import argparse
import base64
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
import urllib.request
from pathlib import Path
from urllib.parse import quote


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait_http(url: str, timeout_s: float) -> str:
    """The body of ``url`` once it answers (raises TimeoutError after ``timeout_s``)."""
    end = time.monotonic() + timeout_s
    while True:
        try:
            with urllib.request.urlopen(url, timeout=2) as r:
                return r.read().decode()
        except OSError:
            if time.monotonic() > end:
                raise TimeoutError(f"{url} did not answer within {timeout_s} s") from None
            time.sleep(0.3)


class DevTools:
    """A minimal Chrome DevTools protocol client over one page's websocket (an open connection)."""

    def __init__(self, ws):
        self.ws = ws
        self.next_id = 0

    def call(self, method: str, **params) -> dict:
        self.next_id += 1
        self.ws.send(json.dumps({"id": self.next_id, "method": method, "params": params}))
        while True:
            msg = json.loads(self.ws.recv(timeout=120))
            if msg.get("id") == self.next_id:
                if "error" in msg:
                    raise RuntimeError(f"{method}: {msg['error']}")
                return msg.get("result", {})


def screenshots(rrd: Path, out: Path, width: int, height: int, wait_s: float, shots: int, interval_s: float,
                chromium: str, rerun: str) -> list[Path]:
    web, grpc, debug = free_port(), free_port(), free_port()
    procs = []
    profile = tempfile.mkdtemp(prefix="mjasc-chromium-")
    try:
        procs.append(subprocess.Popen([rerun, "--serve-web", str(rrd), "--web-viewer-port", str(web),
                                       "--port", str(grpc), "--bind", "127.0.0.1"],
                                      stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True))
        wait_http(f"http://127.0.0.1:{web}/", 30)
        procs.append(subprocess.Popen([chromium, "--headless=new", "--no-sandbox", "--disable-dev-shm-usage",
                                       "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
                                       "--hide-scrollbars", f"--window-size={width},{height}",
                                       f"--remote-debugging-port={debug}", f"--user-data-dir={profile}",
                                       "about:blank"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                      start_new_session=True))
        wait_http(f"http://127.0.0.1:{debug}/json/version", 30)
        pages = [t for t in json.loads(wait_http(f"http://127.0.0.1:{debug}/json/list", 10)) if t["type"] == "page"]
        from websockets.sync.client import connect

        with connect(pages[0]["webSocketDebuggerUrl"], max_size=None, open_timeout=20) as ws:
            tools = DevTools(ws)
            tools.call("Page.enable")
            tools.call("Emulation.setDeviceMetricsOverride", width=width, height=height, deviceScaleFactor=1,
                       mobile=False)
            viewer = f"http://127.0.0.1:{web}/?url={quote(f'rerun+http://127.0.0.1:{grpc}/proxy', safe='')}"
            tools.call("Page.navigate", url=viewer)
            print(f"opened {viewer}; waiting {wait_s:g} s for the viewer to load", flush=True)
            time.sleep(wait_s)
            paths = []
            for k in range(shots):
                if k:
                    time.sleep(interval_s)
                png = base64.b64decode(tools.call("Page.captureScreenshot", format="png")["data"])
                path = out if shots == 1 else out.with_name(f"{out.stem}-{k + 1}{out.suffix}")
                path.parent.mkdir(parents=True, exist_ok=True)
                path.write_bytes(png)
                print(f"wrote {path} ({len(png) / 1e3:.0f} kB)", flush=True)
                paths.append(path)
            return paths
    finally:
        for p in reversed(procs):  # only the processes started here, each with its own group:
            stop_group(p)  # .venv/bin/rerun is a Python wrapper whose child is the real viewer
        shutil.rmtree(profile, ignore_errors=True)


def stop_group(p: subprocess.Popen) -> None:
    """Stop ``p`` and its children (its own process group, from ``start_new_session``)."""
    for sig in (signal.SIGTERM, signal.SIGKILL):
        try:
            os.killpg(p.pid, sig)
        except ProcessLookupError:
            return
        try:
            p.wait(10)
            time.sleep(0.5)  # children leave after their parent
        except subprocess.TimeoutExpired:
            continue
    p.wait()


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("recording", help="an .rrd file or a run's output folder (it holds recording.rrd)")
    p.add_argument("png", help="the screenshot to write")
    p.add_argument("--width", type=int, default=1600, help="window width [px] (default: 1600)")
    p.add_argument("--height", type=int, default=1000, help="window height [px] (default: 1000)")
    p.add_argument("--wait", type=float, default=40.0, help="seconds to let the viewer load (default: 40)")
    p.add_argument("--shots", type=int, default=1, help="number of screenshots (default: 1)")
    p.add_argument("--interval", type=float, default=5.0, help="seconds between screenshots (default: 5)")
    p.add_argument("--chromium", default=shutil.which("chromium") or shutil.which("chromium-browser") or "chromium",
                   help="the Chromium executable (default: chromium on PATH)")
    here = Path(sys.executable).parent / "rerun"
    p.add_argument("--rerun", default=str(here) if here.is_file() else "rerun",
                   help="the rerun executable (default: the one next to this Python)")
    a = p.parse_args(argv)
    rrd = Path(a.recording)
    rrd = rrd / "recording.rrd" if rrd.is_dir() else rrd
    if not rrd.is_file():
        print(f"screenshot_recording: no recording at {rrd}", file=sys.stderr)
        return 2
    for what, exe, hint in (("Chromium", a.chromium, "apt-get install chromium, or --chromium PATH"),
                            ("the Rerun viewer", a.rerun, "pip install rerun-sdk, or --rerun PATH")):
        if shutil.which(exe) is None:  # (before anything starts: a missing one was a FileNotFoundError traceback)
            print(f"screenshot_recording: {what} not found ({exe!r}): {hint}", file=sys.stderr)
            return 2
    screenshots(rrd, Path(a.png), a.width, a.height, a.wait, a.shots, a.interval, a.chromium, a.rerun)
    return 0


if __name__ == "__main__":
    sys.exit(main())

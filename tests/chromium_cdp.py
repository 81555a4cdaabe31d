"""Headless Chromium driven through the DevTools protocol, for tests of the HTML report.

Needs a Chromium (the Debian ``chromium`` package; ``$MRNEA_CHROMIUM`` names another) and the
``websocket-client`` package; no Playwright, no chromedriver, no browser download.

    with Browser() as b:                  # ChromiumUnavailable if there is no browser to start
        page = b.open("file:///tmp/report.html")
        page.evaluate("mrneaView3d.setTime(3.5)")
        png = page.screenshot()
        assert not page.errors and not page.outside_requests

The browser runs with a fresh profile in a temporary folder, on ``--remote-debugging-port=0``
(the port it picks is read from its stderr), in its own process group; :meth:`Browser.close`
(also on any error inside the ``with``) asks it to quit, then kills the group and removes the
profile. Every call has a timeout.
"""

from __future__ import annotations

import base64
import json
import os
import re
import shutil
import signal
import subprocess
import tempfile
import threading
import time
from collections.abc import Callable
from typing import Any

CANDIDATES = ("/usr/bin/chromium", "chromium", "chromium-browser", "google-chrome")
FLAGS = (
    "--headless=new",
    "--no-sandbox",                 # root in a container: the setuid sandbox cannot start
    "--enable-unsafe-swiftshader",  # WebGL on the CPU (no GPU in CI)
    "--use-angle=swiftshader",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--disable-extensions",
    "--disable-default-apps",
    "--disable-dev-shm-usage",
    "--no-first-run",
    "--no-default-browser-check",
    "--mute-audio",
    "--hide-scrollbars",
    "--force-device-scale-factor=1",
    "--remote-debugging-port=0",
)
LOCAL_SCHEMES = ("file:", "data:", "blob:", "about:")


class ChromiumUnavailable(RuntimeError):
    """No Chromium could be started here; the message says why (a test skips with it)."""


class CDPError(RuntimeError):
    """The browser answered a command with an error, or did not answer in time."""


def find_chromium() -> str:
    """Path of the Chromium to run: ``$MRNEA_CHROMIUM``, else the first of :data:`CANDIDATES`."""
    env = os.environ.get("MRNEA_CHROMIUM")
    for c in ((env,) if env else CANDIDATES):
        path = shutil.which(c)
        if path:
            return path
    raise ChromiumUnavailable(
        f"no Chromium found (tried {', '.join((env,) if env else CANDIDATES)}); "
        f"install it with: apt-get install -y chromium")


class Browser:
    """One headless Chromium process and one WebSocket to it (flattened target sessions)."""

    def __init__(self, executable: str | None = None, width: int = 1280, height: int = 900,
                 timeout: float = 30.0, extra_flags: tuple[str, ...] = ()) -> None:
        try:
            import websocket  # websocket-client
        except ImportError:
            raise ChromiumUnavailable("the websocket-client package is not installed") from None
        self._websocket = websocket
        self.executable = executable or find_chromium()
        self.width, self.height, self.timeout = width, height, timeout
        self.extra_flags = extra_flags
        self._profile = tempfile.mkdtemp(prefix="mrnea-chromium-")
        self._proc: subprocess.Popen | None = None
        self._ws: Any = None
        self._id = 0
        self._stderr: list[str] = []
        self._handlers: dict[str, list[Callable[[dict], None]]] = {}
        self.startup_seconds = float("nan")
        try:
            self._start()
        except BaseException:
            self.close()
            raise

    # --- process -------------------------------------------------------------------------------
    def _start(self) -> None:
        t_start = time.perf_counter()
        cmd = [self.executable, *FLAGS, *self.extra_flags, f"--user-data-dir={self._profile}",
               f"--window-size={self.width},{self.height}", "about:blank"]
        try:
            self._proc = subprocess.Popen(cmd, stdin=subprocess.DEVNULL,
                                          stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                                          text=True, start_new_session=True)
        except OSError as exc:
            raise ChromiumUnavailable(f"cannot run {self.executable}: {exc}") from None
        found = threading.Event()
        url: list[str] = []

        def drain() -> None:  # read stderr to the end, so that the browser never blocks on it
            assert self._proc is not None and self._proc.stderr is not None
            for line in self._proc.stderr:
                self._stderr.append(line.rstrip())
                del self._stderr[:-200]
                m = re.search(r"DevTools listening on (ws://\S+)", line)
                if m and not found.is_set():
                    url.append(m.group(1))
                    found.set()
            found.set()  # stderr closed: the browser is gone

        threading.Thread(target=drain, daemon=True).start()
        if not found.wait(self.timeout) or not url:
            tail = "\n".join(self._stderr[-15:])
            raise ChromiumUnavailable(
                f"{self.executable} did not start within {self.timeout:g} s "
                f"(exit code {self._proc.poll()}); its last messages:\n{tail}")
        self._ws = self._websocket.create_connection(url[0], timeout=self.timeout,
                                                     suppress_origin=True)
        self.startup_seconds = time.perf_counter() - t_start

    def close(self) -> None:
        """Quit the browser (kill its process group if it lingers) and remove its profile."""
        if self._ws is not None:
            try:
                self._ws.settimeout(2.0)
                self._id += 1
                self._ws.send(json.dumps({"id": self._id, "method": "Browser.close"}))
            except Exception:
                pass
            try:
                self._ws.close()
            except Exception:
                pass
            self._ws = None
        if self._proc is not None:
            try:
                self._proc.wait(timeout=5.0)
            except subprocess.TimeoutExpired:
                pass
            try:  # whatever is left of its process group (renderer, GPU process): killed
                os.killpg(self._proc.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            self._proc.wait(timeout=5.0)
            self._proc = None
        shutil.rmtree(self._profile, ignore_errors=True)

    def __enter__(self) -> Browser:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # --- protocol ------------------------------------------------------------------------------
    def on(self, method: str, handler: Callable[[dict], None]) -> None:
        self._handlers.setdefault(method, []).append(handler)

    def send(self, method: str, params: dict | None = None, session: str | None = None,
             timeout: float | None = None) -> dict:
        """Send one command and return its result, dispatching the events read meanwhile."""
        self._id += 1
        msg: dict[str, Any] = {"id": self._id, "method": method, "params": params or {}}
        if session:
            msg["sessionId"] = session
        self._ws.send(json.dumps(msg))
        deadline = time.monotonic() + (timeout or self.timeout)
        while True:
            reply = self._recv(deadline, method)
            if reply.get("id") == self._id:
                if "error" in reply:
                    raise CDPError(f"{method}: {reply['error']}")
                return reply.get("result", {})

    def _recv(self, deadline: float, what: str) -> dict:
        left = deadline - time.monotonic()
        if left <= 0:
            raise CDPError(f"{what}: no answer from the browser in time")
        self._ws.settimeout(left)
        try:
            msg = json.loads(self._ws.recv())
        except self._websocket.WebSocketTimeoutException:
            raise CDPError(f"{what}: no answer from the browser in time") from None
        if "method" in msg:
            for h in self._handlers.get(msg["method"], ()):
                h(msg)
        return msg

    def wait_for(self, predicate: Callable[[], bool], timeout: float, what: str) -> None:
        """Read events until ``predicate()`` holds."""
        deadline = time.monotonic() + timeout
        while not predicate():
            self._recv(deadline, what)

    def open(self, url: str, timeout: float | None = None) -> Page:
        """A new tab showing ``url``, its load event fired."""
        target = self.send("Target.createTarget", {"url": "about:blank"})["targetId"]
        session = self.send("Target.attachToTarget", {"targetId": target,
                                                      "flatten": True})["sessionId"]
        page = Page(self, session)
        page.navigate(url, timeout)
        return page


class Page:
    """One tab: what it logged, what it requested, and commands on it."""

    def __init__(self, browser: Browser, session: str) -> None:
        self.browser, self.session = browser, session
        self.errors: list[str] = []
        self.requests: list[str] = []
        self._loaded = False
        browser.on("Runtime.consoleAPICalled", self._console)
        browser.on("Runtime.exceptionThrown", self._exception)
        browser.on("Log.entryAdded", self._log)
        browser.on("Network.requestWillBeSent", self._request)
        browser.on("Page.loadEventFired", self._load)
        for domain in ("Runtime", "Log", "Network", "Page"):
            self.send(f"{domain}.enable")
        self.send("Emulation.setDeviceMetricsOverride", {
            "width": browser.width, "height": browser.height, "deviceScaleFactor": 1,
            "mobile": False})
        self.load_seconds = float("nan")

    def _mine(self, msg: dict) -> bool:
        return msg.get("sessionId") == self.session

    def _console(self, msg: dict) -> None:
        p = msg["params"]
        if self._mine(msg) and p["type"] in ("error", "assert"):
            text = " ".join(str(a.get("value", a.get("description", ""))) for a in p["args"])
            self.errors.append(f"console.{p['type']}: {text}")

    def _exception(self, msg: dict) -> None:
        if self._mine(msg):
            d = msg["params"]["exceptionDetails"]
            desc = d.get("exception", {}).get("description") or d.get("text", "")
            self.errors.append(f"uncaught: {desc} ({d.get('url', '')}:{d.get('lineNumber')})")

    def _log(self, msg: dict) -> None:
        e = msg["params"]["entry"]
        if self._mine(msg) and e["level"] == "error":
            self.errors.append(f"log ({e['source']}): {e['text']} {e.get('url', '')}".rstrip())

    def _request(self, msg: dict) -> None:
        if self._mine(msg):
            self.requests.append(msg["params"]["request"]["url"])

    def _load(self, msg: dict) -> None:
        if self._mine(msg):
            self._loaded = True

    @property
    def outside_requests(self) -> list[str]:
        """Requests to anything but the page's own file and inline data."""
        return [u for u in self.requests if not u.startswith(LOCAL_SCHEMES)]

    def send(self, method: str, params: dict | None = None, timeout: float | None = None) -> dict:
        return self.browser.send(method, params, self.session, timeout)

    def navigate(self, url: str, timeout: float | None = None) -> None:
        t = time.perf_counter()
        self._loaded = False
        res = self.send("Page.navigate", {"url": url})
        if res.get("errorText"):
            raise CDPError(f"navigate {url}: {res['errorText']}")
        if "loaderId" not in res:  # same document, only the #fragment changed: no load event
            self._loaded = True
        self.browser.wait_for(lambda: self._loaded, timeout or self.browser.timeout,
                              f"load event of {url}")
        self.load_seconds = time.perf_counter() - t

    def evaluate(self, expression: str, timeout: float | None = None) -> Any:
        """The value of a JS expression (promises awaited); a thrown error raises CDPError."""
        res = self.send("Runtime.evaluate", {"expression": expression, "awaitPromise": True,
                                             "returnByValue": True}, timeout)
        if "exceptionDetails" in res:
            d = res["exceptionDetails"]
            raise CDPError(f"evaluate {expression!r}: "
                           f"{d.get('exception', {}).get('description') or d.get('text')}")
        return res["result"].get("value")

    def next_frames(self, count: int = 2) -> None:
        """Wait until the page has drawn ``count`` more animation frames."""
        self.evaluate(f"new Promise(r => {{ let k = {int(count)}; const f = () => --k ? "
                      "requestAnimationFrame(f) : r(); requestAnimationFrame(f); })")

    def mouse(self, kind: str, x: float, y: float, **extra: Any) -> None:
        """One mouse event at viewport point (x, y): kind ``mouseMoved``, ``mousePressed``,
        ``mouseReleased`` or ``mouseWheel`` (``deltaY=...``)."""
        self.send("Input.dispatchMouseEvent", {"type": kind, "x": x, "y": y, **extra})

    def screenshot(self, selector: str | None = None, path: str | None = None) -> bytes:
        """PNG of the viewport, or of the box of the first element matching ``selector``."""
        params: dict[str, Any] = {"format": "png"}
        if selector:  # the clip is in document coordinates and may reach beyond the viewport
            box = self.evaluate(
                f"(() => {{ const r = document.querySelector({json.dumps(selector)})"
                ".getBoundingClientRect(); return [r.x + scrollX, r.y + scrollY, r.width, "
                "r.height]; })()")
            params["captureBeyondViewport"] = True
            params["clip"] = {"x": box[0], "y": box[1], "width": box[2], "height": box[3],
                              "scale": 1}
        png = base64.b64decode(self.send("Page.captureScreenshot", params)["data"])
        if path:
            with open(path, "wb") as fh:
                fh.write(png)
        return png

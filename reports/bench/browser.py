"""Open a generated report in headless Chromium and check what a reader would hit.

Chromium is driven over the DevTools protocol on a pipe (``--remote-debugging-pipe``:
commands on fd 3, replies on fd 4, NUL-separated JSON), so nothing beyond the standard
library and Debian's ``chromium`` is needed.  Checked: no console errors or uncaught
exceptions (a missing image logs ``Failed to load resource``), no request leaves the disk
(every URL is ``file:``, ``data:``, ``about:`` or ``blob:``), every in-page link (``#id``)
resolves, every image has loaded (``naturalWidth > 0``).  A screenshot of the first screen
is saved and the page height measured.

``python -m reports.bench.browser DIR`` checks ``DIR/report.html``, writes
``DIR/report-screenshot.png`` and exits 1 when anything is wrong.
"""

from __future__ import annotations

import base64
import dataclasses
import fcntl
import json
import os
import select
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

CANDIDATES = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")
LOCAL_SCHEMES = ("file:", "data:", "about:", "blob:", "chrome:", "devtools:")
VIEWPORT = (1400, 900)  # px: the "first screen" of the screenshot
CHECK_JS = """(() => {
  const links = [...document.querySelectorAll('a[href^="#"]')].map(a => a.getAttribute('href'));
  const toc = [...document.querySelectorAll('nav a[href^="#"]')].length;
  const missing = [...new Set(links)].filter(h => !document.getElementById(h.slice(1)));
  const imgs = [...document.images];
  const broken = imgs.filter(i => !(i.complete && i.naturalWidth > 0))
                     .map(i => i.getAttribute('src'));
  return {links: links.length, toc: toc, missing: missing, images: imgs.length, broken: broken,
          height: document.documentElement.scrollHeight};
})()"""


@dataclasses.dataclass
class BrowserCheck:
    """What headless Chromium saw on a report page."""

    console_errors: list[str]
    network: list[str]
    missing_anchors: list[str]
    broken_images: list[str]
    n_images: int
    n_links: int
    n_toc: int
    page_height_px: int
    screenshot: Path | None

    @property
    def ok(self) -> bool:
        """No console error, no network request, every anchor and image fine."""
        return not (
            self.console_errors or self.network or self.missing_anchors or self.broken_images
        )

    def summary(self) -> str:
        """One paragraph a person reads."""
        state = "OK" if self.ok else "PROBLEMS"
        text = (
            f"{state}: {self.n_images} images ({len(self.broken_images)} broken), "
            f"{self.n_links} in-page links ({self.n_toc} in the contents, "
            f"{len(self.missing_anchors)} unresolved), {len(self.console_errors)} console "
            f"errors, {len(self.network)} network requests; page height {self.page_height_px} px"
        )
        details = self.console_errors + self.network + self.missing_anchors + self.broken_images
        return text + "".join(f"\n  {d}" for d in details[:20])


def find_chromium() -> str | None:
    """Path of a Chromium/Chrome executable, or None."""
    return next((p for p in map(shutil.which, CANDIDATES) if p), None)


class _Pipe:
    """DevTools protocol over the browser's debugging pipe."""

    def __init__(self, proc: subprocess.Popen, w: int, r: int):
        self.proc, self.w, self.r = proc, w, r
        self.buf, self.next_id, self.events = b"", 0, []

    def _read(self, deadline: float) -> dict | None:
        while b"\0" not in self.buf:
            left = deadline - time.monotonic()
            if left <= 0:
                raise TimeoutError("chromium did not answer in time")
            ready, _, _ = select.select([self.r], [], [], left)
            if ready:
                chunk = os.read(self.r, 1 << 20)
                if not chunk:
                    raise RuntimeError("chromium closed the debugging pipe")
                self.buf += chunk
        msg, self.buf = self.buf.split(b"\0", 1)
        return json.loads(msg)

    def call(
        self,
        method: str,
        params: dict | None = None,
        session: str | None = None,
        timeout: float = 30.0,
    ) -> dict:
        self.next_id += 1
        msg: dict[str, Any] = {"id": self.next_id, "method": method, "params": params or {}}
        if session:
            msg["sessionId"] = session
        os.write(self.w, json.dumps(msg).encode() + b"\0")
        deadline = time.monotonic() + timeout
        while True:
            reply = self._read(deadline)
            if reply.get("id") == self.next_id:
                if "error" in reply:
                    raise RuntimeError(f"{method}: {reply['error']}")
                return reply.get("result", {})
            self.events.append(reply)

    def wait_event(self, method: str, timeout: float = 30.0) -> dict:
        deadline = time.monotonic() + timeout
        for ev in self.events:
            if ev.get("method") == method:
                return ev
        while True:
            ev = self._read(deadline)
            self.events.append(ev)
            if ev.get("method") == method:
                return ev


def _high_fd(fd: int) -> int:
    """A duplicate of ``fd`` numbered >= 10 (so dup2 onto 3 and 4 cannot clobber it)."""
    hi = fcntl.fcntl(fd, fcntl.F_DUPFD, 10)
    os.close(fd)
    return hi


_EXEC_ON_3_4 = (
    "import os, sys; os.dup2(int(sys.argv[1]), 3); os.dup2(int(sys.argv[2]), 4); "
    "os.close(int(sys.argv[1])); os.close(int(sys.argv[2])); os.execvp(sys.argv[3], sys.argv[3:])"
)


def _launch(exe: str, profile: str) -> _Pipe:
    cmd_r, cmd_w = map(_high_fd, os.pipe())  # we write commands, chromium reads fd 3
    ev_r, ev_w = map(_high_fd, os.pipe())  # chromium writes fd 4, we read

    args = [
        exe,
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--remote-debugging-pipe",
        "--no-first-run",
        "--no-default-browser-check",
        "--disable-extensions",
        "--disable-background-networking",
        "--disable-component-update",
        "--mute-audio",
        f"--user-data-dir={profile}",
        "about:blank",
    ]
    # a tiny exec wrapper puts the pipe ends on fds 3 and 4 (Popen's close_fds would close
    # them after a preexec hook; dash cannot redirect fds above 9)
    proc = subprocess.Popen(
        [sys.executable, "-c", _EXEC_ON_3_4, str(cmd_r), str(ev_w), *args],
        pass_fds=(cmd_r, ev_w),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    os.close(cmd_r)
    os.close(ev_w)
    return _Pipe(proc, cmd_w, ev_r)


def _messages(events: list[dict]) -> tuple[list[str], list[str]]:
    """(console errors, non-local request URLs) among the protocol events."""
    errors, network = [], []
    for ev in events:
        m, p = ev.get("method"), ev.get("params", {})
        if m == "Runtime.consoleAPICalled" and p.get("type") in ("error", "assert"):
            args = " ".join(str(a.get("value", a.get("description", ""))) for a in p["args"])
            errors.append(f"console.{p['type']}: {args}")
        elif m == "Runtime.exceptionThrown":
            d = p.get("exceptionDetails", {})
            errors.append(
                f"exception: {d.get('text', '')} {d.get('exception', {}).get('description', '')}"
            )
        elif m == "Log.entryAdded" and p.get("entry", {}).get("level") == "error":
            e = p["entry"]
            errors.append(f"{e.get('source', 'log')}: {e.get('text', '')} {e.get('url', '')}")
        elif m == "Network.requestWillBeSent":
            url = p.get("request", {}).get("url", "")
            if not url.startswith(LOCAL_SCHEMES):
                network.append(f"request: {url}")
    return errors, network


def check_report(
    html: str | Path,
    screenshot: str | Path | None = None,
    timeout: float = 60.0,
    exe: str | None = None,
) -> BrowserCheck:
    """Load ``html`` in headless Chromium and check it (see module docstring).

    Raises
    ------
    FileNotFoundError
        No Chromium on this machine (``find_chromium``).
    """
    exe = exe or find_chromium()
    if exe is None:
        raise FileNotFoundError("no chromium executable (Debian: apt-get install chromium)")
    url = Path(html).resolve().as_uri()
    with tempfile.TemporaryDirectory(prefix="flexbench-chromium-") as profile:
        pipe = _launch(exe, profile)
        try:
            target = pipe.call("Target.createTarget", {"url": "about:blank"}, timeout=timeout)
            sess = pipe.call(
                "Target.attachToTarget", {"targetId": target["targetId"], "flatten": True}
            )["sessionId"]
            for domain in ("Page", "Runtime", "Log", "Network"):
                pipe.call(f"{domain}.enable", session=sess)
            w, h = VIEWPORT
            pipe.call(
                "Emulation.setDeviceMetricsOverride",
                {"width": w, "height": h, "deviceScaleFactor": 1, "mobile": False},
                session=sess,
            )
            pipe.call("Page.navigate", {"url": url}, session=sess, timeout=timeout)
            pipe.wait_event("Page.loadEventFired", timeout=timeout)
            res = pipe.call(
                "Runtime.evaluate",
                {"expression": CHECK_JS, "returnByValue": True},
                session=sess,
                timeout=timeout,
            )["result"]["value"]
            shot = None
            if screenshot is not None:
                png = pipe.call(
                    "Page.captureScreenshot", {"format": "png"}, session=sess, timeout=timeout
                )["data"]
                shot = Path(screenshot)
                shot.write_bytes(base64.b64decode(png))
            time.sleep(0.2)  # late console messages
            pipe.call("Runtime.evaluate", {"expression": "1"}, session=sess)
            try:
                pipe.call("Browser.close", timeout=5)
            except (RuntimeError, TimeoutError):
                pass
        finally:
            for fd in (pipe.w, pipe.r):
                os.close(fd)
            try:
                pipe.proc.wait(10)
            except subprocess.TimeoutExpired:
                pipe.proc.kill()
                pipe.proc.wait()
    errors, network = _messages(pipe.events)
    return BrowserCheck(
        errors,
        network,
        res["missing"],
        res["broken"],
        res["images"],
        res["links"],
        res["toc"],
        int(res["height"]),
        shot,
    )


def main(argv: list[str] | None = None) -> int:
    """``python -m reports.bench.browser DIR``: check DIR/report.html, keep a screenshot."""
    argv = sys.argv[1:] if argv is None else argv
    if len(argv) != 1:
        print("usage: python -m reports.bench.browser RUN_DIR", file=sys.stderr)
        return 2
    out = Path(argv[0])
    html = out / "report.html" if out.is_dir() else out
    try:
        res = check_report(html, html.parent / "report-screenshot.png")
    except FileNotFoundError as exc:
        print(f"browser check skipped: {exc}", file=sys.stderr)
        return 2
    print(res.summary())
    print(f"screenshot: {res.screenshot}")
    return 0 if res.ok else 1


if __name__ == "__main__":
    sys.exit(main())

"""Open a generated report in headless Chromium and check what a reader would hit.

Chromium is driven over the DevTools protocol on a pipe (``--remote-debugging-pipe``:
commands on fd 3, replies on fd 4, NUL-separated JSON), so nothing beyond the standard
library and Debian's ``chromium`` is needed.  Checked: no console errors or uncaught
exceptions (a missing image logs ``Failed to load resource``), no request leaves the disk
(every URL is ``file:``, ``data:``, ``about:`` or ``blob:``), every in-page link (``#id``)
resolves, every image has loaded (``naturalWidth > 0``).  A screenshot of the first screen
is saved and the page height measured.

Also measured at a 1400 px window: horizontal overflow of the page (anything a reader would
have to scroll the whole page sideways for; a table scrolling inside its own container is
fine) and the top of every section heading with an id (where the front page ends).

``python -m reports.bench.browser DIR`` checks ``DIR/report.html`` and ``DIR/teaching.html``,
writes ``DIR/report-screenshot.png`` (first two screens) and exits 1 when anything is wrong.
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
# the answer (report.html's pick table, one row per case, a sweep one row) ends within two
# screens: the section after it ("accuracy") starts above this (px); 1487 px for the default run
FRONT_PAGE_MAX_PX = 2 * VIEWPORT[1]
# report.html of the default run (34 cases and 7 sweeps, 34 case sections with their figures)
# measured 84,618 px at 1400 px (145,534 px before the front page was rebuilt); the bound
# leaves ~25 % for new cases and figures: `python -m reports.bench.browser DIR --max-height`
DEFAULT_RUN_MAX_HEIGHT_PX = 105_000
CHECK_JS = """(() => {
  const de = document.documentElement;
  const links = [...document.querySelectorAll('a[href^="#"]')].map(a => a.getAttribute('href'));
  const toc = [...document.querySelectorAll('nav a[href^="#"]')].length;
  const resolves = h => h === '#' || h === '#top'
    || document.getElementById(decodeURIComponent(h.slice(1))) !== null;
  const missing = [...new Set(links)].filter(h => !resolves(h));
  const imgs = [...document.images];
  const broken = imgs.filter(i => !(i.complete && i.naturalWidth > 0))
                     .map(i => i.getAttribute('src'));
  const clips = e => { for (let a = e.parentElement; a && a !== de; a = a.parentElement) {
      if (getComputedStyle(a).overflowX !== 'visible') return true; } return false; };
  const name = e => e.tagName.toLowerCase() + (e.id ? '#' + e.id : '')
    + (e.className && typeof e.className === 'string' ? '.' + e.className.split(' ')[0] : '');
  const wide = [...document.body.querySelectorAll('*')]
    .filter(e => e.getBoundingClientRect().right > de.clientWidth + 1 && !clips(e))
    .slice(0, 10)
    .map(e => `${name(e)} right edge at ${Math.round(e.getBoundingClientRect().right)} px`);
  const tops = Object.fromEntries([...document.querySelectorAll('h2[id], section[id]')]
    .map(e => [e.id, Math.round(e.getBoundingClientRect().top + window.scrollY)]));
  return {links: links.length, toc: toc, missing: missing, images: imgs.length, broken: broken,
          height: de.scrollHeight, overflow: Math.max(de.scrollWidth, document.body.scrollWidth)
          - de.clientWidth, wide: wide, tops: tops};
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
    overflow_px: int = 0
    wide_elements: list[str] = dataclasses.field(default_factory=list)
    section_tops: dict[str, int] = dataclasses.field(default_factory=dict)

    @property
    def ok(self) -> bool:
        """No console error, no network request, every anchor and image fine, nothing wider
        than the window."""
        return not (
            self.console_errors
            or self.network
            or self.missing_anchors
            or self.broken_images
            or self.overflow_px > 0
        )

    def summary(self) -> str:
        """One paragraph a person reads."""
        state = "OK" if self.ok else "PROBLEMS"
        text = (
            f"{state}: {self.n_images} images ({len(self.broken_images)} broken), "
            f"{self.n_links} in-page links ({self.n_toc} in the contents, "
            f"{len(self.missing_anchors)} unresolved), {len(self.console_errors)} console "
            f"errors, {len(self.network)} network requests; page height {self.page_height_px} px, "
            f"horizontal overflow {self.overflow_px} px at {VIEWPORT[0]} px"
        )
        details = self.console_errors + self.network + self.missing_anchors + self.broken_images
        details += self.wide_elements if self.overflow_px > 0 else []
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
    screens: float = 1.0,
) -> BrowserCheck:
    """Load ``html`` in headless Chromium and check it (see module docstring); the
    screenshot shows the top ``screens`` window heights of the page.

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
                clip = {"x": 0, "y": 0, "width": w, "height": int(h * screens), "scale": 1}
                png = pipe.call(
                    "Page.captureScreenshot",
                    {"format": "png", "clip": clip, "captureBeyondViewport": screens > 1},
                    session=sess,
                    timeout=timeout,
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
        int(res["overflow"]),
        res["wide"],
        res["tops"],
    )


def main(argv: list[str] | None = None) -> int:
    """``python -m reports.bench.browser DIR [--max-height PX] [--shots DIR]``: check
    DIR/report.html and DIR/teaching.html (when there), keep a screenshot of each page's
    first two screens; exit 1 when a check fails or report.html is taller than PX."""
    import argparse

    ap = argparse.ArgumentParser(prog="python -m reports.bench.browser")
    ap.add_argument("run_dir", type=Path)
    ap.add_argument(
        "--max-height",
        type=int,
        nargs="?",
        const=DEFAULT_RUN_MAX_HEIGHT_PX,
        help=f"report.html's height bound, px (alone: {DEFAULT_RUN_MAX_HEIGHT_PX})",
    )
    ap.add_argument("--shots", type=Path, help="folder of the screenshots (default: RUN_DIR)")
    args = ap.parse_args(argv)
    out = args.run_dir
    pages = [out / "report.html", out / "teaching.html"] if out.is_dir() else [out]
    shots = args.shots or (out if out.is_dir() else out.parent)
    shots.mkdir(parents=True, exist_ok=True)
    failed = False
    for page in [p for p in pages if p.is_file()]:
        try:
            res = check_report(page, shots / f"{page.stem}-screenshot.png", screens=2)
        except FileNotFoundError as exc:
            print(f"browser check skipped: {exc}", file=sys.stderr)
            return 2
        print(f"{page.name}: {res.summary()}\nscreenshot: {res.screenshot}")
        problems = []
        if page.name == "report.html":
            if args.max_height and res.page_height_px > args.max_height:
                problems.append(f"taller than {args.max_height} px")
            front = res.section_tops.get("accuracy")
            if front is not None:
                print(f"the answer (pick table) ends at {front} px ({FRONT_PAGE_MAX_PX} allowed)")
                if front > FRONT_PAGE_MAX_PX:
                    problems.append("the answer does not fit in two screens")
        for p in problems:
            print(f"{page.name}: {p}")
        failed = failed or not res.ok or bool(problems)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())

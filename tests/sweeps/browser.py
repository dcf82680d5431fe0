"""Open a page in headless Chromium and read it through the DevTools protocol.

Chromium is started on loopback with a fresh profile and no network services; the test
talks to it over its DevTools WebSocket (Tornado's client, which Dask already brings).
"""

from __future__ import annotations

import asyncio
import base64
import json
import re
import shutil
import subprocess
import tempfile
import time
import urllib.request
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from tornado.websocket import websocket_connect

FLAGS = (
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--remote-debugging-address=127.0.0.1",
    "--remote-debugging-port=0",
    "--window-size=1300,2200",
)


def chromium() -> str | None:
    """The Chromium executable, or ``None``."""
    return shutil.which("chromium") or shutil.which("chromium-browser")


@dataclass
class PageReport:
    """What the page showed: images, table text, console errors and a screenshot."""

    images: list[dict[str, Any]]
    tables: list[str]
    errors: list[str] = field(default_factory=list)
    screenshot: bytes = b""


def inspect(url: str, *, timeout: float = 60.0) -> PageReport:
    """Load ``url`` in headless Chromium and report what it rendered."""
    executable = chromium()
    assert executable, "chromium is not installed"
    # chromium's helper processes may still write into the profile as the main one exits
    with tempfile.TemporaryDirectory(
        prefix="bayesmap-chromium-", ignore_cleanup_errors=True
    ) as profile:
        process = subprocess.Popen(
            [executable, *FLAGS, f"--user-data-dir={profile}", "about:blank"],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
        )
        try:
            port = _devtools_port(process, timeout)
            return asyncio.run(asyncio.wait_for(_inspect(port, url), timeout))
        finally:
            process.terminate()
            try:
                process.wait(10)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()


def _devtools_port(process: subprocess.Popen[str], timeout: float) -> int:
    deadline = time.monotonic() + timeout
    assert process.stderr is not None
    while time.monotonic() < deadline:
        line = process.stderr.readline()
        match = re.search(r"DevTools listening on ws://127\.0\.0\.1:(\d+)/", line)
        if match:
            return int(match.group(1))
        if not line and process.poll() is not None:
            break
    raise RuntimeError("chromium did not open its DevTools port")


async def _inspect(port: int, url: str) -> PageReport:
    targets = json.loads(urllib.request.urlopen(f"http://127.0.0.1:{port}/json").read())
    page = next(t for t in targets if t["type"] == "page")
    socket = await websocket_connect(page["webSocketDebuggerUrl"], max_message_size=2**28)
    counter = 0
    errors: list[str] = []

    async def call(method: str, **params: Any) -> dict[str, Any]:
        nonlocal counter
        counter += 1
        ident = counter
        await socket.write_message(json.dumps({"id": ident, "method": method, "params": params}))
        while True:
            message = json.loads(await socket.read_message())
            _collect(message, errors)
            if message.get("id") == ident:
                if "error" in message:
                    raise RuntimeError(f"{method}: {message['error']}")
                return message["result"]

    for domain in ("Page", "Runtime", "Log"):
        await call(f"{domain}.enable")
    await call("Page.navigate", url=url)
    while True:
        message = json.loads(await socket.read_message())
        _collect(message, errors)
        if message.get("method") == "Page.loadEventFired":
            break
    script = """JSON.stringify({
      images: [...document.images].map(i => ({alt: i.alt, complete: i.complete,
                                              width: i.naturalWidth, height: i.naturalHeight,
                                              inline: i.src.startsWith('data:image/')})),
      tables: [...document.querySelectorAll('table')].map(t => t.innerText)})"""
    found = await call("Runtime.evaluate", expression=script, returnByValue=True)
    data = json.loads(found["result"]["value"])
    shot = await call("Page.captureScreenshot", format="png", captureBeyondViewport=True)
    socket.close()
    return PageReport(data["images"], data["tables"], errors, base64.b64decode(shot["data"]))


def _collect(message: dict[str, Any], errors: list[str]) -> None:
    method = message.get("method")
    params = message.get("params", {})
    if method == "Runtime.consoleAPICalled" and params.get("type") in ("error", "assert"):
        errors.append(" ".join(str(a.get("value", a.get("description"))) for a in params["args"]))
    elif method == "Runtime.exceptionThrown":
        errors.append(params["exceptionDetails"].get("text", "exception"))
    elif method == "Log.entryAdded" and params["entry"].get("level") == "error":
        errors.append(params["entry"].get("text", ""))


def save(report: PageReport, path: Path) -> Path:
    """Write the screenshot (for a person to look at)."""
    path.write_bytes(report.screenshot)
    return path

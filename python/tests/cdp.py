"""A headless Chromium driven as a user drives a browser: clicks at an element's centre, files chosen in an
<input type="file"> or dropped on an element, the page's visible text read back. It speaks the DevTools protocol
over `--remote-debugging-pipe` (two pipes, NUL-terminated JSON), so it needs no package beyond Chromium."""

import json
import os
import subprocess
import time


class Browser:
    def __init__(self, chromium, workdir, width=1200, height=1600):
        to_chrome_r, self._to_chrome = os.pipe()
        self._from_chrome, from_chrome_w = os.pipe()
        flags = [chromium, "--headless", "--no-sandbox", "--disable-dev-shm-usage", "--use-angle=swiftshader",
                 "--enable-unsafe-swiftshader", f"--window-size={width},{height}", "--remote-debugging-pipe",
                 f"--user-data-dir={workdir}", "about:blank"]

        def fds():  # Chromium reads commands on fd 3 and writes answers on fd 4
            r, w = os.dup(to_chrome_r), os.dup(from_chrome_w)  # copies first: a pipe may itself be fd 3 or 4
            os.dup2(r, 3)
            os.dup2(w, 4)
            os.set_inheritable(3, True)  # (dup2 onto the same number keeps close-on-exec)
            os.set_inheritable(4, True)

        self.p = subprocess.Popen(flags, preexec_fn=fds, close_fds=False, cwd=workdir,
                                  stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                  env={**os.environ, "HOME": workdir})
        os.close(to_chrome_r)
        os.close(from_chrome_w)
        self._buf, self._id, self.session = b"", 0, None
        targets = self.call("Target.getTargets")["targetInfos"]
        page = next(t for t in targets if t["type"] == "page")
        self.session = self.call("Target.attachToTarget", targetId=page["targetId"], flatten=True)["sessionId"]
        self.call("Page.enable")
        self.call("Runtime.enable")

    def _read(self):
        while b"\0" not in self._buf:
            chunk = os.read(self._from_chrome, 1 << 16)
            if not chunk:
                raise RuntimeError("chromium closed the debugging pipe")
            self._buf += chunk
        msg, self._buf = self._buf.split(b"\0", 1)
        return json.loads(msg)

    def call(self, method, **params):
        self._id += 1
        msg = {"id": self._id, "method": method, "params": params}
        if self.session:
            msg["sessionId"] = self.session
        os.write(self._to_chrome, json.dumps(msg).encode() + b"\0")
        while True:
            m = self._read()
            if m.get("id") == self._id:
                if "error" in m:
                    raise RuntimeError(f"{method}: {m['error']}")
                return m.get("result", {})

    def js(self, expression):
        r = self.call("Runtime.evaluate", expression=expression, returnByValue=True, awaitPromise=True)
        if "exceptionDetails" in r:
            raise RuntimeError(f"{expression}: {r['exceptionDetails']}")
        return r["result"].get("value")

    def goto(self, url):
        """Navigates and returns once the document has been parsed (its scripts may still be working)."""
        self.call("Page.navigate", url=url)
        self.wait_for(f"location.href === {json.dumps(url)} && document.readyState !== 'loading'", timeout=60,
                      what=f"{url} to load")

    def wait_for(self, expression, timeout=120, what=None):
        """Polls `expression` until it is truthy; returns its value."""
        end = time.time() + timeout
        while time.time() < end:
            try:
                v = self.js(expression)
            except RuntimeError:
                v = None
            if v:
                return v
            time.sleep(0.1)
        raise AssertionError(f"timed out waiting for {what or expression}; status: {self.text('#status')!r}")

    def text(self, selector):
        return self.js(f"(e => e ? e.innerText : null)(document.querySelector({json.dumps(selector)}))")

    def visible(self, selector):
        return self.js(f"(e => !!e && e.offsetParent !== null && e.getBoundingClientRect().height > 0)"
                       f"(document.querySelector({json.dumps(selector)}))")

    def _node(self, selector):
        root = self.call("DOM.getDocument")["root"]["nodeId"]
        node = self.call("DOM.querySelector", nodeId=root, selector=selector)["nodeId"]
        assert node, f"no element {selector}"
        return node

    def _centre(self, selector):
        self.js(f"document.querySelector({json.dumps(selector)}).scrollIntoView({{block: 'center'}})")
        q = self.call("DOM.getBoxModel", nodeId=self._node(selector))["model"]["content"]
        return (q[0] + q[2] + q[4] + q[6]) / 4, (q[1] + q[3] + q[5] + q[7]) / 4

    def click(self, selector):
        x, y = self._centre(selector)
        for kind in ("mousePressed", "mouseReleased"):
            self.call("Input.dispatchMouseEvent", type=kind, x=x, y=y, button="left", clickCount=1)

    def type(self, selector, text):
        self.click(selector)
        self.call("Input.insertText", text=text)

    def choose_file(self, selector, path):
        """As the file dialog would: the input's files set, its change event fired."""
        self.call("DOM.setFileInputFiles", files=[os.path.abspath(path)], nodeId=self._node(selector))

    def drop_file(self, selector, path, mime="image/png"):
        x, y = self._centre(selector)
        data = {"items": [], "files": [os.path.abspath(path)], "dragOperationsMask": 1}
        for kind in ("dragEnter", "dragOver", "drop"):
            self.call("Input.dispatchDragEvent", type=kind, x=x, y=y, data=data)

    def screenshot(self, path):
        import base64
        with open(path, "wb") as f:
            f.write(base64.b64decode(self.call("Page.captureScreenshot", format="png")["data"]))

    def close(self):
        try:
            self.session = None
            self.call("Browser.close")
        except Exception:  # noqa: BLE001 — already gone
            pass
        try:
            self.p.wait(timeout=20)
        except subprocess.TimeoutExpired:
            self.p.kill()
        os.close(self._to_chrome)
        os.close(self._from_chrome)

"""A client of `freeloc serve` (docs/service.md), standard library only.

    c = freeloc.Client("http://127.0.0.1:8080", token=None)
    anchor = c.add_anchor("ref.jpg", depth="ref.depth.png", intrinsics=(fx, fy, cx, cy))   # -> id
    record = c.relocalize(anchor, "query.jpg")   # the `freeloc relocalize --json` record
"""

import json as _json
import os as _os
import urllib.error as _error
import urllib.request as _request
import uuid as _uuid


class ServiceError(RuntimeError):
    """An HTTP error of the service: .status (400, 401, 404, 413, 503, …) and the service's message."""

    def __init__(self, status, message):
        super().__init__(f"{status}: {message}")
        self.status = status
        self.message = message


def _bytes(value):
    if isinstance(value, (bytes, bytearray)):
        return bytes(value)
    with open(_os.fspath(value), "rb") as f:
        return f.read()


def _form(image, depth=None, intrinsics=None):
    boundary = "freeloc-" + _uuid.uuid4().hex
    parts = [("image", _bytes(image), "image")]
    if depth is not None:
        parts.append(("depth", _bytes(depth), "depth.png"))
    if intrinsics is not None:
        text = intrinsics if isinstance(intrinsics, str) else ",".join(repr(float(v)) for v in intrinsics)
        parts.append(("intrinsics", text.encode(), None))
    body = b""
    for name, data, filename in parts:
        disp = f'form-data; name="{name}"' + (f'; filename="{filename}"' if filename else "")
        body += f"--{boundary}\r\nContent-Disposition: {disp}\r\n\r\n".encode() + data + b"\r\n"
    body += f"--{boundary}--\r\n".encode()
    return body, f"multipart/form-data; boundary={boundary}"


class Client:
    """`url`: the service's address; `token`: its --token, if any; `timeout`: seconds per request."""

    def __init__(self, url, token=None, timeout=300):
        self.url = url.rstrip("/")
        self.token = token
        self.timeout = timeout

    def _call(self, method, path, body=None, content_type=None):
        req = _request.Request(self.url + path, data=body, method=method)
        if content_type:
            req.add_header("Content-Type", content_type)
        if self.token:
            req.add_header("Authorization", "Bearer " + self.token)
        try:
            with _request.urlopen(req, timeout=self.timeout) as r:
                return _json.loads(r.read())
        except _error.HTTPError as e:
            text = e.read()
            try:
                message = _json.loads(text).get("error", "")
            except ValueError:
                message = text.decode(errors="replace")
            raise ServiceError(e.code, message) from None

    def health(self):
        return self._call("GET", "/healthz")

    def metrics(self):
        return self._call("GET", "/metrics")

    def add_anchor(self, image, depth=None, intrinsics=None):
        """Stores a reference photo (path or bytes; optional 16-bit depth PNG and fx,fy,cx,cy); returns its id."""
        return self._call("POST", "/v1/anchors", *_form(image, depth, intrinsics))["id"]

    def anchors(self):
        return self._call("GET", "/v1/anchors")["anchors"]

    def anchor(self, anchor_id):
        return self._call("GET", f"/v1/anchors/{anchor_id}")

    def delete_anchor(self, anchor_id):
        return self._call("DELETE", f"/v1/anchors/{anchor_id}")

    def relocalize(self, anchor_id, image, depth=None, intrinsics=None):
        """The pose of `image` relative to the anchor: the `freeloc relocalize --json` record (+ "service")."""
        return self._call("POST", f"/v1/anchors/{anchor_id}/relocalize", *_form(image, depth, intrinsics))

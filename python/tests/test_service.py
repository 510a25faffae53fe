"""`freeloc serve` as a user runs it: the binary on a free localhost port, the Python client, the answer equal to
`freeloc relocalize --json`, errors as ServiceError, the page in headless Chromium (an answer shown, the 3D view
drawn), and SIGTERM ending it cleanly (exit 0)."""

import json
import os
import shutil
import signal
import subprocess
import tempfile
import threading
import time

import pytest

import freeloc

SRC = os.environ.get("FREELOC_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", ".."))
BIN = os.environ.get("FREELOC_BINARY", os.path.join(SRC, "build", "freeloc"))
S3 = os.path.join(SRC, "data", "demo", "val", "s00003")
REF, QUERY = os.path.join(S3, "seq0", "frame_00000.png"), os.path.join(S3, "seq1", "frame_00000.png")
REF_D, QUERY_D = os.path.join(S3, "seq0", "frame_00000.sensor.png"), os.path.join(S3, "seq1", "frame_00000.sensor.png")
K = (520.908620, 521.007327, 325.141442, 249.701764)


class Serve:
    def __init__(self, *args):
        self.p = subprocess.Popen([BIN, "serve", "--port", "0", *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                  text=True, env={**os.environ, "FREELOC_MODELS": ""})
        line = self.p.stdout.readline()
        assert line.startswith("freeloc serve: http://127.0.0.1:"), line + self.p.stderr.read()
        self.url = line.split()[2].rstrip("/")

    def stop(self):
        self.p.send_signal(signal.SIGTERM)
        out, err = self.p.communicate(timeout=60)
        return self.p.returncode, out, err


@pytest.fixture(scope="module")
def server():
    s = Serve()
    yield s
    if s.p.poll() is None:
        s.stop()


def test_client_answer_equals_relocalize_json(server):
    c = freeloc.Client(server.url)
    assert c.health()["status"] == "ok"
    a = c.add_anchor(REF, depth=REF_D, intrinsics=K)
    rec = c.relocalize(a, QUERY, depth=QUERY_D, intrinsics=K)
    k = ",".join(repr(v) for v in K)
    cli = json.loads(subprocess.run([BIN, "relocalize", "--ref", REF, "--query", QUERY, "--ref-intrinsics", k,
                                     "--query-intrinsics", k, "--ref-depth", REF_D, "--query-depth", QUERY_D, "--json"],
                                    capture_output=True, text=True, check=True).stdout)
    for key in ("status", "qvec", "tvec", "confidence", "inliers", "matches", "options"):
        assert rec[key] == cli[key], key
    assert any(x["id"] == a for x in c.anchors())
    with pytest.raises(freeloc.ServiceError) as e:
        c.relocalize("0123456789abcdef", QUERY)
    assert e.value.status == 404
    with pytest.raises(freeloc.ServiceError) as e:
        c.relocalize(a, b"GIF89a not an image")
    assert e.value.status == 400 and "image" in e.value.message
    with pytest.raises(freeloc.ServiceError) as e:
        c.relocalize(a, QUERY, intrinsics="1,2,x")
    assert e.value.status == 400 and "intrinsics" in e.value.message
    assert c.metrics()["anchors"] >= 1
    c.delete_anchor(a)


def _chromium():
    for name in ("chromium", "chromium-browser", "google-chrome"):
        if shutil.which(name):
            return shutil.which(name)
    return None


def test_page_shows_an_answer_and_draws_the_3d_view(server):
    chromium = _chromium()
    if chromium is None:
        pytest.skip("chromium is not installed (scripts/install-deps.sh installs it)")
    Image = pytest.importorskip("PIL.Image", reason="Pillow (python3-pil) is not installed")
    c = freeloc.Client(server.url)
    a = c.add_anchor(REF, depth=REF_D, intrinsics=K)
    b = c.add_anchor(QUERY, depth=QUERY_D, intrinsics=K)  # its photo is the query the page sends
    url = f"{server.url}/?anchor={a}&query_anchor={b}"
    flags = [chromium, "--headless", "--no-sandbox", "--disable-dev-shm-usage", "--use-angle=swiftshader",
             "--enable-unsafe-swiftshader", "--window-size=1200,1900", "--virtual-time-budget=30000"]
    with tempfile.TemporaryDirectory() as tmp:
        dom = subprocess.run(flags + ["--dump-dom", url], capture_output=True, text=True, timeout=180,
                             cwd=tmp, env={**os.environ, "HOME": tmp}).stdout
        assert 'data-status="ok"' in dom, dom[-2000:]
        shot = os.path.join(tmp, "page.png")
        subprocess.run(flags + [f"--screenshot={shot}", url], capture_output=True, timeout=180, cwd=tmp,
                       env={**os.environ, "HOME": tmp})
        im = Image.open(shot).convert("RGB")
        px = im.load()
        w, h = im.size
        # The 3D view's canvas: points in the photo's colours on #111, the predicted frustum orange (ff9922) and the
        # reference's green (33dd66). Count them.
        orange = green = coloured = 0
        for y in range(0, h, 2):
            for x in range(0, w, 2):
                r, g, b_ = px[x, y]
                if r > 200 and 120 < g < 185 and b_ < 90:
                    orange += 1
                if r < 90 and g > 180 and 60 < b_ < 140:
                    green += 1
                if max(r, g, b_) > 40 and not (r > 240 and g > 240 and b_ > 240):
                    coloured += 1
        assert orange > 10 and green > 10, (orange, green)
        assert coloured > 5000
        os.makedirs(os.path.join(tempfile.gettempdir(), "freeloc_page"), exist_ok=True)
        shutil.copy(shot, os.path.join(tempfile.gettempdir(), "freeloc_page", "page.png"))  # for people to look at


def test_page_used_by_hand_adds_an_anchor_and_shows_an_answer_with_its_legend(server):
    """The page as a person uses it: wait until it says it is ready, drop the reference photo, choose its depth, type
    the intrinsics, click "add anchor", choose the query the same way, click "relocalize", read the answer and the
    legend. Clicks and files go through Chromium's input layer (DevTools protocol), not through page scripts."""
    chromium = _chromium()
    if chromium is None:
        pytest.skip("chromium is not installed (scripts/install-deps.sh installs it)")
    import cdp
    k = ",".join(repr(v) for v in K)
    with tempfile.TemporaryDirectory() as tmp:
        import urllib.request
        html = urllib.request.urlopen(server.url + "/").read().decode()
        assert '<button id="go" disabled>' in html  # nothing to click until the page says it is ready
        b = cdp.Browser(chromium, tmp)
        try:
            b.goto(server.url + "/")
            ready = b.wait_for("(s => s.startsWith('ready') && s)(document.getElementById('status').innerText)",
                               what="the page to say it is ready")
            assert "anchor" in ready
            assert not b.visible("#view3d") and not b.visible("#pair")  # no empty black box before an answer
            b.drop_file("#dropA", REF)
            assert b.js("document.getElementById('fileA').files[0].name") == os.path.basename(REF)  # the input says so
            b.choose_file("#depthA", REF_D)
            b.type("#kA", k)
            b.click("#addA")
            added = b.wait_for("(s => /^anchor \\S+ added/.test(s) && s)(document.getElementById('status').innerText)",
                               what="the anchor to be added")
            b.choose_file("#fileQ", QUERY)
            b.choose_file("#depthQ", QUERY_D)
            b.type("#kQ", k)
            b.js("window.seen = []; new MutationObserver(() => seen.push([document.getElementById('status').innerText,"
                 " document.getElementById('go').disabled])).observe(document.getElementById('status'),"
                 " {childList: true, characterData: true, subtree: true})")
            b.click("#go")
            status = b.wait_for("document.body.dataset.status", what="an answer")
            assert status == "ok", b.text("#status")
            seen = b.js("seen")
            assert any(t.startswith("relocalizing") and disabled for t, disabled in seen), seen  # a visible busy state
            assert b.text("#status").startswith("ok — t = ("), b.text("#status")
            assert b.visible("#legend")
            legend = b.text("#legend")
            for word in ("inlier", "outlier", "reference", "predicted", "truth", "turbo"):
                assert word in legend, legend
            assert b.visible("#view3d") and b.js("document.getElementById('pair').width") > 100
            lines = b.js("JSON.parse(document.getElementById('record').textContent).inliers")
            assert lines > 0 and added
        finally:
            b.close()


def test_sigterm_finishes_the_admitted_request_and_exits_zero():
    s = Serve("--workers", "1")
    c = freeloc.Client(s.url)
    a = c.add_anchor(REF, depth=REF_D, intrinsics=K)
    results, errors = [], []

    def query():
        try:
            results.append(c.relocalize(a, QUERY, depth=QUERY_D, intrinsics=K))
        except Exception as e:  # noqa: BLE001 — recorded and asserted on below
            errors.append(e)

    threads = [threading.Thread(target=query) for _ in range(3)]
    for t in threads:
        t.start()
    deadline = time.time() + 30
    while time.time() < deadline and c.metrics()["in_flight"] == 0 and not results:
        time.sleep(0.005)
    code, out, err = s.stop()
    for t in threads:
        t.join(timeout=60)
    assert code == 0, err
    assert "stopped" in out and "SIGTERM" in err
    # Every request admitted before the signal was answered in full; none got half an answer.
    assert results, errors
    assert all(r["status"] == "ok" for r in results)

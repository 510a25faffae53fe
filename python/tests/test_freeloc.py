"""The Python API against the CLI on the same inputs (bundled TUM scenes, data/demo): same poses, statuses,
confidences and metrics; arrays of any layout; bad input raises. Run by ctest (python_tests) with PYTHONPATH set
to <build>/python and FREELOC_BINARY to the freeloc executable."""

import json
import os
import struct
import subprocess
import sys

import numpy as np
import pytest

import freeloc

SRC = os.environ.get("FREELOC_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", ".."))
BIN = os.environ.get("FREELOC_BINARY", os.path.join(SRC, "build", "freeloc"))
SHARED = os.environ.get("FREELOC_SHARED_DIR", os.path.join(SRC, "..", "shared"))
DEMO = os.path.join(SRC, "data", "demo")
S3 = os.path.join(DEMO, "val", "s00003")
S2 = os.path.join(DEMO, "val", "s00002")
MATCHES = os.path.join(SRC, "tests", "data", "tum_sift", "s00003_sift_matches.txt")
K_TUM = np.array([[535.4, 0, 320.1], [0, 539.2, 247.6], [0, 0, 1]])
K_TEXT = "535.4,539.2,320.1,247.6"


def cli(*args, check=True):
    p = subprocess.run([BIN, *args], capture_output=True, text=True, env={**os.environ, "FREELOC_MODELS": ""})
    if check and p.returncode not in (0, 1):
        raise AssertionError(f"freeloc {' '.join(args)} exited {p.returncode}: {p.stderr}")
    return p


def rel(a, b):
    a, b = np.asarray(a, float), np.asarray(b, float)
    return float(np.max(np.abs(a - b) / np.maximum(1e-300, np.maximum(np.abs(a), np.abs(b)))))


def same_record(py, rec):
    assert py.status == rec["status"]
    assert rel(py.qvec, rec["qvec"]) <= 1e-9
    assert rel(py.t, rec["tvec"]) <= 1e-9
    assert rel(py.confidence, rec["confidence"]) <= 1e-9 or py.confidence == rec["confidence"]
    assert py.num_inliers == rec["inliers"]


def depth(scene, seq):
    return os.path.join(scene, seq, "frame_00000.sensor.png")


@pytest.mark.parametrize("extra", [[], ["--preset", "dust3r"], ["--threshold", "1"], ["--solver", "pnp"],
                                   ["--scale", "official", "--threshold", "2.5"]])
def test_pose_equals_cli(extra):
    out = cli("pose", "--matches", MATCHES, "--ref-intrinsics", K_TEXT, "--query-intrinsics", K_TEXT, "--ref-depth",
              depth(S3, "seq0"), "--query-depth", depth(S3, "seq1"), "--json", *extra)
    rec = json.loads(out.stdout)
    kw = {}
    for flag, value in zip(extra[::2], extra[1::2]):
        name = {"--threshold": "threshold_px"}.get(flag, flag[2:])
        kw[name] = float(value) if name == "threshold_px" else value
    m = np.loadtxt(MATCHES)
    r = freeloc.estimate_relative_pose(m[:, :2], m[:, 2:], K_TUM, K_TUM, depth(S3, "seq0"), depth(S3, "seq1"), **kw)
    same_record(r, rec)
    assert r.metric and r.solved and r.submitted and r.ok  # ok: solved's older name
    assert r.inliers.dtype == bool and r.inliers.shape == (len(m),) and r.inliers.sum() == r.num_inliers
    assert r.as_dict()["options"] == rec["options"]
    assert np.allclose(r.R @ r.R.T, np.eye(3), atol=1e-12)


def test_pose_without_depth_is_a_unit_translation():
    m = np.loadtxt(MATCHES)
    r = freeloc.estimate_relative_pose(m[:, :2], m[:, 2:], K_TUM, K_TUM)
    rec = json.loads(cli("pose", "--matches", MATCHES, "--ref-intrinsics", K_TEXT, "--query-intrinsics", K_TEXT,
                         "--json").stdout)
    same_record(r, rec)
    assert r.status == "ok-unit-translation" and not r.metric
    assert abs(np.linalg.norm(r.t) - 1) < 1e-9


def test_unsolved_pairs_are_submitted_with_the_prior_unless_told_not_to():
    rng = np.random.default_rng(3)
    a, b = rng.uniform(0, 600, (40, 2)), rng.uniform(0, 400, (40, 2))  # unrelated points: no consensus
    r = freeloc.estimate_relative_pose(a, b, K_TUM, K_TUM)
    assert not r.solved and r.submitted and r.status in ("no-consensus", "too-few-matches")
    assert r.confidence == 0 and np.allclose(r.t, 0) and np.allclose(r.R, np.eye(3))
    assert r.as_dict()["solved"] is False and r.as_dict()["submitted"] is True
    r = freeloc.estimate_relative_pose(a, b, K_TUM, K_TUM, always_answer=0)
    assert not r.solved and not r.submitted and r.as_dict()["submitted"] is False
    with pytest.raises(AttributeError, match=r"\.solved .*\.submitted"):
        r.answered  # the old, inverted-looking name says what replaced it


def test_hybrid_solver_is_metric_and_names_its_route():
    m = np.loadtxt(MATCHES)
    r = freeloc.estimate_relative_pose(m[:, :2], m[:, 2:], K_TUM, K_TUM, depth(S3, "seq0"), depth(S3, "seq1"),
                                       solver="hybrid")
    assert r.ok and r.metric and r.route.startswith("hybrid")
    e = freeloc.estimate_relative_pose(m[:, :2], m[:, 2:], K_TUM, K_TUM, depth(S3, "seq0"), depth(S3, "seq1"))
    assert e.route == "essential"
    assert np.linalg.norm(r.t - e.t) < 0.05  # the same real pair: both metric, within centimetres


def test_arrays_of_any_layout_and_dtype_give_the_same_pose():
    m = np.loadtxt(MATCHES)
    base = freeloc.estimate_relative_pose(m[:, :2], m[:, 2:], K_TUM, K_TUM)
    wide = np.zeros((len(m), 6))
    wide[:, [0, 2]] = m[:, :2]
    wide[:, [3, 5]] = m[:, 2:]
    strided = freeloc.estimate_relative_pose(wide[:, ::2][:, :2], wide[:, 3::2], np.asfortranarray(K_TUM), K_TUM.T.T)
    assert np.array_equal(strided.t, base.t) and strided.confidence == base.confidence
    fortran = freeloc.estimate_relative_pose(np.asfortranarray(m[:, :2]), np.asfortranarray(m[:, 2:]), K_TUM, K_TUM)
    assert np.array_equal(fortran.qvec, base.qvec)
    lists = freeloc.estimate_relative_pose(m[:, :2].tolist(), m[:, 2:].tolist(), K_TUM.tolist(), K_TUM.tolist())
    assert np.array_equal(lists.t, base.t)
    # float32 input is a different problem (rounded pixels) but a valid one.
    assert freeloc.estimate_relative_pose(m[:, :2].astype(np.float32), m[:, 2:].astype(np.float32), K_TUM,
                                          K_TUM).status == "ok-unit-translation"
    # Depth as arrays equals depth as paths.
    dr, dq = freeloc.read_depth(depth(S3, "seq0")), freeloc.read_depth(depth(S3, "seq1"))
    assert dr.dtype == np.float32 and dr.shape == (480, 640) and dr.max() < 20
    a = freeloc.estimate_relative_pose(m[:, :2], m[:, 2:], K_TUM, K_TUM, dr, dq)
    b = freeloc.estimate_relative_pose(m[:, :2], m[:, 2:], K_TUM, K_TUM, depth(S3, "seq0"), depth(S3, "seq1"))
    assert np.array_equal(a.t, b.t)
    # uint16 arrays are millimetres (the PNG's values), as a cv2/PIL reader returns them.
    mm_r, mm_q = np.round(dr * 1000).astype(np.uint16), np.round(dq * 1000).astype(np.uint16)
    c = freeloc.estimate_relative_pose(m[:, :2], m[:, 2:], K_TUM, K_TUM, mm_r, mm_q)
    assert np.array_equal(c.t, b.t)
    with pytest.raises(ValueError, match="float .metres. or uint16"):
        freeloc.estimate_relative_pose(m[:, :2], m[:, 2:], K_TUM, K_TUM, mm_r.astype(np.int32), mm_q)


def relocalize_cli(scene, with_depth=True):
    args = ["relocalize", "--ref", os.path.join(scene, "seq0", "frame_00000.png"), "--query",
            os.path.join(scene, "seq1", "frame_00000.png"), "--intrinsics", os.path.join(scene, "intrinsics.txt"),
            "--json"]
    if with_depth:
        args += ["--ref-depth", depth(scene, "seq0"), "--query-depth", depth(scene, "seq1")]
    return json.loads(cli(*args).stdout)


def camera(scene, frame):
    for line in open(os.path.join(scene, "intrinsics.txt")):
        f = line.split()
        if f and f[0] == frame:
            fx, fy, cx, cy = map(float, f[1:5])
            return np.array([[fx, 0, cx], [0, fy, cy], [0, 0, 1]])
    raise KeyError(frame)


def test_relocalize_equals_cli_and_reuses_the_reference():
    reloc = freeloc.Relocalizer("sift-essential")
    for scene in (S3, S2):
        kr, kq = camera(scene, "seq0/frame_00000.png"), camera(scene, "seq1/frame_00000.png")
        ref, query = os.path.join(scene, "seq0", "frame_00000.png"), os.path.join(scene, "seq1", "frame_00000.png")
        r = reloc.relocalize(ref, query, kr, kq, depth(scene, "seq0"), depth(scene, "seq1"))
        same_record(r, relocalize_cli(scene))
        assert r.status == "ok"
        # The same reference again (as an array this time): same answer.
        from_array = reloc.relocalize(freeloc.read_image(ref), query, kr, kq, depth(scene, "seq0"), depth(scene, "seq1"))
        assert np.array_equal(from_array.t, r.t)
        strided = np.zeros((480, 640, 6), np.uint8)
        strided[:, :, ::2] = freeloc.read_image(ref)
        assert np.array_equal(reloc.relocalize(strided[:, :, ::2], query, kr, kq, depth(scene, "seq0"),
                                               depth(scene, "seq1")).t, r.t)
        # Without depth: the unit translation `freeloc relocalize` gives.
        nd = reloc.relocalize(ref, query, kr, kq)
        same_record(nd, relocalize_cli(scene, with_depth=False))
        assert nd.status == "ok-unit-translation"
    assert reloc.options["matcher"] == "sift"


def test_evaluate_and_run_equal_the_cli(tmp_path):
    sub_cli, sub_py = tmp_path / "cli.zip", tmp_path / "py.zip"
    assert cli("-q", "run", "--data", DEMO, "--out", str(sub_cli)).returncode == 0
    seen = []
    summary = freeloc.run(DEMO, str(sub_py), progress=lambda done, total: seen.append((done, total)))
    assert sub_py.read_bytes() == sub_cli.read_bytes()
    assert summary["queries"] == 7 and summary["solved"] == 2 and summary["submitted"] == 7
    assert seen[-1] == (7, 7) and len(seen) == 7
    assert summary["results"]["s00001"][0]["status"] == "no-depth"
    metrics = freeloc.evaluate(DEMO, sub_py)
    want = json.loads(cli("-q", "eval", "--data", DEMO, "--submission", str(sub_cli), "--json", "-").stdout)
    assert metrics == want
    assert freeloc.evaluate(DEMO, sub_py, scenes="s00002")["counts"]["estimates"] == 1


def test_bad_input_raises_clearly(tmp_path):
    m = np.loadtxt(MATCHES)
    with pytest.raises(ValueError, match="N x 2"):
        freeloc.estimate_relative_pose(m[:, :3], m[:, 2:], K_TUM, K_TUM)
    with pytest.raises(ValueError, match="differ in length"):
        freeloc.estimate_relative_pose(m[:10, :2], m[:, 2:], K_TUM, K_TUM)
    with pytest.raises(ValueError, match="3x3"):
        freeloc.estimate_relative_pose(m[:, :2], m[:, 2:], K_TUM[:2], K_TUM)
    with pytest.raises(ValueError, match="positive finite"):
        freeloc.estimate_relative_pose(m[:, :2], m[:, 2:], -K_TUM, K_TUM)
    bad = m[:, :2].copy()
    bad[3, 0] = np.nan
    with pytest.raises(ValueError, match="row 3 is not finite"):
        freeloc.estimate_relative_pose(bad, m[:, 2:], K_TUM, K_TUM)
    with pytest.raises(ValueError, match="colour: not an option"):
        freeloc.estimate_relative_pose(m[:, :2], m[:, 2:], K_TUM, K_TUM, colour="red")
    with pytest.raises(ValueError, match="scale: 'median' is not one of robust, official"):
        freeloc.estimate_relative_pose(m[:, :2], m[:, 2:], K_TUM, K_TUM, scale="median")
    with pytest.raises(ValueError, match="preset: 'magic' is unknown"):
        freeloc.Relocalizer("magic")
    with pytest.raises(ValueError, match="needs the DUSt3R weights"):
        freeloc.Relocalizer("dust3r", models=str(tmp_path))
    with pytest.raises(ValueError, match="only solver='pnp'"):
        freeloc.estimate_relative_pose(m[:, :2], m[:, 2:], K_TUM, K_TUM, depth(S3, "seq0"))
    with pytest.raises(freeloc.Error, match="nope.png"):
        freeloc.read_depth(tmp_path / "nope.png")
    reloc = freeloc.Relocalizer()
    with pytest.raises(ValueError, match="uint8"):
        reloc.relocalize(np.zeros((4, 4, 3), np.float32), os.path.join(S3, "seq1", "frame_00000.png"), K_TUM, K_TUM)
    (tmp_path / "junk.png").write_bytes(b"not a png")
    with pytest.raises(freeloc.Error, match="junk.png"):
        reloc.relocalize(str(tmp_path / "junk.png"), os.path.join(S3, "seq1", "frame_00000.png"), K_TUM, K_TUM)
    # Too few correspondences: a status, not an exception.
    r = freeloc.estimate_relative_pose(m[:4, :2], m[:4, 2:], K_TUM, K_TUM)
    assert r.status == "too-few-matches" and not r.ok and r.inliers.shape == (4,) and not r.inliers.any()


def _safetensors(path):
    data = open(path, "rb").read()
    n = struct.unpack("<Q", data[:8])[0]
    header = json.loads(data[8:8 + n])
    out = {}
    for name, e in header.items():
        if name == "__metadata__":
            continue
        dt = {"F32": np.float32, "U8": np.uint8, "I32": np.int32}[e["dtype"]]
        b, end = e["data_offsets"]
        out[name] = np.frombuffer(data[8 + n + b:8 + n + end], dt).reshape(e["shape"])
    return out


@pytest.mark.skipif(not os.path.exists(os.path.join(SHARED, "fixtures", "pth", "dust3r_tiny.pth")),
                    reason="tiny DUSt3R fixture absent (../shared)")
def test_dust3r_equals_freeloc_pointmap(tmp_path):
    model = os.path.join(SHARED, "fixtures", "pth", "dust3r_tiny.pth")
    a, b = os.path.join(S3, "seq0", "frame_00000.png"), os.path.join(S3, "seq1", "frame_00000.png")
    assert cli("pointmap", "--model", model, "--size", "224", a, b, "--out", str(tmp_path / "pm.safetensors"))\
        .returncode == 0
    want = _safetensors(tmp_path / "pm.safetensors")
    got = freeloc.Dust3r(model)(a, b, size=224)
    for k in ("pts3d_1", "conf_1", "pts3d_2", "conf_2", "image_1", "image_2"):
        assert got[k].shape == want[k].shape and np.array_equal(got[k], want[k]), k
    assert "desc_1" not in got


@pytest.mark.skipif(not os.path.exists(os.path.join(SHARED, "fixtures", "metric3d", "final_norm", "weights.safetensors")),
                    reason="tiny Metric3D / SegGPT fixtures absent (../shared)")
def test_metric3d_and_seggpt_equal_the_commands(tmp_path):
    """Python's Metric3D and SegGPT (through the networks module's table) give what `freeloc depth --raw` and
    `freeloc segment` write."""
    d = os.path.join(SHARED, "fixtures", "metric3d")
    model, config = os.path.join(d, "final_norm", "weights.safetensors"), os.path.join(d, "final_norm", "config.json")
    image = os.path.join(d, "images", "nyu_rgb_00000_160x120.png")
    assert cli("depth", "--model", model, "--config", config, "--image", image, "--intrinsics", "100,100,80,60",
               "--out", str(tmp_path / "d.png"), "--raw", str(tmp_path / "d.safetensors")).returncode == 0
    want = _safetensors(tmp_path / "d.safetensors")
    got = freeloc.Metric3D(model, config=config).estimate(image, np.array([[100., 0, 80], [0, 100, 60], [0, 0, 1]]))
    for k in ("depth", "confidence", "normal", "canonical_depth"):
        assert k in want, (k, list(want))
        assert got[k].shape == want[k].shape and np.array_equal(got[k], want[k]), k
    s = os.path.join(SHARED, "fixtures", "seggpt")
    sm, sc = os.path.join(s, "weights.safetensors"), os.path.join(s, "config.json")
    im = os.path.join(s, "images", "c_ensemble")
    prompt, mask, target = (os.path.join(im, f) for f in ("prompt_image_0.png", "prompt_mask_0.png", "target_image.png"))
    assert cli("segment", "--model", sm, "--config", sc, "--prompt-image", prompt, "--prompt-mask", mask, "--target",
               target, "--out", str(tmp_path / "m.png")).returncode == 0
    want_mask = freeloc.read_image(str(tmp_path / "m.png"))[:, :, 0] > 127
    got_mask = freeloc.SegGPT(sm, config=sc).segment([prompt], [mask], target)["mask"]
    assert got_mask.shape == want_mask.shape and np.array_equal(got_mask, want_mask)
    with pytest.raises(ValueError, match="type"):
        freeloc.SegGPT(sm, config=sc).segment([prompt], [mask], target, type="panoptic")


@pytest.mark.skipif(not os.path.exists(os.path.join(SHARED, "fixtures", "mast3r", "mast3r_tiny.pth")),
                    reason="tiny MASt3R fixture absent (../shared)")
def test_mast3r_descriptors_equal_freeloc_pointmap(tmp_path):
    model = os.path.join(SHARED, "fixtures", "mast3r", "mast3r_tiny.pth")
    a, b = os.path.join(S3, "seq0", "frame_00000.png"), os.path.join(S3, "seq1", "frame_00000.png")
    assert cli("pointmap", "--model", model, "--size", "224", a, b, "--out", str(tmp_path / "pm.safetensors"))\
        .returncode == 0
    want = _safetensors(tmp_path / "pm.safetensors")
    m = freeloc.Dust3r(model)
    assert m.family == "MASt3R"
    got = m(a, b, size=224)
    for k in ("pts3d_2", "desc_1", "desc_conf_1", "desc_2", "desc_conf_2"):
        assert got[k].shape == want[k].shape and np.array_equal(got[k], want[k]), k
    assert got["desc_1"].shape[2] == 8 and np.allclose(np.linalg.norm(got["desc_1"], axis=2), 1, atol=1e-5)


def test_blas_coretype_table_matches_the_cpp_one():
    """The Python copy of the OpenBLAS core-type decision gives the C++ answers on the shared cases."""
    from freeloc import _blas
    with open(os.path.join(SRC, "tests", "data", "blas", "coretype_cases.json")) as f:
        cases = json.load(f)["cases"]
    assert len(cases) >= 10
    for c in cases:
        assert _blas.choose_coretype(c["vendor"], set(c["flags"].split()), c["reported"]) == c["expect"], c["name"]


def test_blas_selection_respects_the_user_and_reports_the_kernels():
    """A user-set OPENBLAS_CORETYPE is kept; `freeloc -v` says which kernels run."""
    env = dict(os.environ, OPENBLAS_CORETYPE="Haswell")
    r = subprocess.run([sys.executable, "-c", "import freeloc, os; print(os.environ['OPENBLAS_CORETYPE'])"],
                       capture_output=True, text=True, env=env)
    assert r.returncode == 0 and r.stdout.strip() == "Haswell", r.stderr
    r = subprocess.run([BIN, "-v", "match", "--model", "none.pth", "a.png", "b.png", "--out", "x.txt"],
                       capture_output=True, text=True, env=env)
    assert "BLAS: OpenBLAS" in r.stderr and "OPENBLAS_CORETYPE=Haswell set by the user" in r.stderr, r.stderr


def _hostile_pth(path, declared_numel, record_bytes, offset, shape, stride):
    """A torch.save zip whose storage/view metadata is chosen freely (as tests/testing/pth_builder.h writes it)."""
    import zipfile

    def s(x):
        b = x.encode()
        return b"X" + struct.pack("<I", len(b)) + b

    def long8(v):
        return b"\x8a\x08" + struct.pack("<q", v)

    def ints(v):
        return b"(" + b"".join(long8(x) for x in v) + b"t"

    pkl = (b"\x80\x02}(" + s("w") + b"ctorch._utils\n_rebuild_tensor_v2\n((" + s("storage") + b"ctorch\nFloatStorage\n"
           + s("0") + s("cpu") + long8(declared_numel) + b"tQ" + long8(offset) + ints(shape) + ints(stride)
           + b"\x89ccollections\nOrderedDict\n)RtRu.")
    with zipfile.ZipFile(path, "w", zipfile.ZIP_STORED) as z:
        z.writestr("archive/data.pkl", pkl)
        z.writestr("archive/byteorder", "little")
        z.writestr("archive/data/0", bytes(record_bytes))


def test_hostile_inputs_raise_freeloc_error_never_crash(tmp_path):
    """The hostile classes through the Python API: each raises freeloc.Error (files) or ValueError (arguments)."""
    # A storage count whose byte size wraps 64 bits, with a view far into it (once a SIGSEGV).
    _hostile_pth(tmp_path / "wrap.pth", 1 << 62, 16, 1 << 40, [4], [1])
    with pytest.raises(freeloc.Error, match="wrap.pth"):
        freeloc.Dust3r(str(tmp_path / "wrap.pth"))
    _hostile_pth(tmp_path / "neg.pth", -1, 16, 0, [0], [1])
    with pytest.raises(freeloc.Error, match="declares -1 elements"):
        freeloc.Dust3r(str(tmp_path / "neg.pth"))
    _hostile_pth(tmp_path / "far.pth", 4, 16, 1 << 50, [0], [1])
    with pytest.raises(freeloc.Error, match="outside its storage"):
        freeloc.Dust3r(str(tmp_path / "far.pth"))
    # A JPEG cut after its EXIF thumbnail (an FF D9 near the end, no image data).
    thumb = b"\xff\xd8\xff\xdb\x00\x04\x00\x00\xff\xd9"
    app1 = b"\xff\xe1" + struct.pack(">H", 2 + 6 + len(thumb)) + b"Exif\x00\x00" + thumb
    (tmp_path / "cut.jpg").write_bytes(b"\xff\xd8" + app1)
    with pytest.raises(freeloc.Error, match="cut.jpg: JPEG ends before its end-of-image marker"):
        freeloc.read_image(tmp_path / "cut.jpg")
    # Intrinsics beyond the image: ValueError naming the argument.
    reloc = freeloc.Relocalizer()
    huge = np.array([[1e308, 0, 320], [0, 1e308, 240], [0, 0, 1]])
    with pytest.raises(ValueError, match="K_ref: focal length"):
        reloc.relocalize(os.path.join(S3, "seq0", "frame_00000.png"), os.path.join(S3, "seq1", "frame_00000.png"),
                         huge, K_TUM)
    # A frame name that leaves its scene.
    import shutil
    split = tmp_path / "data" / "val"
    shutil.copytree(S3, split / "s00003")
    k = (split / "s00003" / "intrinsics.txt").read_text()
    (split / "s00003" / "intrinsics.txt").write_text(k + "../s00002/seq1/frame_00000.png 535 539 320 247 640 480\n")
    with pytest.raises(freeloc.Error, match="is not a path inside the scene"):
        freeloc.run(str(tmp_path / "data"), str(tmp_path / "x.zip"))
    assert not (tmp_path / "x.zip").exists()
    # A preset whose name would become a path.
    with pytest.raises(ValueError, match="not a path"):
        freeloc.run(DEMO, str(tmp_path / "y.zip"), preset="precomputed:../../x-essential")


def test_run_with_damaged_inputs_reports_them(tmp_path):
    """As `freeloc run` exits 3 and prints them, Python warns and returns the count and the first messages."""
    import shutil
    split = tmp_path / "data" / "val"
    shutil.copytree(S3, split / "s00003")
    (split / "s00003" / "seq1" / "frame_00000.png").write_bytes(b"not a png")
    with pytest.warns(RuntimeWarning, match="1 of 1 queries failed on input errors"):
        r = freeloc.run(str(tmp_path / "data"), str(tmp_path / "x.zip"))
    assert r["input_errors"] == 1 and r["statuses"] == {"error": 1}
    assert "s00003/seq1/frame_00000.png" in r["input_error_messages"][0]
    assert (tmp_path / "x.zip").exists()
    p = cli("run", "--data", str(tmp_path / "data"), "--out", str(tmp_path / "c.zip"), check=False)
    assert p.returncode == 3 and "1 of 1 queries failed on input errors" in p.stderr


def test_weak_support_is_a_low_confidence_answer_not_the_prior():
    # 14 true TUM matches among 60: support below the chance bar but clearly above what random matches reach.
    m = np.loadtxt(MATCHES)
    weak = 0
    for seed in range(8):
        rng = np.random.default_rng(seed)
        x = np.r_[m[rng.choice(len(m), 14, replace=False)],
                  np.c_[rng.uniform(0, 640, (46, 2)), rng.uniform(0, 480, (46, 2))]]
        r = freeloc.estimate_relative_pose(x[:, :2], x[:, 2:], K_TUM, K_TUM, threshold_px=2.0)
        assert r.status in ("ok-unit-translation", "weak-support", "no-consensus"), r.status
        if r.status != "weak-support":
            continue
        weak += 1
        assert not r.solved and r.submitted and 0 < r.confidence < 1e-3
        assert abs(np.linalg.norm(r.t) - 1) < 1e-9 and r.inliers.sum() >= 10  # its own pose, not the prior
        assert r.as_dict()["status"] == "weak-support"
        s = freeloc.estimate_relative_pose(x[:, :2], x[:, 2:], K_TUM, K_TUM, threshold_px=2.0, always_answer=0)
        assert s.status == "weak-support" and not s.submitted
    assert weak >= 2


def _exif_jpeg(path, image_path, orientation=1, focal_mm=4.0, fx=520.908620, fy=521.007327, f35=None, rotate=None):
    """A TUM frame re-encoded as a JPEG with the EXIF a camera writes (Pillow), stored turned by `rotate`."""
    from PIL import Image
    from PIL.TiffImagePlugin import IFDRational
    im = Image.open(image_path).convert("RGB")
    if rotate is not None:
        im = im.transpose(rotate)
    exif = Image.Exif()
    exif[0x0112] = orientation
    sub = {}
    if focal_mm:
        swap = orientation in (5, 6, 7, 8)  # stored x is displayed y
        sub[0x920A] = IFDRational(int(focal_mm * 1000), 1000)
        sub[0xA20E] = IFDRational(int((fy if swap else fx) / focal_mm * 100000), 100000)
        sub[0xA20F] = IFDRational(int((fx if swap else fy) / focal_mm * 100000), 100000)
        sub[0xA210] = 4  # mm
    if f35:
        sub[0xA405] = f35
    exif[0x8769] = sub  # the Exif sub-IFD (Pillow writes a dict value as one)
    im.save(path, "JPEG", quality=95, exif=exif.tobytes())
    return str(path)


def test_intrinsics_are_optional_exif_then_pointmap(tmp_path):
    pytest.importorskip("PIL.Image", reason="Pillow (python3-pil) is not installed")
    from PIL import Image
    ref = _exif_jpeg(tmp_path / "ref.jpg", os.path.join(S3, "seq0", "frame_00000.png"))
    query = _exif_jpeg(tmp_path / "q.jpg", os.path.join(S3, "seq1", "frame_00000.png"))
    # read_intrinsics: the EXIF focal to 0.1 %, principal point at the centre.
    info = freeloc.read_intrinsics(ref)
    assert info["source"] == "exif" and info["width"] == 640 and info["height"] == 480
    assert abs(info["K"][0, 0] / 520.908620 - 1) < 1e-3 and abs(info["K"][1, 1] / 521.007327 - 1) < 1e-3
    assert info["K"][0, 2] == 319.5 and info["K"][1, 2] == 239.5
    # relocalize without K: the EXIF intrinsics, the same pose as the same K handed in.
    reloc = freeloc.Relocalizer("sift-essential")
    r = reloc.relocalize(ref, query, depth_ref=depth(S3, "seq0"), depth_query=depth(S3, "seq1"))
    d = r.as_dict()
    assert d["intrinsics"]["ref"]["source"] == "exif" and d["intrinsics"]["query"]["source"] == "exif"
    g = reloc.relocalize(ref, query, info["K"], info["K"], depth(S3, "seq0"), depth(S3, "seq1"))
    assert g.as_dict()["intrinsics"]["ref"]["source"] == "given"
    assert r.status == g.status == "ok"
    assert np.allclose(r.t, g.t, atol=0.01) and np.allclose(r.R, g.R, atol=1e-3)
    # A photo stored turned (orientation 6): read upright, the swap of fx/fy undone, the same pose within 0.5°.
    turned = _exif_jpeg(tmp_path / "q6.jpg", os.path.join(S3, "seq1", "frame_00000.png"), orientation=6,
                        rotate=Image.Transpose.ROTATE_90)
    info6 = freeloc.read_intrinsics(turned)
    assert info6["orientation"] == 6 and info6["width"] == 640
    assert abs(info6["K"][0, 0] / 520.908620 - 1) < 1e-3
    r6 = reloc.relocalize(ref, turned, depth_ref=depth(S3, "seq0"), depth_query=depth(S3, "seq1"))
    angle = np.degrees(np.arccos(np.clip((np.trace(r6.R @ r.R.T) - 1) / 2, -1, 1)))
    assert r6.status == "ok" and angle < 0.5 and np.linalg.norm(r6.t - r.t) < 0.02
    # The 35 mm equivalent alone: 36 mm across the long side.
    only35 = _exif_jpeg(tmp_path / "q35.jpg", os.path.join(S3, "seq1", "frame_00000.png"), focal_mm=None, f35=29)
    assert abs(freeloc.read_intrinsics(only35)["K"][0, 0] - 29 / 36 * 640) < 1e-9
    # No source: a ValueError naming the keyword (sift has no pointmap); a PNG has no EXIF.
    png = os.path.join(S3, "seq0", "frame_00000.png")
    assert freeloc.read_intrinsics(png)["source"] == "none" and freeloc.read_intrinsics(png)["K"] is None
    with pytest.raises(ValueError, match="K_ref: not given"):
        reloc.relocalize(png, query)
    with pytest.raises(ValueError, match="K_query: not given"):
        reloc.relocalize(ref, freeloc.read_image(query))  # an array carries no EXIF


def quat_to_matrix(w, x, y, z):
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def test_relocalize_window_is_the_single_frame_answer_for_one_frame_and_fuses_more():
    reloc = freeloc.Relocalizer("sift-essential")
    kr, kq = camera(S3, "seq0/frame_00000.png"), camera(S3, "seq1/frame_00000.png")
    ref, query = os.path.join(S3, "seq0", "frame_00000.png"), os.path.join(S3, "seq1", "frame_00000.png")
    single = reloc.relocalize(ref, query, kr, kq, depth(S3, "seq0"), depth(S3, "seq1"))
    one = reloc.relocalize_window(ref, [query], kr, kq, depth(S3, "seq0"), [depth(S3, "seq1")])
    assert np.array_equal(one.t, single.t) and one.status == single.status == "ok"
    # s00001: five frames of a TUM sequence (no depth), the device poses from its ground truth (frame_from_query).
    s1 = os.path.join(DEMO, "val", "s00001")
    gt = {}
    for line in open(os.path.join(s1, "poses.txt")):
        f = line.split()
        T = np.eye(4)
        T[:3, :3] = quat_to_matrix(*map(float, f[1:5]))
        T[:3, 3] = list(map(float, f[5:8]))
        gt[f[0]] = T
    names = [f"seq1/frame_{i:05d}.png" for i in range(5)]
    frames = [os.path.join(s1, n) for n in names]
    k = camera(s1, names[0])
    poses = [gt[n] @ np.linalg.inv(gt[names[-1]]) for n in names]
    r = reloc.relocalize_window(os.path.join(s1, "seq0", "frame_00000.png"), frames, k, k, device_poses=poses)
    w = r.as_dict()["window"]
    assert w["frames"] == 5 and [v["frame"] for v in w["votes"]][-1] == "frame 4"
    assert w["votes"][-1]["relation"] == "self"
    assert r.ok and w["used"] >= 2
    err = np.degrees(np.arccos(np.clip((np.trace(r.R.T @ gt[names[-1]][:3, :3]) - 1) / 2, -1, 1)))
    assert err < 2.0
    with pytest.raises(ValueError, match="device_poses"):
        reloc.relocalize_window(os.path.join(s1, "seq0", "frame_00000.png"), frames, k, k, device_poses=[np.eye(3)] * 5)
    with pytest.raises(ValueError, match="frames"):
        reloc.relocalize_window(os.path.join(s1, "seq0", "frame_00000.png"), frames * 2, k, k)


def test_evaluate_multi_frame_scores_linear_positions_9_19(tmp_path):
    # A scene whose frame numbers skip; the submission answers every frame, each with its own translation error.
    scene = tmp_path / "val" / "s00007"
    (scene / "seq1").mkdir(parents=True)
    numbers = [n for n in range(26) if n not in (4, 13)]  # 24 frames: positions 9 and 19 are frames 10 and 21
    k = "seq0/frame_00000.jpg 500 500 270 360 540 720\n"
    gt = "seq0/frame_00000.jpg 1 0 0 0 0 0 0\n"
    sub = ""
    for n in numbers:
        k += f"seq1/frame_{n:05d}.jpg 500 500 270 360 540 720\n"
        gt += f"seq1/frame_{n:05d}.jpg 1 0 0 0 0.5 0 0\n"
        sub += f"seq1/frame_{n:05d}.jpg 1 0 0 0 {0.5 + 0.01 * n} 0 0 1\n"
    (scene / "intrinsics.txt").write_text(k)
    (scene / "poses.txt").write_text(gt)
    import zipfile
    zpath = tmp_path / "sub.zip"
    with zipfile.ZipFile(zpath, "w") as z:
        z.writestr("pose_s00007.txt", sub)
    m = freeloc.evaluate(tmp_path, zpath, track="multi-frame")
    # Independently: the evaluated frames are 10 and 21 (errors 0.10 and 0.21 m), their median 0.155.
    assert m["counts"]["estimates"] == 2
    assert abs(m["Average Median Translation Error"] - 0.155) < 1e-6
    single = freeloc.evaluate(tmp_path, zpath, track="single-frame")
    assert single["counts"]["estimates"] == 5
    with pytest.raises(ValueError, match="track"):
        freeloc.evaluate(tmp_path, zpath, track="multi")


def test_plausible_inputs_refuse_the_usual_mistakes():
    """docs/formats.md "Plausible inputs" through Python: depth units, shape, intrinsics — refused with the fix."""
    ref, query = os.path.join(S3, "seq0", "frame_00000.png"), os.path.join(S3, "seq1", "frame_00000.png")
    reloc = freeloc.Relocalizer("sift-essential")
    good = reloc.relocalize(ref, query, K_TUM, K_TUM, depth(S3, "seq0"), depth(S3, "seq1"))
    assert good.status == "ok" and good.inputs == []
    mm_ref = np.round(freeloc.read_depth(depth(S3, "seq0")) * 1000).astype(np.uint16)
    mm_query = np.round(freeloc.read_depth(depth(S3, "seq1")) * 1000).astype(np.uint16)
    # Float depth in millimetres where metres are meant.
    with pytest.raises(freeloc.Error, match="divide them by 1000"):
        reloc.relocalize(ref, query, K_TUM, K_TUM, mm_ref.astype(np.float32), mm_query.astype(np.float32))
    # uint16 in centimetres: refused naming the keyword's value; with depth_unit='cm' right.
    cm_ref, cm_query = np.round(mm_ref / 10).astype(np.uint16), np.round(mm_query / 10).astype(np.uint16)
    with pytest.raises(freeloc.Error, match="set depth_unit=cm"):
        reloc.relocalize(ref, query, K_TUM, K_TUM, cm_ref, cm_query)
    cm = freeloc.Relocalizer("sift-essential", depth_unit="cm").relocalize(ref, query, K_TUM, K_TUM, cm_ref, cm_query)
    assert cm.status == "ok"
    assert np.linalg.norm(cm.t - good.t) < 0.05 * np.linalg.norm(good.t)
    # Transposed: refused; a quarter of the resolution: resampled and noted.
    with pytest.raises(freeloc.Error, match="transposed"):
        reloc.relocalize(ref, query, K_TUM, K_TUM, mm_ref, np.ascontiguousarray(mm_query.T))
    small = reloc.relocalize(ref, query, K_TUM, K_TUM, mm_ref, mm_query[1::4, 1::4])
    assert small.status == "ok" and "resampled from 160x120" in small.inputs[0]
    assert small.confidence < good.confidence
    # Normalised intrinsics, with the pose solver too.
    kn = np.array([[0.836, 0, 0.5], [0, 0.842, 0.5], [0, 0, 1]])
    with pytest.raises(freeloc.Error, match="look normalised"):
        reloc.relocalize(ref, query, kn, K_TUM, depth(S3, "seq0"), depth(S3, "seq1"))
    m = np.loadtxt(MATCHES)
    with pytest.raises(freeloc.Error, match="look normalised"):
        freeloc.estimate_relative_pose(m[:, :2], m[:, 2:], kn, K_TUM, depth(S3, "seq0"), depth(S3, "seq1"))
    with pytest.raises(freeloc.Error, match="metres stored as integers"):
        freeloc.estimate_relative_pose(m[:, :2], m[:, 2:], K_TUM, K_TUM, np.round(mm_ref / 1000).astype(np.uint16),
                                       np.round(mm_query / 1000).astype(np.uint16))


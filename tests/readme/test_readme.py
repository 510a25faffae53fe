"""The README's examples, run as a newcomer would type them.

Every fenced ``sh`` block of README.md is preceded by a marker saying how it is checked:

* ``<!-- readme-test: run -->``: each command runs exactly as written (from a scratch folder whose ``build``,
  ``data``, ``tests`` and ``bench`` are the build and the checkout's folders, and whose ``../shared`` is the shared
  data beside the checkout), must exit 0, and the output lines the README shows under a ``$ command`` must appear in
  its output, in order (``…`` stands for any text; runs of spaces compare equal). A command reading ``../shared``
  where it is absent is only checked as in ``check-args``.
* ``<!-- readme-test: check-args -->``: the examples that need downloaded weights or a dataset: each ``freeloc``
  command is run with ``--check-args`` (the command, its flags and their values are checked, nothing runs).
* ``<!-- readme-test: exists -->``: the programs and scripts the block names exist in the build or the checkout.
* ``<!-- readme-test: make -->``: the ``make`` targets the block names exist in the Makefile (``make test`` is what
  runs this file; CI and ``../shared/tools/clean-room`` run both targets on a fresh machine).

A ``python`` block marked ``run`` is run with the freeloc package on the path; a ``text`` block after it marked
``output`` holds what it prints (checked like command output). The command table's rows are checked too: every flag a
row names is in that command's ``--help``. So a flag renamed in the code but not in the README fails ``make test``.
"""
import os
import re
import shlex
import shutil
import subprocess
import sys

import pytest

SOURCE = os.environ.get("FREELOC_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", ".."))
BUILD = os.environ.get("FREELOC_BUILD_DIR", os.path.join(SOURCE, "build"))
SHARED = os.path.join(SOURCE, "..", "shared")
README = os.path.join(SOURCE, "README.md")
FREELOC = os.path.join(BUILD, "freeloc")

MARKER = re.compile(r"<!--\s*readme-test:\s*([a-z-]+)\s*-->")


def parse_blocks(text):
    """[(line number, language, mode, [lines])] of every fenced block; mode from the marker above it (or None)."""
    blocks, lines, i = [], text.split("\n"), 0
    while i < len(lines):
        m = re.match(r"^```(\w*)\s*$", lines[i])
        if not m:
            i += 1
            continue
        start, lang, j = i, m.group(1), i + 1
        while j < len(lines) and not lines[j].startswith("```"):
            j += 1
        k = start - 1
        while k >= 0 and not lines[k].strip():
            k -= 1
        marker = MARKER.search(lines[k]) if k >= 0 else None
        blocks.append((start + 1, lang, marker.group(1) if marker else None, lines[start + 1:j]))
        i = j + 1
    return blocks


def commands_of(lines):
    """[(command, [expected output lines])]: `$ ` lines with their output when the block has prompts, else every
    non-comment line; a trailing backslash continues a command."""
    prompted = any(l.startswith("$ ") for l in lines)
    out = []
    pending = ""
    for line in lines:
        if pending:
            pending += " " + line.strip()
            if not pending.endswith("\\"):
                out.append((pending, []))
                pending = ""
            else:
                pending = pending[:-1].rstrip()
            continue
        is_cmd = line.startswith("$ ") if prompted else bool(line.strip()) and not line.lstrip().startswith("#")
        if is_cmd:
            body = line[2:] if prompted else line
            if body.rstrip().endswith("\\"):
                pending = body.rstrip()[:-1].rstrip()
                continue
            out.append((body.strip(), []))
        elif prompted and out and line.strip():
            out[-1][1].append(line)
    assert not pending, "a command ends in a backslash with nothing after it"
    return out


def norm(s):
    return re.sub(r"\s+", " ", s).strip()


def check_output(expected, output):
    """Each expected line (… = any text) matches an output line, in order."""
    out_lines = [norm(l) for l in output.split("\n")]
    pos = 0
    for e in expected:
        parts = [re.escape(norm(p)) for p in e.split("…")]
        pattern = re.compile("^" + ".*".join(parts) + "$")
        for k in range(pos, len(out_lines)):
            if pattern.match(out_lines[k]):
                pos = k + 1
                break
        else:
            raise AssertionError(f"the README shows {e!r} but the output has no such line after line {pos}:\n{output}")


@pytest.fixture(scope="module")
def scratch(tmp_path_factory):
    root = tmp_path_factory.mktemp("readme")
    work = root / "work"
    work.mkdir()
    os.symlink(os.path.abspath(BUILD), work / "build")
    for d in ("data", "tests", "bench"):
        os.symlink(os.path.join(os.path.abspath(SOURCE), d), work / d)
    if os.path.isdir(SHARED):
        os.symlink(os.path.abspath(SHARED), root / "shared")
    return work


def run(cmd, cwd, env=None, timeout=600):
    e = dict(os.environ, PYTHONPATH=os.path.join(BUILD, "python"), **(env or {}))
    return subprocess.run(["bash", "-c", "set -eo pipefail; " + cmd], cwd=cwd, env=e, capture_output=True, text=True,
                          timeout=timeout)


def check_args_form(cmd):
    """The `freeloc …` part of a command line with --check-args after the program (launchers like mpirun dropped)."""
    i = cmd.find("build/freeloc ")
    if i < 0:
        return None
    rest = cmd[i + len("build/freeloc "):]
    rest = re.split(r"\s+#", rest)[0]  # a trailing comment
    return "build/freeloc --check-args " + rest


BLOCKS = parse_blocks(open(README, encoding="utf-8").read())
SH = [b for b in BLOCKS if b[1] == "sh"]


def test_every_shell_block_says_how_it_is_checked():
    unmarked = [line for line, _, mode, _ in SH if mode not in ("run", "check-args", "exists", "make")]
    assert not unmarked, \
        f"README.md lines {unmarked}: a ```sh block without <!-- readme-test: run|check-args|exists|make -->"
    assert len([b for b in SH if b[2] == "run"]) >= 3


@pytest.mark.parametrize("line,lang,mode,lines", [b for b in SH if b[2] == "run"],
                         ids=[f"README.md:{b[0]}" for b in SH if b[2] == "run"])
def test_run_block(line, lang, mode, lines, scratch):
    assert os.path.exists(FREELOC), f"{FREELOC}: build freeloc first"
    cmds = commands_of(lines)
    assert cmds, f"README.md:{line}: a run block with no command"
    for cmd, expected in cmds:
        if "../shared/" in cmd and not os.path.isdir(SHARED):
            c = check_args_form(cmd)
            r = run(c, scratch)
            assert r.returncode == 0, f"README.md:{line}: {c}\n{r.stdout}{r.stderr}"
            continue
        r = run(cmd, scratch)
        assert r.returncode == 0, f"README.md:{line}: `{cmd}` exited {r.returncode}\n{r.stdout}{r.stderr}"
        check_output(expected, r.stdout + r.stderr)


@pytest.mark.parametrize("line,lang,mode,lines", [b for b in SH if b[2] == "check-args"],
                         ids=[f"README.md:{b[0]}" for b in SH if b[2] == "check-args"])
def test_check_args_block(line, lang, mode, lines, scratch):
    checked = 0
    for cmd, _ in commands_of(lines):
        c = check_args_form(cmd)
        if c is None:
            continue
        r = run(c, scratch)
        assert r.returncode == 0, f"README.md:{line}: `{cmd}` is not a valid command line:\n{r.stdout}{r.stderr}"
        checked += 1
    assert checked, f"README.md:{line}: a check-args block with no freeloc command"


@pytest.mark.parametrize("line,lang,mode,lines", [b for b in SH if b[2] == "exists"],
                         ids=[f"README.md:{b[0]}" for b in SH if b[2] == "exists"])
def test_exists_block(line, lang, mode, lines, scratch):
    names = 0
    for cmd, _ in commands_of(lines):
        code = re.split(r"\s#", cmd)[0]
        for tok in shlex.split(code):
            if re.match(r"^(build|bench|scripts|tests)/[\w./-]+$", tok) and not tok.endswith("/"):
                assert os.path.exists(os.path.join(scratch, tok)), f"README.md:{line}: {tok} does not exist"
                names += 1
    assert names, f"README.md:{line}: an exists block naming no program"


@pytest.mark.parametrize("line,lang,mode,lines", [b for b in SH if b[2] == "make"],
                         ids=[f"README.md:{b[0]}" for b in SH if b[2] == "make"])
def test_make_block(line, lang, mode, lines):
    makefile = open(os.path.join(SOURCE, "Makefile"), encoding="utf-8").read()
    targets = 0
    for cmd, _ in commands_of(lines):
        words = re.split(r"\s#", cmd)[0].split()
        assert words[0] == "make", f"README.md:{line}: {cmd!r} is not a make command"
        for t in words[1:]:
            assert re.search(r"^" + re.escape(t) + r":", makefile, re.M), f"README.md:{line}: no make target {t}"
            targets += 1
    assert targets, f"README.md:{line}: a make block naming no target"


PY = [(i, b) for i, b in enumerate(BLOCKS) if b[1] == "python" and b[2] == "run"]


@pytest.mark.parametrize("index,block", PY, ids=[f"README.md:{b[0]}" for _, b in PY])
def test_python_block(index, block, scratch):
    if not os.path.exists(os.path.join(BUILD, "python", "freeloc")):
        pytest.skip("the Python package is not built (FREELOC_BUILD_PYTHON=OFF)")
    line, _, _, lines = block
    script = scratch / f"readme_{line}.py"
    script.write_text("\n".join(lines) + "\n")
    r = subprocess.run([sys.executable, str(script)], cwd=scratch, capture_output=True, text=True, timeout=600,
                       env=dict(os.environ, PYTHONPATH=os.path.join(BUILD, "python")))
    assert r.returncode == 0, f"README.md:{line}: the Python example failed\n{r.stdout}{r.stderr}"
    nxt = BLOCKS[index + 1] if index + 1 < len(BLOCKS) else None
    assert nxt and nxt[2] == "output", f"README.md:{line}: a run python block needs its output block after it"
    check_output([l for l in nxt[3] if l.strip()], r.stdout)


def table_rows():
    rows = []
    for n, l in enumerate(open(README, encoding="utf-8").read().split("\n"), 1):
        m = re.match(r"^\| `(?:mpirun -np N )?freeloc ([a-z]+)(.*?)` \|", l)
        if m:
            rows.append((n, m.group(1), m.group(2)))
    return rows


@pytest.mark.parametrize("line,command,synopsis", table_rows())
def test_command_table_row(line, command, synopsis):
    r = subprocess.run([FREELOC, command, "--help"], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, f"README.md:{line}: freeloc {command} is not a command\n{r.stderr}"
    g = subprocess.run([FREELOC, "--help"], capture_output=True, text=True, timeout=60).stdout
    for flag in set(re.findall(r"(?<![\w-])--[a-z][a-z0-9-]*", synopsis)):
        assert re.search(r"(?<![\w-])" + re.escape(flag) + r"(?![\w-])", r.stdout + g), \
            f"README.md:{line}: freeloc {command} has no flag {flag}"


def test_command_table_lists_every_command():
    r = subprocess.run([FREELOC, "--help"], capture_output=True, text=True, timeout=60)
    section = r.stdout.split("Subcommands:")[-1]
    commands = set(re.findall(r"^\s+([a-z]+)\s", section, re.M))
    listed = {c for _, c, _ in table_rows()}
    assert commands and commands <= listed, f"commands missing from README's table: {sorted(commands - listed)}"


def exit_code_paragraph():
    text = open(README, encoding="utf-8").read()
    start = text.index("Exit codes:")
    return text[start:text.index("\n\n", start)] if "\n\n" in text[start:] else text[start:]


S3 = "data/demo/val/s00003/"
PAIR = (f"--ref {S3}seq0/frame_00000.png --query {S3}seq1/frame_00000.png --intrinsics {S3}intrinsics.txt "
        f"--ref-depth {S3}seq0/frame_00000.sensor.png --query-depth {S3}seq1/frame_00000.sensor.png")
# Each case of the README's exit-code paragraph: (code, what the paragraph says, command line). "damaged" makes a copy
# of data/demo whose s00003 query photo is cut in half.
EXIT_CASES = [
    (0, "success", "build/freeloc --version"),
    (0, "success", f"build/freeloc relocalize {PAIR}"),
    (0, "success", "build/freeloc -q run --data data/demo --out ok.zip"),
    (1, "an input error", f"build/freeloc relocalize {PAIR.replace('frame_00000.png --intrinsics', 'nope.png --intrinsics')}"),
    (1, "an option-value error", f"build/freeloc relocalize {PAIR} --preset nosuch"),
    (1, "a query that was not solved", f"build/freeloc relocalize {PAIR.split(' --ref-depth')[0]} --preset sift-pnp"),
    (2, "an unknown flag", f"build/freeloc relocalize {PAIR} --querry x.png"),
    (2, "an unknown command", "build/freeloc relocalise"),
    (2, "a missing flag", f"build/freeloc relocalize --ref {S3}seq0/frame_00000.png"),
    (2, "a value outside a flag's own choices", f"build/freeloc relocalize {PAIR} --solver fast"),
    (2, "a value outside a flag's range", "build/freeloc run --data data/demo --out x.zip --frames 10"),
    (2, "a value outside a flag's range", "build/freeloc serve --port 70000"),
    (2, "a --set the parser refuses", f"build/freeloc relocalize {PAIR} --set threshold_px=abc"),
    (2, "a --set the parser refuses", f"build/freeloc relocalize {PAIR} --set preset=seed"),
    (2, "a --limit the parser refuses", f"build/freeloc --limit bogus=1 relocalize {PAIR}"),
    (2, "a value outside a flag's range", f"build/freeloc --threads 2147483648 relocalize {PAIR}"),
    (2, "an empty --token", "build/freeloc serve --token ''"),
    (2, "a name that would become a path", f"build/freeloc relocalize {PAIR} --depth provided:../../etc"),
    (3, "some queries failed on input errors", "build/freeloc -q run --data damaged --out damaged.zip"),
]


def test_the_exit_code_table_is_what_the_commands_return(scratch):
    """Walks the README's exit codes: every code it names has cases here, and each case exits with its code."""
    named = {int(c) for c in re.findall(r"`(\d)`", exit_code_paragraph())}
    assert named == {c for c, _, _ in EXIT_CASES}, (named, exit_code_paragraph())
    damaged = os.path.join(scratch, "damaged")
    if not os.path.isdir(damaged):
        shutil.copytree(os.path.join(SOURCE, "data", "demo"), damaged)
        photo = os.path.join(damaged, "val", "s00003", "seq1", "frame_00000.png")
        data = open(photo, "rb").read()
        open(photo, "wb").write(data[: len(data) // 2])
    bad = []
    for code, what, cmd in EXIT_CASES:
        r = run(cmd, scratch)
        if r.returncode != code:
            bad.append(f"{what}: `{cmd}` exited {r.returncode}, the README says {code}: {r.stderr.strip()[-300:]}")
        elif code != 0 and what != "a query that was not solved" and not r.stderr.strip():
            bad.append(f"{what}: `{cmd}` exited {code} with nothing on stderr")  # every error says what to do
    assert not bad, "\n".join(bad)

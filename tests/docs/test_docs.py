"""Claims of the docs that can be checked against the tree: files the docs and comments cite exist, the architecture
document has the sections comments cite, and library errors name no command-line flag."""
import os
import re

import pytest

SOURCE = os.path.abspath(os.environ.get("FREELOC_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", "..")))
CODE_DIRS = ["src", "python", "bench", "tests", "fuzz", "scripts", "cmake"]
LIBRARY_MODULES = ["core", "io", "vision", "geometry", "nn", "matching", "pipeline", "networks", "eval", "service"]


def files(dirs, exts):
    for d in dirs:
        for root, _, names in os.walk(os.path.join(SOURCE, d)):
            for n in names:
                if n.endswith(exts):
                    yield os.path.join(root, n)


def test_architecture_document_has_the_cited_sections():
    path = os.path.join(SOURCE, "docs", "architecture.md")
    assert os.path.isfile(path), "docs/architecture.md is missing"
    text = open(path, encoding="utf-8").read()
    sections = set(re.findall(r"^## (\d+)\.", text, re.M))
    assert {"1", "2", "3"} <= sections, sections
    for name in ["core", "io", "vision", "geometry", "nn", "matching", "pipeline", "networks", "eval", "cli"]:
        assert f"`{name}" in text, f"docs/architecture.md does not describe {name}/"
    # Every "docs/architecture.md §N" anywhere in the tree names a section that exists.
    for f in list(files(CODE_DIRS + ["docs"], (".cc", ".h", ".py", ".md", ".sh", ".txt"))) + [
            os.path.join(SOURCE, "README.md")]:
        for n in re.findall(r"architecture\.md §(\d+)", open(f, encoding="utf-8", errors="replace").read()):
            assert n in sections, f"{os.path.relpath(f, SOURCE)} cites docs/architecture.md §{n}, which does not exist"


def test_no_citation_of_a_file_the_repository_lacks():
    bad = []
    cited = re.compile(r"(?<![\w/.])((?:docs|bench|scripts|tests|fuzz|python|src|data)/[\w./-]*\w)")
    for f in list(files(CODE_DIRS + ["docs"], (".cc", ".h", ".py", ".md", ".sh", ".txt", ".cmake"))) + [
            os.path.join(SOURCE, "README.md"), os.path.join(SOURCE, "Makefile")]:
        if f == os.path.abspath(__file__):
            continue
        text = open(f, encoding="utf-8", errors="replace").read()
        for n, line in enumerate(text.split("\n"), 1):
            if re.search(r"\bDESIGN(\.md)?\b", line):
                bad.append(f"{os.path.relpath(f, SOURCE)}:{n}: cites DESIGN, which the repository lacks")
            for path in cited.findall(line):
                if any(ch in path for ch in "<>*{}$") or path.startswith("src/freeloc/<"):
                    continue
                p = path.rstrip(".")
                # A file named with its folder omitted for brevity is not a citation of a missing file.
                if not any(os.path.exists(os.path.join(base, p))
                           for base in (SOURCE, os.path.join(SOURCE, "src", "freeloc"), os.path.dirname(f))):
                    if p.endswith((".md", ".h", ".cc", ".py", ".sh", ".txt", ".json")):
                        bad.append(f"{os.path.relpath(f, SOURCE)}:{n}: cites {p}, which does not exist")
    assert not bad, "\n".join(bad)


def test_no_comment_or_doc_cites_a_tracker_issue():
    # Comments and docs say what and why; which tracker issue asked for it belongs in the commit message.
    bad = []
    for f in list(files(CODE_DIRS + ["docs"], (".cc", ".h", ".py", ".md", ".sh", ".txt", ".cmake"))) + [
            os.path.join(SOURCE, "README.md"), os.path.join(SOURCE, "Makefile")]:
        if f == os.path.abspath(__file__):
            continue
        for n, line in enumerate(open(f, encoding="utf-8", errors="replace").read().split("\n"), 1):
            if re.search(r"\bissues? #?\d+\b", line, re.IGNORECASE):
                bad.append(f"{os.path.relpath(f, SOURCE)}:{n}: {line.strip()[:100]}")
    assert not bad, "\n".join(bad)


def test_citations_resolve_in_a_clone():
    """Comments and docs cite files of the repository or the upstream code, never the specifications beside the
    checkout (`spec/<name>.md`): a clone has no ../shared."""
    bad = []
    for f in files(CODE_DIRS + ["docs"], (".cc", ".h", ".py", ".md", ".sh", ".txt")):
        if f == os.path.abspath(__file__):
            continue
        for n, line in enumerate(open(f, encoding="utf-8", errors="replace"), 1):
            if re.search(r"(?<![\w/.])spec/[\w-]+\.md", line):
                bad.append(f"{os.path.relpath(f, SOURCE)}:{n}: {line.strip()[:100]}")
    assert not bad, "cites a file only ../shared holds:\n" + "\n".join(bad)


FLAG = re.compile(r"(?<![\w-])--[a-z][a-z0-9-]*")
# The option registry declares each option's flag (the input limits name their environment variables).
REGISTRIES = (os.path.join("pipeline", "option_fields.cc"), os.path.join("pipeline", "run_fields.cc"),
              os.path.join("service", "service_fields.cc"), os.path.join("core", "limits.cc"))


def string_literals(code):
    """(line, text) of every string literal outside comments (plain C++ tokenizing; no raw strings in the tree)."""
    out, i, n, line = [], 0, len(code), 1
    while i < n:
        c = code[i]
        if c == "\n":
            line += 1
        if code.startswith("//", i):
            j = code.find("\n", i)
            i = n if j < 0 else j
            continue
        if code.startswith("/*", i):
            j = code.find("*/", i + 2)
            line += code.count("\n", i, j)
            i = n if j < 0 else j + 2
            continue
        if c == "'":  # a character literal, e.g. '"'
            j = i + 1
            while j < n and code[j] != "'":
                j += 2 if code[j] == "\\" else 1
            i = j + 1
            continue
        if c == '"':
            j, start = i + 1, line
            while j < n and code[j] != '"':
                j += 2 if code[j] == "\\" else 1
            out.append((start, code[i + 1:j]))
            i = j + 1
            continue
        i += 1
    return out


def test_the_literal_scanner_finds_what_it_must():
    code = 'x = 1; // "--not-this"\nFREELOC_CHECK(a, "b; c" << \'"\' << "--this");\n/* "--nor" */ y("--that");'
    found = [t for _, t in string_literals(code) if FLAG.search(t)]
    assert found == ["--this", "--that"], found


@pytest.mark.parametrize("module", LIBRARY_MODULES)
def test_library_messages_name_no_flag(module):
    """The library names option fields and inputs in its errors and logs; the CLI turns fields into flags
    (cli/common.cc), Python into keywords."""
    bad = []
    for f in files([os.path.join("src", "freeloc", module)], (".cc", ".h")):
        if f.endswith("_test.cc") or f.endswith(REGISTRIES):
            continue
        for line, lit in string_literals(open(f, encoding="utf-8").read()):
            if FLAG.search(lit):
                bad.append(f"{os.path.relpath(f, SOURCE)}:{line}: \"{lit}\"")
    assert not bad, "library messages that name a command-line flag:\n" + "\n".join(bad)


def test_python_binds_the_pipeline_not_the_networks_directly():
    """python/ reaches the networks through the networks module's table (pipeline/networks.h), never by including an
    nn/ or vision/ header (docs/architecture.md §3)."""
    offenders = []
    for folder, _, files in os.walk(os.path.join(SOURCE, "python")):
        for f in files:
            if f.endswith((".cc", ".h")):
                path = os.path.join(folder, f)
                for n, line in enumerate(open(path, encoding="utf-8"), 1):
                    if re.match(r'\s*#\s*include\s+"freeloc/(nn|vision)/', line):
                        offenders.append(f"{os.path.relpath(path, SOURCE)}:{n}: {line.strip()}")
    assert not offenders, offenders


def test_one_word_for_solved_and_submitted():
    """The words for a query's outcome are status, solved and submitted (pipeline/query_result.h) on every surface:
    the old ones — a count of "relocalized" queries, an "answered" field — are gone from the README and docs."""
    bad = []
    for f in [os.path.join(SOURCE, "README.md")] + list(files(["docs"], (".md",))):
        for n, line in enumerate(open(f, encoding="utf-8"), 1):
            if re.search(r"\bthe old\b|written before these", line):
                continue  # the one sentence that names the old word for those who used it
            if re.search(r"queries relocalized|\"relocalized\"|[`\"]answered[`\"]|\.answered\b", line):
                bad.append(f"{os.path.relpath(f, SOURCE)}:{n}: {line.strip()[:120]}")
    assert not bad, "old words for solved/submitted:\n" + "\n".join(bad)

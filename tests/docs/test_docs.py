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


# ---------------------------------------------------------------------------------------------------------------
# The house's shape (docs/architecture.md §3.2): which way includes go, and how long a function may grow.

INCLUDE = re.compile(r'#include "freeloc/([a-z_]+)/([a-z_0-9]+)\.(?:h|def)"')
# What a lower module may include besides itself (the rest of §3.2 is kept by the link dependencies).
MAY_INCLUDE = {"core": {"core"}, "geometry": {"core", "geometry"}, "pose": {"core", "geometry", "pose"},
               "inputs": {"core", "io", "geometry", "pose", "inputs"}}


def include_graph():
    """{module/stem: {module/stem included}} over the library's non-test sources (a .h and its .cc are one node)."""
    graph = {}
    for f in files([os.path.join("src", "freeloc")], (".h", ".cc", ".def")):
        if f.endswith("_test.cc"):
            continue
        parts = os.path.relpath(f, os.path.join(SOURCE, "src", "freeloc")).split(os.sep)
        if len(parts) != 2:  # module/internal/… files belong to their module's internals
            node = parts[0] + "/" + "/".join(parts[1:]).split(".")[0]
        else:
            node = parts[0] + "/" + parts[1].split(".")[0]
        for m in INCLUDE.finditer(open(f, encoding="utf-8").read()):
            target = m.group(1) + "/" + m.group(2)
            if target != node:
                graph.setdefault(node, set()).add(target)
    return graph


def test_no_include_runs_back_up():
    graph = include_graph()
    upward = [f"{n} includes {t}" for n, ts in graph.items() for t in ts
              if n.split("/")[0] in MAY_INCLUDE and t.split("/")[0] not in MAY_INCLUDE[n.split("/")[0]]]
    assert not upward, "\n".join(upward)
    # No cycle between files (Tarjan's strongly connected components).
    index, low, stack, on, cycles, counter = {}, {}, [], set(), [], [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                cycles.append(sorted(comp))

    for v in sorted(set(graph) | {t for ts in graph.values() for t in ts}):
        if v not in index:
            visit(v)
    assert not cycles, "includes that run back up (a cycle):\n" + "\n".join(" <-> ".join(c) for c in cycles)


def function_lengths(path):
    """(lines, first line, header) of each function defined at namespace or class level in a clang-formatted file."""
    text = open(path, encoding="utf-8").read().split("\n")
    code = [re.sub(r'"(\\.|[^"\\])*"', '""', re.sub(r"'(\\.|[^'\\])'", "''", re.sub(r"//.*", "", line)))
            for line in text]
    control = re.compile(r"(namespace|class|struct|enum|union|if|for|while|switch|else|do|try|catch|extern|case|"
                         r"default|template|return)\b")
    out, i = [], 0
    while i < len(text):
        stripped = code[i].strip()
        if stripped.endswith("{") and not stripped.startswith("}"):
            k = i
            while (k > 0 and len(text[k]) - len(text[k].lstrip()) > 4 and text[k - 1].strip()
                   and not code[k - 1].strip().endswith((";", "{", "}"))):
                k -= 1
            indent = len(text[k]) - len(text[k].lstrip())
            head = " ".join(c.strip() for c in code[k:i + 1])
            lambda_or_init = re.search(r"=\s*(\[[^\]]*\])?\s*(\(.*\))?\s*\{$", head) or re.search(
                r"\]\s*(\(.*\))?\s*(mutable\s*)?(->[^{]*)?\{$", head)
            if indent <= 4 and "(" in head and not control.match(head) and not lambda_or_init:
                depth, j = 0, i
                while j < len(text):
                    depth += code[j].count("{") - code[j].count("}")
                    if depth <= 0:
                        break
                    j += 1
                out.append((j - k + 1, k + 1, text[k].strip()[:80]))
                i = j
        i += 1
    return out


def test_the_function_scanner_measures_what_it_must():
    import tempfile
    with tempfile.NamedTemporaryFile("w", suffix=".cc", delete=False) as f:
        f.write("int Short(int a,\n          int b) {\n  return a;\n}\n\nvoid Long() {\n" + "  x();\n" * 200 + "}\n")
    try:
        assert sorted(n for n, _, _ in function_lengths(f.name)) == [4, 202]
    finally:
        os.remove(f.name)


def test_no_library_function_is_longer_than_150_lines():
    long = []
    for f in files([os.path.join("src", "freeloc"), os.path.join("python", "src")], (".cc",)):
        if f.endswith("_test.cc"):
            continue
        long += [f"{os.path.relpath(f, SOURCE)}:{line}: {n} lines: {head}"
                 for n, line, head in function_lengths(f) if n > 150]
    assert not long, "split these into named steps:\n" + "\n".join(long)

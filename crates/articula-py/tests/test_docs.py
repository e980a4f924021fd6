"""The Python snippets of docs/python.md and README.md run, as written, and print what their
comments say.

Each ```python block runs in order in one namespace per document (docs/python.md's blocks build
on each other), from the workspace root, so its relative paths (`models/humanoid.urdf`) resolve.
A statement whose trailing comment is a Python literal (`model.nq, model.nv   # (41, 40)`) is
checked against that value. What a snippet leaves to the reader (`Q, V, TAU = ...`) and the
sizes meant for a real cluster (Ray's workers and shards) are filled in or scaled down by
`FILLS`; each fill names the text it replaces, so a changed snippet fails here until the fill
follows it. The Ray blocks are skipped, with the reason, when Ray is not installed.
"""

import ast
import io
import os
import re
import tokenize

import pytest

from conftest import ROOT

FENCE = re.compile(r"^```python\s*$")

# (document, text in a block, replacement): placeholders given values, cluster sizes scaled
# down so that the snippet runs in seconds on two cores.
FILLS = [
    ("docs/python.md", "Q, V, TAU = ...",
     "Q = np.tile(model.rest(), (4, 1)); Q[:, 2] = 1.1; "
     "V = np.zeros((4, model.nv)); TAU = np.zeros((4, model.nv))"),
    ("docs/python.md", "ray.init()",
     "ray.init(num_cpus=2, include_dashboard=False, ignore_reinit_error=True, "
     "log_to_driver=False)"),
    ("docs/python.md", '"models/humanoid.urdf", Q0, V0, TAU,', '"models/humanoid.urdf", Q, V, TAU,'),
    ("docs/python.md", "num_workers=8", "num_workers=2"),
    ("docs/python.md", "num_shards=4, threads=8", "num_shards=2, threads=1"),
    ("docs/python.md", "scene.run(300)", "scene.run(30)"),
]


def blocks(doc):
    """The ```python blocks of `doc` as (first line number, source)."""
    out, current, start = [], None, 0
    with open(os.path.join(ROOT, doc), encoding="utf-8") as f:
        for n, line in enumerate(f, 1):
            if current is None and FENCE.match(line.strip()):
                current, start = [], n + 1
            elif current is not None and line.strip().startswith("```"):
                out.append((start, "".join(current)))
                current = None
            elif current is not None:
                current.append(line)
    return out


def filled(doc, source):
    for d, old, new in FILLS:
        if d == doc and old in source:
            source = source.replace(old, new)
    return source


def literal_comments(source):
    """{line: value} for the comments that are a Python literal (the whole comment, or the part
    before a colon: `# (n, 200, nq): the state after each step` is not one)."""
    found = {}
    for tok in tokenize.generate_tokens(io.StringIO(source).readline):
        if tok.type == tokenize.COMMENT:
            text = tok.string[1:].strip()
            try:
                found[tok.start[0]] = ast.literal_eval(text)
            except (ValueError, SyntaxError):
                pass
    return found


def run_block(doc, line, source, ns):
    """Runs `source` statement by statement in `ns`; checks each literal comment."""
    comments = literal_comments(source)
    tree = ast.parse(source)
    for stmt in tree.body:
        where = f"{doc}:{line + stmt.lineno - 1}"
        expected = comments.get(stmt.end_lineno)
        if isinstance(stmt, ast.Expr) and expected is not None:
            got = eval(compile(ast.Expression(stmt.value), where, "eval"), ns)
            if isinstance(got, tuple) and isinstance(expected, tuple):
                got = tuple(got)
            assert got == expected, f"{where}: {ast.unparse(stmt)} is {got!r}, the doc says {expected!r}"
        else:
            exec(compile(ast.Module([stmt], type_ignores=[]), where, "exec"), ns)
    return len(comments)


def test_every_fill_still_matches_its_snippet():
    for doc, old, _ in FILLS:
        assert any(old in src for _, src in blocks(doc)), \
            f"{doc} no longer shows `{old}`: update FILLS in {__file__}"


def run_document(doc, monkeypatch, skip_ray):
    monkeypatch.chdir(ROOT)
    ns, checked, ran = {}, 0, 0
    try:
        for line, source in blocks(doc):
            if "articula.ray" in source and skip_ray:
                continue
            checked += run_block(doc, line, filled(doc, source), ns)
            ran += 1
    finally:
        if "ray" in ns and hasattr(ns["ray"], "shutdown"):
            import articula.ray
            articula.ray.shutdown()
            ns["ray"].shutdown()
    return ran, checked


def test_python_md_snippets_run_and_say_what_they_print(monkeypatch):
    try:
        import ray  # noqa: F401
        skip_ray = False
    except ImportError:
        skip_ray = True
    ran, checked = run_document("docs/python.md", monkeypatch, skip_ray)
    assert ran >= 4 and checked >= 2, (ran, checked)
    if skip_ray:
        pytest.skip("Ray is not installed (pip install ray): docs/python.md's Ray blocks not run")


def test_readme_snippet_runs(monkeypatch):
    ran, _ = run_document("README.md", monkeypatch, skip_ray=True)
    assert ran == 1

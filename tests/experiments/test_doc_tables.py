"""The docs' benchmark blocks: each written by a bench script, replaced alone by ``write_table``; links resolve."""

import re
import subprocess
import sys
import types
from datetime import datetime, timezone
from importlib.metadata import version
from pathlib import Path

import pytest

from experiments.benches.harness import parser, publish
from experiments.studies import doc_tables
from experiments.studies.doc_tables import DOCS, LIBRARIES, STAMP, block_names, block_text, git_commit, write_table
from physics.errors import BeamDamageError

ROOT = Path(__file__).resolve().parents[2]
PAGES = sorted(DOCS.glob("*.md"))


def test_every_bench_block_is_written_by_a_bench_script_or_a_study():
    benches = ROOT / "experiments" / "benches"
    scripts = [*sorted(benches.glob("bench_*.py")), *sorted(benches.glob("study_*.py")),
               *sorted((ROOT / "experiments" / "studies").glob("*.py"))]
    sources = "\n".join(p.read_text() for p in scripts)
    blocks = {name: page.name for page in PAGES for name in block_names(page.read_text())}
    assert len(blocks) >= 8, blocks                      # datasets 2, discrepancy 3, classifier 3
    assert {"missing-modes-sweep", "study-beams", "debond-layered", "bolted-masses"} <= set(blocks), blocks
    orphans = sorted(f"{page}: {name}" for name, page in blocks.items() if f'"{name}"' not in sources)
    assert not orphans, f"bench blocks no bench script or study (experiments/benches, studies) writes: {orphans}"
    for page in PAGES:
        text = page.read_text()
        for name in block_names(text):
            assert text.count(f"<!-- bench:{name} -->") == 1 and text.count(f"<!-- /bench:{name} -->") == 1, \
                f"{page.name}: block {name} is not opened and closed once"


def test_write_table_replaces_only_its_block(tmp_path):
    page = tmp_path / "page.md"
    before = ("# Page\n\nIntro.\n\n<!-- bench:a -->\n| x |\n| --- |\n| 1 |\n<!-- /bench:a -->\n\nBetween.\n\n"
              "<!-- bench:b -->\n| y |\n| --- |\n| 2 |\n<!-- /bench:b -->\n\nEnd.\n")
    page.write_text(before)
    write_table(page, "a", "| x |\n| --- |\n| 3 |\n| 4 |\n")
    after = page.read_text()
    assert STAMP.sub("", after).replace("\n\n\n", "\n") == before.replace("| 1 |\n", "| 3 |\n| 4 |\n")
    write_table(page, "a", "| x |\n| --- |\n| 3 |\n| 4 |")      # same table again: same page but the stamp's day
    assert STAMP.sub("", page.read_text()) == STAMP.sub("", after)
    assert block_names(after) == ["a", "b"]
    assert block_text(after, "a") == "| x |\n| --- |\n| 3 |\n| 4 |"
    assert block_text(after, "b") == "| y |\n| --- |\n| 2 |"


def test_publish_writes_the_block_into_the_page_the_parser_names_with_docs_only(tmp_path):
    page = tmp_path / "page.md"
    page.write_text("<!-- bench:a -->\n| x |\n<!-- /bench:a -->\n")
    p = parser("bench_a.py", "A bench.", docs=str(page))
    publish(p.parse_args([]), "a", "| y |")
    assert block_text(page.read_text(), "a") == "| x |"
    args = p.parse_args(["--docs"])
    publish(args, "a", "| y |")
    assert args.docs == str(page) and block_text(page.read_text(), "a") == "| y |"


def test_a_written_block_ends_with_its_stamp_and_a_rewrite_replaces_it(tmp_path):
    page = tmp_path / "page.md"
    page.write_text("Intro.\n\n<!-- bench:a -->\n| x |\n| --- |\n| 1 |\n<!-- /bench:a -->\n\nEnd.\n")
    day = datetime.now(timezone.utc).date().isoformat()
    write_table(page, "a", "| x |\n| --- |\n| 2 |", command="python -m experiments.benches.bench_a --docs")
    if day not in page.read_text():                                # written just after midnight UTC
        day = datetime.now(timezone.utc).date().isoformat()
    commit = git_commit() + ", " + ", ".join(f"{name} {version(name)}" for name in LIBRARIES)
    first = (f"<!-- bench:a -->\n| x |\n| --- |\n| 2 |\n\nWritten by `python -m experiments.benches.bench_a --docs` "
             f"on {day} (UTC), commit {commit}.\n<!-- /bench:a -->")
    assert page.read_text() == f"Intro.\n\n{first}\n\nEnd.\n"
    # a rewrite (its content given with the old stamp, as read back from the page) keeps one stamp, the new one
    write_table(page, "a", block_text(page.read_text(), "a") + "\n\n" + STAMP.findall(page.read_text())[0],
                command="beam-damage demo --docs")
    text = page.read_text()
    assert len(STAMP.findall(text)) == 1 and text.count("Written by") == 1
    assert f"Written by `beam-damage demo --docs` on {day} (UTC), commit {commit}.\n<!-- /bench:a -->" in text
    assert block_text(text, "a") == "| x |\n| --- |\n| 2 |"


def test_git_commit_is_the_checkouts_head(tmp_path):
    head = subprocess.run(["git", "rev-parse", "--short=7", "HEAD"], cwd=ROOT, capture_output=True, text=True,
                          timeout=10)
    if head.returncode != 0:
        pytest.skip("not a git checkout")
    assert git_commit() == head.stdout.strip()
    assert git_commit(tmp_path) == "unknown"                       # no .git: unknown, no error
    (tmp_path / ".git").write_text("gitdir: nowhere\n")
    assert git_commit(tmp_path) == "unknown"


@pytest.mark.parametrize("spec, argv, command", [
    ("experiments.benches.bench_learn", ["x.py", "--docs", f"{ROOT}/out/m"],
     "python -m experiments.benches.bench_learn --docs out/m"),
    ("experiments.cli.__main__", ["x.py", "demo", "--docs"], "beam-damage demo --docs"),
    (None, ["/venv/bin/beam-damage", "demo", "--docs"], "beam-damage demo --docs"),
    (None, ["tools/run.py", "a b"], "python tools/run.py 'a b'")])
def test_the_stamp_names_the_command_as_typed(monkeypatch, spec, argv, command):
    main = types.ModuleType("__main__")
    main.__spec__ = types.SimpleNamespace(name=spec) if spec else None
    monkeypatch.setitem(sys.modules, "__main__", main)
    monkeypatch.setattr(sys, "argv", argv)
    assert doc_tables.invoking_command() == command
    assert STAMP.fullmatch(doc_tables.stamp())


@pytest.mark.parametrize("text, found", [("no markers\n", "0 opening and 0 closing"),
                                         ("<!-- bench:a -->\nonly the opening\n", "1 opening and 0 closing"),
                                         ("<!-- /bench:a -->\n<!-- bench:a -->\n", "1 opening and 1 closing")])
def test_write_table_one_line_error_without_its_markers(tmp_path, text, found):
    page = tmp_path / "page.md"
    page.write_text(text)
    with pytest.raises(BeamDamageError) as e:
        write_table(page, "a", "| x |")
    msg = str(e.value)
    assert "\n" not in msg and str(page) in msg and "<!-- bench:a -->" in msg and found in msg
    assert page.read_text() == text                               # nothing written


def test_write_table_missing_page(tmp_path):
    with pytest.raises(BeamDamageError, match="cannot read the docs page"):
        write_table(tmp_path / "absent.md", "a", "| x |")
    assert not (tmp_path / "absent.md").exists()


def test_links_between_readme_and_docs_resolve():
    broken = []
    for page in [ROOT / "README.md", *PAGES]:
        for target in re.findall(r"\]\(([^)#\s]+\.md)(?:#[^)]*)?\)", page.read_text()):
            if not (page.parent / target).is_file():
                broken.append(f"{page.name} -> {target}")
    assert not broken, broken


def test_the_stamp_names_numpy_and_scipy_and_an_older_stamp_still_reads():
    """The stamp carries the installed numpy and scipy (the same commit's numbers can differ between their versions);
    a stamp written without them is still recognised."""
    import numpy
    import scipy

    line = doc_tables.stamp("python -m x --docs")
    assert line.endswith(f", numpy {numpy.__version__}, scipy {scipy.__version__}.")
    assert STAMP.fullmatch(line)
    assert STAMP.fullmatch("Written by `python -m x --docs` on 2026-11-29 (UTC), commit 53b2bf0.")
    assert not STAMP.fullmatch("Written by `python -m x --docs` on 2026-11-29 (UTC), commit 53b2bf0, numpy 2.4.6.")

"""The docs' benchmark blocks: each written by a bench script, replaced alone by ``write_table``; links resolve."""

import re
from pathlib import Path

import pytest

from experiments.studies.doc_tables import DOCS, block_names, write_table
from physics.errors import BeamDamageError

ROOT = Path(__file__).resolve().parents[2]
PAGES = sorted(DOCS.glob("*.md"))


def test_every_bench_block_is_written_by_a_bench_script_or_a_study():
    sources = "\n".join(p.read_text() for p in [*sorted((ROOT / "experiments" / "benches").glob("bench_*.py")),
                                                 *sorted((ROOT / "experiments" / "studies").glob("*.py"))])
    blocks = {name: page.name for page in PAGES for name in block_names(page.read_text())}
    assert len(blocks) >= 8, blocks                      # datasets 2, discrepancy 3, classifier 3
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
    assert after == before.replace("| 1 |\n", "| 3 |\n| 4 |\n")
    write_table(page, "a", "| x |\n| --- |\n| 3 |\n| 4 |")      # same table again: same page
    assert page.read_text() == after
    assert block_names(after) == ["a", "b"]


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

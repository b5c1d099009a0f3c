"""A failed ``genie report-card`` leaves nothing it wrote in either of its folders: the card
folder it made is gone, the user's pages folder keeps their files and nothing else
(genie_gl/outputs.py ``OutputFolder.abandoning``). The card is rendered for real; the page's
text, written after its curves and after the card files, is made to fail."""

import pytest

from genie_gl import cli
from genie_gl.card import pages as card_pages
from genie_gl.errors import ConfigError
from tests.test_file_safety import assert_intact, plant

pytestmark = pytest.mark.gl


def test_a_failed_page_removes_the_cards_and_curves_it_wrote(tmp_path, capsys, monkeypatch):
    out, docs = tmp_path / "cards", tmp_path / "docs"
    docs.mkdir()
    planted = plant(docs)

    def fail(*_a, **_k):
        assert (out / "ideal_pinhole.card.json").is_file()  # midway: the card is written,
        assert list(docs.glob("ideal_pinhole_*.png"))  # and the page's curves
        raise ConfigError("the page failed")

    monkeypatch.setattr(card_pages, "page_markdown", fail)
    argv = ["report-card", "--sensor", "ideal_pinhole", "--quick", "--frames", "2"]
    assert cli.main([*argv, "--out", str(out), "--pages", str(docs)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1] == "genie report-card: error: the page failed"
    assert sum("error" in line for line in err) == 1
    assert not out.exists()
    assert_intact(docs, planted)
    left = sorted(p.relative_to(docs).as_posix() for p in docs.rglob("*") if p.is_file())
    assert left == sorted(planted)

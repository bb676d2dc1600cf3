"""The Python sessions of docs/python.md run as shown (doctest), so the page cannot drift from
the package."""

import doctest
import shutil

from conftest import repo


def test_the_sessions_of_docs_python_md_print_what_the_page_shows(tmp_path, monkeypatch):
    # The page's paths are the repository's; its files are written beside a copy of them.
    shutil.copytree(repo("sequences"), tmp_path / "sequences")
    monkeypatch.chdir(tmp_path)
    text = repo("docs/python.md").read_text()
    blocks = [b.split("```", 1)[0] for b in text.split("```python\n")[1:]]
    sessions = [b for b in blocks if b.startswith(">>> ")]
    assert len(sessions) >= 3, "docs/python.md shows no session"
    # One test of the whole page: later sessions use what earlier ones made.
    page = doctest.DocTestParser().get_doctest("\n".join(sessions), {}, "docs/python.md", None, 0)
    runner = doctest.DocTestRunner(optionflags=doctest.NORMALIZE_WHITESPACE | doctest.ELLIPSIS)
    runner.run(page)
    result = runner.summarize(verbose=False)
    assert result.failed == 0, f"{result.failed} of {result.attempted} examples of docs/python.md differ (above)"
    assert (tmp_path / "pan.json").exists()

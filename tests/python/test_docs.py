"""The Python sessions of docs/python.md run as shown (doctest), so the page cannot drift from
the package."""

import doctest
import shutil

import pytest

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


def test_the_readmes_python_example_runs(tmp_path, monkeypatch):
    # Its arm calibrated by LeRobot as "my_follower" (the calibration the tests use), its
    # wave.json the example sequence.
    calibrations = tmp_path / "calibration" / "robots" / "so_follower"
    calibrations.mkdir(parents=True)
    (calibrations / "my_follower.json").write_text(repo("tests/data/lerobot_so101_follower.json").read_text())
    monkeypatch.setenv("HF_LEROBOT_CALIBRATION", str(tmp_path / "calibration"))
    shutil.copy(repo("sequences/so101_wave.json"), tmp_path / "wave.json")
    monkeypatch.chdir(tmp_path)
    text = repo("README.md").read_text()
    (block,) = [b.split("```", 1)[0] for b in text.split("```python\n")[1:]]
    names = {}
    exec(compile(block, "README.md", "exec"), names)
    assert names["report"].passed
    assert names["q"].shape == (len(names["t"]), 6)
    assert names["arm"].tool(names["q_reach"]).xyz == pytest.approx((0.25, 0.0, 0.15), abs=1e-6)

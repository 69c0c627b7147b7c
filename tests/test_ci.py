"""CI runs exactly the README's two commands, and checks what the README says build writes."""

import importlib.util
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MAIN_CMD = "python -m pip install . && handarm build --out build"
TEST_CMD = 'python -m pip install ".[test]" && python -m pytest'


def _readme_commands():
    text = (ROOT / "README.md").read_text()
    block = re.search(r"```bash\n(.*?)```", text, re.S).group(1)
    return [line.strip() for line in block.strip().splitlines()]


def test_readme_starts_with_the_two_commands():
    head = "\n".join((ROOT / "README.md").read_text().splitlines()[:8])
    assert MAIN_CMD in head and TEST_CMD in head
    assert _readme_commands() == [MAIN_CMD, TEST_CMD]


def test_ci_runs_the_readme_commands_in_separate_fresh_venvs():
    ci = (ROOT / ".ci" / "run").read_text()
    for cmd in _readme_commands():
        assert cmd in ci
    # the main job runs before the test extra is installed, in another venv
    assert ci.index(MAIN_CMD) < ci.index(TEST_CMD)
    assert ci.count("fresh_venv ") >= 2
    assert "mkdocs build --strict" in ci and "pytest -m slow" in ci


def test_readme_names_everything_ci_checks_in_the_build_folder():
    spec = importlib.util.spec_from_file_location("check_build", ROOT / ".ci" / "check_build.py")
    check_build = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(check_build)
    readme = (ROOT / "README.md").read_text()
    for name, _pattern, _count in check_build.EXPECTED:
        assert f"`{name}`" in readme or name in readme, name


def test_docs_never_cite_files_outside_the_repository():
    texts = [(ROOT / "README.md").read_text()]
    texts += [p.read_text() for p in (ROOT / "docs").rglob("*.md")]
    texts += [p.read_text() for p in (ROOT / "src").rglob("*.py")]
    for text in texts:
        assert "DESIGN.md" not in text and "mx64.md" not in text
    for link in re.findall(r"\]\(((?!http)[^)#]+)", (ROOT / "README.md").read_text()):
        assert (ROOT / link).exists(), link

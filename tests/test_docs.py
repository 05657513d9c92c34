"""Every document cited by the code, the tests and the docs is inside the repository.

A citation is a path ending in ``.md`` (``docs/MATH.md``, ``README.md``, ...) in a
source file, a test, a benchmark, an example or a document; it must name a file of
the repository (relative to the root), with a ``§k`` that the document has (a
``## k.`` heading). Nothing may point outside (``../shared``).
"""

import pathlib
import re

ROOT = pathlib.Path(__file__).resolve().parents[1]
SOURCES = [
    *ROOT.glob("drake_dynid/**/*.py"),
    *ROOT.glob("tests/**/*.py"),
    *ROOT.glob("benchmarks/*.py"),
    *ROOT.glob("examples/*.py"),
    *ROOT.glob("docs/*.md"),
    ROOT / "README.md",
]
CITATION = re.compile(r"(?<![\w/.-])((?:[\w.-]+/)*[\w-]+\.md)(?:,? §\s?(\d+))?")
# Files the program writes (not documents): examples/paper_table2.py's table.
OUTPUTS = {"table2.md", "out/table2.md"}
PENDING: set[tuple[str, str]] = set()


def _sections(document: pathlib.Path) -> set[str]:
    return set(re.findall(r"^## (\d+)\.", document.read_text(), re.M))


def test_cited_documents_exist_in_the_repository():
    missing = []
    for path in SOURCES:
        text = path.read_text()
        if path.name == "test_docs.py":
            continue
        if "../shared" in text:
            missing.append(f"{path.relative_to(ROOT)}: cites ../shared")
        for match in CITATION.finditer(text):
            name, section = match.group(1), match.group(2)
            if name in OUTPUTS or (str(path.relative_to(ROOT)), name) in PENDING:
                continue
            target = ROOT / name
            if not target.is_file():
                missing.append(f"{path.relative_to(ROOT)}: {name}")
            elif section and section not in _sections(target):
                missing.append(f"{path.relative_to(ROOT)}: {name} §{section}")
    assert missing == []


FILE_CITATION = re.compile(
    r"(?<![\w/.-])((?:tests|benchmarks|examples|drake_dynid|docs|models)/"
    r"[\w./-]*[\w-]\.(?:py|urdf|toml|json|csv))"
)


def test_cited_repository_files_exist():
    """A path like ``tests/test_x.py`` or ``benchmarks/bench_y.py`` in a docstring
    or a document names a file of the repository (a review found three that did
    not)."""
    missing = []
    for path in SOURCES:
        if path.name == "test_docs.py":
            continue
        for match in FILE_CITATION.finditer(path.read_text()):
            name = match.group(1)
            if not (ROOT / name).exists() and not any(ROOT.glob(name)):
                missing.append(f"{path.relative_to(ROOT)}: {name}")
    assert missing == []

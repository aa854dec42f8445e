"""Every reproducer of ``tests/repro/`` (folders included) is named by a test, and carries
its header; no test reads anything beside the checkout (the suite stands alone).

A reproducer is a file that once showed a defect (its first lines say what went wrong
and the truth).  A file inside a folder counts as named when a test names both the folder
and the file; a folder when a test names it.
"""

import re
from pathlib import Path

TESTS = Path(__file__).resolve().parents[1]
REPRO = TESTS / "repro"
HEADER = {".toml": "#", ".py": "#", ".md": "#"}


def _test_texts():
    return {p: p.read_text(encoding="utf-8") for p in TESTS.rglob("test_*.py")
            if REPRO not in p.parents and p != Path(__file__).resolve()}


def _reproducers():
    return sorted(p for p in REPRO.rglob("*") if p.name != "README.md"
                  and "__pycache__" not in p.parts)


def test_every_reproducer_is_named_by_a_test():
    texts = _test_texts()
    missing = []
    for p in _reproducers():
        rel = p.relative_to(REPRO)
        parts = rel.parts
        if not any(all(part in text for part in parts) for text in texts.values()):
            missing.append(str(rel))
    assert not missing, f"reproducers no test names: {missing}"


def test_reproducers_keep_their_headers():
    """Each reproducer says what went wrong (a comment at the top); a folder's data files
    (JSON has no comments) are described by its sweep or problem file."""
    for p in _reproducers():
        if p.is_dir():
            assert any(q.suffix in HEADER and q.read_text().lstrip().startswith("#")
                       for q in p.iterdir()), p
            continue
        if p.suffix in HEADER:
            assert p.read_text(encoding="utf-8").lstrip().startswith(HEADER[p.suffix]), p


def test_no_test_reads_beside_the_checkout():
    """``../shared`` (or any absolute path of this machine) in a test would fail in a
    user's clone; reproducers and data are copied under tests/."""
    bad = re.compile(r"""(\.\./shared|parents\[\d\]\s*/\s*["']shared|/work/)""")
    for path, text in _test_texts().items():
        assert not bad.search(text), path
    for helper in TESTS.glob("*.py"):
        assert not bad.search(helper.read_text(encoding="utf-8")), helper

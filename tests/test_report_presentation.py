

def _notation_row(tag: str) -> str:
    """The equation cell of ``tag``'s row in docs/notation.md, read here line by line."""
    from armlab.viz.notes import DOCS

    for line in (DOCS / "notation.md").read_text(encoding="utf-8").splitlines():
        if line.startswith(f"| {tag} |"):
            return line.split(" | ")[1].strip()
    raise AssertionError(tag)


def test_the_tag_legend_defines_each_tag_from_its_source():
    from armlab.viz.tags import legend

    import armlab.theory

    rows = legend("the law (C2) settles where (T1) says, unlike T_3^0 or C2H", theory={"T1"})
    assert [(tag, source) for tag, source, _ in rows] == [("C2", "docs/notation.md"), ("T1", "armlab.theory")]
    assert rows[0][2] == _notation_row("C2").replace("`", "")
    assert "B̂(q) K_P q̃ + n̂(q, 0) = g(q)" in rows[1][2] and "B̂(q) K_P q̃" in armlab.theory.__doc__
    # Without a prediction of that tag, T1 is the notation's task-space error.
    assert legend("x̃ (T1)")[0][1:] == ("docs/notation.md", _notation_row("T1").replace("`", ""))

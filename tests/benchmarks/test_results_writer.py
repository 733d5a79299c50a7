from benchmarks.results import write_section


def test_sections_are_replaced_in_place_and_others_kept(tmp_path):
    f = tmp_path / "RESULTS.md"
    write_section("a", "first", f)
    write_section("b", "other", f)
    write_section("a", "second\n", f)
    text = f.read_text()
    assert text.count("<!-- bench:a -->") == 1 and "second" in text and "first" not in text
    assert text.index("bench:a") < text.index("bench:b") and "other" in text

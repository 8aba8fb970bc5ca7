"""docs/scenes.md is the scene catalogue generated from the assemblies' ``description:`` fields.

The test regenerates it from the scenes snakesim ships (no third-party plugins' scenes) and compares,
so a changed, added or removed scene (or picture) shows up here until the page is regenerated."""

import difflib
from pathlib import Path

from click.testing import CliRunner

from snakesim.framework.scene_catalogue import builtin_scenes_markdown, first_sentence

PAGE = Path(__file__).resolve().parents[2] / "docs" / "scenes.md"

REGENERATE = """docs/scenes.md is stale: a scene's description (or a scene, or its picture) changed.
Regenerate it and commit the result:

    snakesim scenes --markdown > docs/scenes.md

(with no third-party snakesim plugins installed). Difference, committed -> generated:
"""


def test_scenes_md_is_current():
    expected = builtin_scenes_markdown()
    actual = PAGE.read_text() if PAGE.exists() else ""
    if actual != expected:
        diff = "".join(difflib.unified_diff(actual.splitlines(True), expected.splitlines(True),
                                            "docs/scenes.md (committed)", "generated", n=1))
        raise AssertionError(REGENERATE + diff[:6000])


def test_every_shipped_scene_is_on_the_page_with_its_own_description():
    text = PAGE.read_text()
    for yaml_file in sorted((PAGE.parents[1] / "assemblies").glob("*.yaml")):
        assert f"\n### {yaml_file.stem}\n" in text, f"{yaml_file.stem} is not in docs/scenes.md"
        assert f"`snakesim run {yaml_file.stem}`" in text


def test_the_scenes_command_lists_them_and_prints_the_page():
    from snakesim.framework.cli import cli

    listing = CliRunner().invoke(cli, ["scenes"])
    assert listing.exit_code == 0, listing.output
    assert listing.output.splitlines()[0].startswith("surface-screw-traverse") and "(default)" in listing.output
    assert "pendulum" in listing.output and "Damped pendulum" in listing.output
    page = CliRunner().invoke(cli, ["scenes", "--markdown"])
    assert page.exit_code == 0 and page.output.startswith("# Scenes\n")


def test_a_first_sentence_does_not_end_at_an_abbreviation():
    assert first_sentence("The default scene (paper 4.2, figs. 13-14). EELS 1.0 lies") == \
        "The default scene (paper 4.2, figs. 13-14)"
    assert first_sentence("x" * 300).endswith("…") and len(first_sentence("x" * 300)) == 100


def test_version():
    from snakesim.framework.cli import cli

    r = CliRunner().invoke(cli, ["--version"])
    assert r.exit_code == 0 and r.output.strip().startswith("snakesim ") and r.output.split()[1][0].isdigit()

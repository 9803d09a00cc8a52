"""The generated documentation pages cover what they claim: every scene key has a description
(the comment on its dataclass field) and appears in the scenes reference; every command is in
the command-line reference."""

import pytest

from tiseg.apps import cli_reference
from tiseg.setup import reference as scene_reference
from tiseg.apps.cli import COMMAND_MODULES
from tiseg.setup.scene import SECTION_KEYS


def test_every_scene_key_is_described():
    desc = scene_reference.descriptions()
    missing = [k for k, v in desc.items() if len(v.strip()) < 8]
    assert not missing, f"scene keys without a description (comment their field): {missing}"
    assert set(desc) == {f"{s}.{k}" for s, keys in SECTION_KEYS.items() for k in keys}


def test_scenes_reference_lists_every_key_and_choice():
    page = scene_reference.markdown()
    for section, keys in SECTION_KEYS.items():
        assert f"## `[{section}]`" in page
        for key in keys:
            assert f"| `{key}` |" in page, (section, key)
    assert "`central-upwind`" in page and "`channel`" in page


@pytest.mark.parametrize("command", COMMAND_MODULES)
def test_cli_reference_has_every_command(command):
    assert f"`tiseg {command}`" in cli_reference.markdown()


def test_cli_reference_fits_the_page_and_shows_examples():
    """The site's code blocks show about 80 characters at page width: no line of the reference
    is wider than 76 (none clipped), and every command's section has its examples."""
    page = cli_reference.markdown()
    blocks = page.split("```text\n")[1:]
    assert len(blocks) > len(COMMAND_MODULES)
    wide = [line for b in blocks for line in b.split("```")[0].splitlines() if len(line) > 76]
    assert not wide, wide[:3]
    for command in COMMAND_MODULES:
        section = page.split(f"## `tiseg {command}`", 1)[1].split("\n## ", 1)[0]
        assert "\nexamples:\n  tiseg " + command in section, command
